"""What a capture is, said once for every writer and listener: ``CaptureInfo``.

Built from the capture when a run starts (``TapRunner``); recordings write it as
their ``gimbalscope`` metadata record, the doctor names the inputs in its advice,
the TUI names the ports.
"""

from __future__ import annotations

import datetime
import socket
from dataclasses import dataclass, field

from . import __version__

# what each line carries (README, "Inputs")
LINE_ROLES = {"A": "controller→device", "B": "device→controller", "AB": "single-line tap (both directions)"}


@dataclass(frozen=True)
class CaptureInfo:
    inputs: tuple[str, ...]            # the files or ports as given
    lines: tuple[str, ...]             # ("A", "B") or ("AB",)
    source: str                        # the source's own description
    live: bool
    timed: bool
    baud: int
    data_bits: int
    parity: str
    stop_bits: float
    start_time: float | None           # epoch seconds of t = 0, when known
    command: str | None = None         # the subcommand reading it ("live", "convert", …)
    tool: str = f"gimbalscope {__version__}"
    host: str = field(default_factory=socket.gethostname)

    @classmethod
    def of(cls, capture, command: str | None = None) -> "CaptureInfo":
        o = capture.options
        src = capture.source
        return cls(inputs=tuple(capture.inputs), lines=tuple(capture.lines), source=src.description,
                   live=bool(getattr(src, "live", False)), timed=bool(capture.timed), baud=o.baud,
                   data_bits=o.data_bits, parity=o.parity, stop_bits=o.stop_bits,
                   start_time=src.start_time, command=command)

    @property
    def line_names(self) -> dict[str, str]:
        """Each line's port or file as given (a socat log or a recording names both)."""
        if len(self.inputs) == len(self.lines):
            return dict(zip(self.lines, self.inputs))
        return {line: self.source for line in self.lines}

    @property
    def serial_settings(self) -> str:
        """``9600 8N1``."""
        return f"{self.baud} {self.data_bits}{self.parity}{self.stop_bits:g}"

    def metadata(self, **extra: str) -> dict[str, str]:
        """The recording's ``gimbalscope`` metadata record (every value a string)."""
        names = self.line_names
        meta = {
            "tool": self.tool, "host": self.host, "mode": self.command or "api",
            "inputs": " ".join(self.inputs), "source": self.source, "lines": ",".join(self.lines),
            "line_roles": ", ".join(f"{line}={names[line]} ({LINE_ROLES.get(line, '?')})" for line in self.lines),
            "baud": str(self.baud), "data_bits": str(self.data_bits), "parity": self.parity,
            "stop_bits": f"{self.stop_bits:g}", "timed": "yes" if self.timed else "no",
            "start_time": _iso(self.start_time),
        }
        if self.live:
            meta["ports"] = " ".join(self.inputs)
        meta.update(extra)
        return meta


def _iso(epoch: float | None) -> str:
    """ISO 8601 in UTC with microseconds (``datetime.fromisoformat`` reads it back)."""
    if epoch is None:
        return "unknown"
    return datetime.datetime.fromtimestamp(epoch, datetime.timezone.utc).isoformat(timespec="microseconds")
