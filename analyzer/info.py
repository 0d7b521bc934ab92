"""What a capture is, said once for every writer and listener: ``CaptureInfo``.

Built from the capture when a run starts (``TapRunner``); recordings write it as
their ``gimbalscope`` metadata record, the doctor names the inputs in its advice,
the TUI names the ports. Reading a recording takes its settings back from that
record (``recorded_settings``, which analyzer/capture/recorded.py applies;
docs/time.md, "Recordings").

This module sits below the capture (docs/architecture.md, "Layers"): what it
reads of one is declared here (``DescribedCapture``), and ``Capture`` has it.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from .errors import BadMetadata
from .lines import LineFault
from .version import __version__

# what each line carries (docs/inputs.md)
LINE_ROLES = {"A": "controller→device", "B": "device→controller", "AB": "single-line tap (both directions)"}


class DescribedTimeouts(Protocol):
    """The timeouts a capture pairs with (``analyzer.analysis.pairing.Timeouts``)."""
    @property
    def ack(self) -> float: ...
    @property
    def result(self) -> float: ...
    @property
    def result_by_command(self) -> Mapping[str, float]: ...


class DescribedOptions(Protocol):
    """The options a capture decodes with (``analyzer.capture.Options``)."""
    @property
    def baud(self) -> int: ...
    @property
    def data_bits(self) -> int: ...
    @property
    def parity(self) -> str: ...
    @property
    def stop_bits(self) -> float: ...
    @property
    def timeouts(self) -> DescribedTimeouts: ...
    @property
    def swap_lines(self) -> bool: ...
    @property
    def follow_rate(self) -> bool: ...
    @property
    def frame_gap(self) -> float | None: ...
    @property
    def tz(self) -> str | None: ...


class DescribedSource(Protocol):
    """What a capture's source says of itself (``analyzer.sources.Source``)."""
    @property
    def description(self) -> str: ...
    @property
    def live(self) -> bool: ...
    @property
    def start_time(self) -> float | None: ...
    @property
    def wire_times(self) -> bool: ...
    @property
    def faults(self) -> list[LineFault] | None: ...
    @property
    def time_origin(self) -> str: ...
    @property
    def input_per_line(self) -> bool: ...
    @property
    def metadata(self) -> dict[str, str] | None: ...


class DescribedCapture(Protocol):
    """What ``CaptureInfo.of`` reads of a capture (``analyzer.capture.Capture``)."""
    @property
    def options(self) -> DescribedOptions: ...
    @property
    def source(self) -> DescribedSource: ...
    @property
    def inputs(self) -> tuple[str, ...]: ...
    @property
    def lines(self) -> tuple[str, ...]: ...
    @property
    def timed(self) -> bool: ...
    @property
    def clocks(self) -> int: ...


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
    host: str = field(default_factory=lambda: _hostname())
    # how the capture is decoded (docs/time.md): what reading its recording needs again
    clocks: int = 0                    # 0 untimed, 1 one clock, 2 a clock per line
    wire_times: bool = False           # chunk times measured on the wire (Source.wire_times)
    # the source sees the line's own errors (Source.faults: a logic or USB capture),
    # which its recording keeps on the raw chunks (docs/mcap.md, "Below the bytes")
    line_errors: bool = False
    time_origin: str = ""              # where start_time came from
    swap_lines: bool = False
    follow_rate: bool = True
    ack_timeout: float = 0.5
    result_timeout: float = 2.0
    timeouts: tuple[tuple[str, float], ...] = ()   # per command id
    frame_gap: float | None = None
    tz: str | None = None
    # one id per run, shared by every part of a recording in parts: how parts are
    # told to belong together (a recording of a recording keeps its source's)
    capture_id: str = field(default_factory=lambda: _new_id())
    input_per_line: bool = False       # each input is one line (two raw dumps, two ports)
    site: str | None = None            # where it was captured (--site; the dataset's site column)

    @classmethod
    def of(cls, capture: DescribedCapture, command: str | None = None, site: str | None = None) -> CaptureInfo:
        o = capture.options
        src = capture.source
        recorded = src.metadata or {}
        t = o.timeouts
        kw = {}
        if recorded.get("capture_id"):
            kw["capture_id"] = recorded["capture_id"]
        site = site or recorded.get("site") or None   # a recording of a recording keeps its site
        return cls(inputs=tuple(capture.inputs), lines=tuple(capture.lines), source=src.description,
                   live=bool(src.live), timed=bool(capture.timed), baud=o.baud,
                   data_bits=o.data_bits, parity=o.parity, stop_bits=o.stop_bits,
                   start_time=src.start_time, command=command, clocks=capture.clocks,
                   wire_times=src.wire_times, line_errors=src.faults is not None,
                   time_origin=src.time_origin or recorded.get("time_origin", ""),
                   swap_lines=o.swap_lines, follow_rate=o.follow_rate, ack_timeout=t.ack,
                   result_timeout=t.result, timeouts=tuple(sorted(t.result_by_command.items())),
                   frame_gap=o.frame_gap, tz=o.tz, input_per_line=src.input_per_line, site=site,
                   **kw)

    @property
    def line_names(self) -> dict[str, str]:
        """Each line's port or file as given (a socat log or a recording names both,
        and so do the parts of a recording)."""
        if len(self.inputs) == len(self.lines) and self.input_per_line:
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
            "start_time": _iso(self.start_time), "time_origin": self.time_origin or "unknown",
            "clocks": str(self.clocks), "wire_times": _yes(self.wire_times),
            "line_errors": _yes(self.line_errors), "capture_id": self.capture_id,
            "swap_lines": _yes(self.swap_lines), "follow_rate": _yes(self.follow_rate),
            "ack_timeout": f"{self.ack_timeout:g}", "result_timeout": f"{self.result_timeout:g}",
            "timeouts": ",".join(f"{cmd}={secs:g}" for cmd, secs in self.timeouts),
            "frame_gap": "default" if self.frame_gap is None else f"{self.frame_gap:g}",
        }
        if self.tz is not None:
            meta["tz"] = self.tz
        if self.site:
            meta["site"] = self.site
        if self.live:
            meta["ports"] = " ".join(self.inputs)
        meta.update(extra)
        return meta


