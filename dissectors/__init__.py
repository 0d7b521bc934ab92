"""Protocol decoding for the gimbal serial command set, rev 1.9: frames, the
command table, field decoders. Pure: no I/O anywhere in this package."""

from .commands import BY_ID, COMMANDS, Command
from .deframer import Deframer
from .dissect import apply_command, dissect_command, dissect_result, result_fits, summarize
from .event import Event
from .wire import build_frame, checksum

__all__ = [
           "BY_ID",
           "COMMANDS",
           "Command",
           "Deframer",
           "Event",
           "apply_command",
           "build_frame",
           "checksum",
           "dissect_command",
           "dissect_result",
           "result_fits",
           "summarize",
]
