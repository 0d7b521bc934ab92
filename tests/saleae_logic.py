"""Running the generated Saleae analyzer (analyzer/saleae) as Logic 2 would,
without Logic 2: Saleae ships no offline harness, so a stand-in ``saleae``
package (tests/saleae_standin) is put on ``sys.path`` while the module loads,
and ``Logic`` feeds it Async Serial frames (one a byte, as Logic's Async
Serial analyzer gives them) and checks what it returns as Logic would take it.

``async_serial_table`` writes the same bytes as Logic 2's Async Serial data
table export (CSV), which gimbalscope reads: the analyzer's messages are then
compared with gimbalscope's own decode of the same bytes at the same times.
"""

from __future__ import annotations

import contextlib
import csv
import importlib
import os
import re
import sys
import types
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

STANDIN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "saleae_standin")
ORIGIN = datetime(2024, 5, 1, 12, 0, 0, tzinfo=UTC)   # the capture's time 0 as a wall clock
BUBBLE_KEY = re.compile(r"\{\{\{?(type|data\.\w+)\}?\}\}")


@dataclass
class Byte:
    """One Async Serial frame: a byte of a line, its start and end (seconds), its error."""
    line: str
    start: float
    end: float
    value: int
    error: str | None = None


@contextlib.contextmanager
def saleae_standin() -> Iterator[types.SimpleNamespace]:
    """The stand-in ``saleae`` package importable, and only while inside."""
    ours = [name for name in sys.modules if name == "saleae" or name.startswith("saleae.")]
    saved = {name: sys.modules.pop(name) for name in ours}
    sys.path.insert(0, STANDIN)
    try:
        yield types.SimpleNamespace(analyzers=importlib.import_module("saleae.analyzers"),
                                    data=importlib.import_module("saleae.data"))
    finally:
        sys.path.remove(STANDIN)
        for name in [n for n in sys.modules if n == "saleae" or n.startswith("saleae.")]:
            del sys.modules[name]
        sys.modules.update(saved)


class Logic:
    """The generated analyzer module loaded over the stand-in, and run."""

    def __init__(self, source: str) -> None:
        with saleae_standin() as saleae:
            self.saleae = saleae
            self.module = types.ModuleType("gimbal_hla")
            exec(compile(source, "gimbal_hla.py", "exec"), self.module.__dict__)   # noqa: S102 - our analyzer
        self.origin = saleae.data.GraphTime(ORIGIN)

    def at(self, seconds: float) -> Any:
        return self.origin + self.saleae.data.GraphTimeDelta(second=seconds)

    def seconds(self, t: Any) -> float:
        return float(t - self.origin)

    def analyzer(self, **settings: Any) -> Any:
        """An instance, its settings given as Logic 2 gives them: on the instance before ``__init__``."""
        cls = self.module.Gimbal
        declared = {name: value for name, value in vars(cls).items()
                    if isinstance(value, self.saleae.analyzers.Setting)}
        unknown = set(settings) - set(declared)
        assert not unknown, f"no such setting {unknown}"
        hla = cls.__new__(cls)
        for name, setting in declared.items():
            value = settings.get(name, setting.default())
            setting.check(value)
            setattr(hla, name, value)
        hla.__init__()
        return hla

    def serial_frame(self, byte: Byte) -> Any:
        data: dict[str, Any] = {"data": bytes([byte.value])}
        if byte.error is not None:
            data["error"] = byte.error
        return self.saleae.analyzers.AnalyzerFrame("data", self.at(byte.start), self.at(byte.end), data)

    def run(self, byts: Iterable[Byte], **settings: Any) -> list[Any]:
        """Every frame the analyzer returns for ``byts``, each checked as Logic 2 takes it."""
        hla = self.analyzer(**settings)
        out: list[Any] = []
        for byte in byts:
            got = hla.decode(self.serial_frame(byte))
            frames = [] if got is None else got if isinstance(got, list) else [got]
            for frame in frames:
                self.check(hla, frame, out[-1] if out else None)
                out.append(frame)
        return out

    def check(self, hla: Any, frame: Any, before: Any) -> None:
        assert isinstance(frame, self.saleae.analyzers.AnalyzerFrame)
        assert frame.type in hla.result_types, frame.type
        assert float(frame.end_time - frame.start_time) >= 0
        if before is not None:   # in time order, not overlapping the one before
            assert float(frame.start_time - before.end_time) >= 0
        for key in BUBBLE_KEY.findall(hla.result_types[frame.type]["format"]):
            assert key == "type" or key[5:] in frame.data, (key, frame.data)

    def bubble(self, hla_class: Any, frame: Any) -> str:
        """The bubble text Logic 2 shows: the type's format filled."""
        fmt = hla_class.result_types[frame.type]["format"]
        return BUBBLE_KEY.sub(lambda m: frame.type if m.group(1) == "type" else str(frame.data[m.group(1)[5:]]),
                              fmt)


def back_to_back(line: str, data: bytes, start: float, char: float) -> list[Byte]:
    """``data`` on ``line`` from ``start``, each byte one character long."""
    return [Byte(line, start + k * char, start + (k + 1) * char, b) for k, b in enumerate(data)]


def async_serial_table(path: str | os.PathLike, byts: Iterable[Byte], names: dict[str, str]) -> None:
    """The bytes as Logic 2's Async Serial data table export: one analyzer per
    line (``names``: line -> the analyzer's name), hexadecimal bytes, in time order."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        out = csv.writer(f)
        out.writerow(["name", "type", "start_time", "duration", "data", "error"])
        for b in sorted(byts, key=lambda b: b.start):
            out.writerow([names[b.line], "data", repr(b.start), repr(b.end - b.start), f"0x{b.value:02X}",
                          b.error or ""])
