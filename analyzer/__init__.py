"""gimbalscope analyzer: capture sources, pairing, statistics, filters, CLI.

    import analyzer
    from dissectors.event import COMMAND, OK

    for ev in analyzer.open("ctl.bin", "dev.bin"):
        if ev.kind == COMMAND and ev.status != OK:
            print(ev.number, ev.command, ev.status, ev.problems)
"""

__version__ = "0.1.0"   # before the imports: analyzer.info reads it while they load

from dissectors.event import Event

from .capture import Capture, Options, open
from .filter import FilterError
from .pairing import Pairer, Timeouts, Transaction
from .sources import CaptureError

__all__ = ["Capture", "CaptureError", "Event", "FilterError", "Options", "Pairer", "Timeouts", "Transaction", "open",
           "__version__"]
