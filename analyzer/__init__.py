"""gimbalscope analyzer: capture sources, pairing, statistics, filters, CLI.

    import analyzer
    from dissectors.event import COMMAND, OK

    for ev in analyzer.open("ctl.bin", "dev.bin"):
        if ev.kind == COMMAND and ev.status != OK:
            print(ev.number, ev.command, ev.status, ev.problems)
"""

from dissectors.event import Event

from .analysis.filter import FilterError
from .analysis.pairing import Pairer, Timeouts, Transaction
from .capture import Capture, Options, open
from .sources import CaptureError
from .version import __version__

__all__ = [
           "Capture",
           "CaptureError",
           "Event",
           "FilterError",
           "Options",
           "Pairer",
           "Timeouts",
           "Transaction",
           "__version__",
           "open",
]