def _hostname() -> str:
    import socket  # here: reading a capture (``analyzer.open``) needs neither module
    return socket.gethostname()


def _new_id() -> str:
    import uuid
    return uuid.uuid4().hex


def _yes(flag: bool) -> str:
    return "yes" if flag else "no"


def _iso(epoch: float | None) -> str:
    """ISO 8601 in UTC with microseconds (``datetime.fromisoformat`` reads it back)."""
    if epoch is None:
        return "unknown"
    return datetime.datetime.fromtimestamp(epoch, datetime.UTC).isoformat(timespec="microseconds")


# ---------------------------------------------------------------- reading back
def _number(meta: dict[str, str], key: str, kind: Callable[[str], float], ok: Callable[[float], bool]) -> float:
    try:
        value = kind(meta[key])
    except (TypeError, ValueError):
        raise BadMetadata(f"{key}={meta[key]!r}") from None
    # (an int is never NaN nor infinite, and may be too big for a float)
    if (isinstance(value, float) and not math.isfinite(value)) or not ok(value):
        raise BadMetadata(f"{key}={meta[key]!r}")
    return value


def _per_command(text: str) -> dict[str, float]:
    per = {}
    for item in text.split(","):
        cmd, _, secs = item.partition("=")
        try:
            value = float(secs)
        except ValueError:
            raise BadMetadata(f"timeouts={text!r}") from None
        if not cmd or not 0 < value < float("inf"):
            raise BadMetadata(f"timeouts={text!r}")
        per[cmd] = value
    return per


def recorded_settings(meta: dict[str, str]) -> dict[str, Any]:
    """The decoding settings ``meta`` holds (only those present), checked, by the
    names ``Options.settings()`` gives them: ``BadMetadata`` names the first value
    that cannot be."""
    out: dict[str, Any] = {}
    if "baud" in meta:
        out["baud"] = _number(meta, "baud", int, lambda v: v > 0)
    if "data_bits" in meta:
        out["data_bits"] = _number(meta, "data_bits", int, lambda v: v in (5, 6, 7, 8))
    if "parity" in meta:
        if meta["parity"] not in ("N", "E", "O", "M", "S"):
            raise BadMetadata(f"parity={meta['parity']!r}")
        out["parity"] = meta["parity"]
    if "stop_bits" in meta:
        out["stop_bits"] = _number(meta, "stop_bits", float, lambda v: v in (1, 1.5, 2))
    for key in ("ack_timeout", "result_timeout"):
        if key in meta:
            out[key] = _number(meta, key, float, lambda v: v > 0)
    if meta.get("frame_gap") not in (None, "default"):
        out["frame_gap"] = _number(meta, "frame_gap", float, lambda v: v > 0)
    if meta.get("timeouts"):
        out["timeouts"] = _per_command(meta["timeouts"])
    if "follow_rate" in meta:
        if meta["follow_rate"] not in ("yes", "no"):
            raise BadMetadata(f"follow_rate={meta['follow_rate']!r}")
        out["follow_rate"] = meta["follow_rate"] == "yes"
    return out
