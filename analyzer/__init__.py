"""gimbalscope analyzer: capture sources, pairing, statistics, filters, CLI.

    import analyzer
    for ev in analyzer.open("ctl.bin", "dev.bin"):
        if ev.kind == "command" and ev.status != "ok":
            print(ev.number, ev.command, ev.status, ev.problems)
"""

from dissectors.event import Event

from .capture import Capture, Options, open
from .pairing import Pairer, Timeouts
from .sources import CaptureError

__version__ = "0.1.0"
__all__ = ["Capture", "CaptureError", "Event", "Options", "Pairer", "Timeouts", "open", "__version__"]
