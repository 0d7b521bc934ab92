"""What a recording keeps of a capture below its bytes (docs/mcap.md, "Below the
bytes"): a logic or USB capture's source knows things about the line that its
bytes do not say, and a recording made from it keeps them, so that reading the
recording tells them as the capture did.

- Each line's ``LineReport`` (a logic capture's: the rate measured, the format,
  the idle level, the errors and glitches counted; analyzer/physical/report.py)
  as the ``gimbalscope.lines`` metadata record: ``version`` (``"1"``), and one
  key per line (``A``, ``B`` or ``AB``) whose value is the report as a JSON
  object of its fields (``null`` where the report has no value), with its
  ``format`` (``8N1``) besides. Fields added to the report later come along;
  a reader takes the fields it knows and leaves the others.
- The line's own errors (framing, parity, break, overrun: the ``LineFault``s a
  logic capture's software UART or a USB adapter's line status tells) on the
  raw chunk holding their byte, as ``line_errors``: a list of ``{"at": the
  byte's index in the chunk's data, "problem": its id (LINE_FRAMING…),
  "detail": the problem's text after its category}``.

Nothing read back is trusted: a record that does not read is refused with why
(``ValueError``), a line error that does not read is left out.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Iterable
from typing import Any

from dissectors.problems import BY_NAME, LINE, Problem

from ..lines import LINE_A, LINE_AB, LINE_B, LineFault
from ..physical.report import LineReport, RateChange

LINES_RECORD = "gimbalscope.lines"
LINES_VERSION = "1"
_LINES = (LINE_A, LINE_B, LINE_AB)
_SWAP = {LINE_A: LINE_B, LINE_B: LINE_A}


# ------------------------------------------------------------------ line reports
def lines_record(reports: dict[str, LineReport], swapped: bool = False) -> dict[str, str]:
    """The ``gimbalscope.lines`` record of a capture's reports (line → report, as
    the source names its lines). ``swapped``: the capture reads the lines the
    other way round, and so does its recording: each report goes under the line
    its bytes are recorded on."""
    record = {"version": LINES_VERSION}
    for line, report in reports.items():
        named = _SWAP.get(line, line) if swapped else line
        values = dataclasses.asdict(report)
        values["line"] = named
        values["format"] = report.format
        record[named] = json.dumps(values, separators=(",", ":"), default=_plain)
    return record


def _plain(value: Any) -> Any:
    """A numpy scalar (the UART counts and measures with numpy) as the number it is."""
    item = getattr(value, "item", None)
    if callable(item):
        return item()
    raise TypeError(f"{type(value).__name__} is not JSON")


def reports_of(record: dict[str, str]) -> dict[str, LineReport]:
    """The line reports a ``gimbalscope.lines`` record holds; ``ValueError`` says
    why it cannot be read (a version this reader does not know included)."""
    version = record.get("version")
    if version != LINES_VERSION:
        raise ValueError("no version" if version is None else
                         f"version {version!r}, where this gimbalscope reads version {LINES_VERSION}")
    reports = {}
    for line in _LINES:
        if line in record:
            try:
                values = json.loads(record[line])
            except (ValueError, RecursionError):
                raise ValueError(f"line {line} is not JSON") from None
            reports[line] = _report(line, values)
    if not reports:
        raise ValueError("no line")
    return reports


def _report(line: str, values: Any) -> LineReport:
    if not isinstance(values, dict):
        raise ValueError(f"line {line} is not a JSON object")   # noqa: TRY004 - reports_of says all in ValueError
    report = LineReport(line, "")
    for f in dataclasses.fields(LineReport):
        if f.name == "line" or f.name not in values:
            continue   # a field written by another version stays as the report starts it
        check = _CHECKS.get(str(f.type))
        if check is None:
            continue   # a field this reader cannot check: left as it starts
        try:
            setattr(report, f.name, check(values[f.name]))
        except (TypeError, ValueError, KeyError):
            raise ValueError(f"line {line}: {f.name}={values[f.name]!r}") from None
    return report


# A value's check: the value, or TypeError or ValueError (``_report`` says which field)

def _number(v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise TypeError
    if isinstance(v, float) and not math.isfinite(v):
        raise ValueError
    return v


def _count(v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise TypeError
    if v < 0:
        raise ValueError
    return v


def _flag(v: Any) -> bool:
    if not isinstance(v, bool):
        raise TypeError
    return v


def _text(v: Any) -> str:
    if not isinstance(v, str):
        raise TypeError
    return v


def _texts(v: Any) -> list[str]:
    if not isinstance(v, list):
        raise TypeError
    return [_text(x) for x in v]


def _rate_changes(v: Any) -> list[RateChange]:
    if not isinstance(v, list):
        raise TypeError
    out = []
    for x in v:
        if not isinstance(x, dict):
            raise TypeError
        out.append(RateChange(_number(x["t"]), _number(x["before"]), _number(x["after"])))
    return out


def _or_none(check: Callable[[Any], Any]) -> Callable[[Any], Any]:
    return lambda v: None if v is None else check(v)


# each annotation of LineReport's fields, as written, and how a value of it is read
_CHECKS: dict[str, Callable[[Any], Any]] = {
    "str": _text, "float": _number, "int": _count, "bool": _flag, "list[str]": _texts,
    "list[RateChange]": _rate_changes,
    "float | None": _or_none(_number), "int | None": _or_none(_count), "str | None": _or_none(_text),
}


# ------------------------------------------------------------------ line errors
def line_error(problem: Problem, at: int) -> dict[str, Any]:
    """A raw chunk's entry of its ``line_errors`` for ``problem`` on its byte ``at``."""
    text, prefix = str(problem), problem.id.text + ": "
    entry: dict[str, Any] = {"at": at, "problem": problem.id.name}
    if text.startswith(prefix):
        entry["detail"] = text[len(prefix):]
    return entry


def faults_of(line: str, offset: int, size: int, entries: Any) -> Iterable[LineFault]:
    """The line errors of a raw chunk of ``line`` whose ``size`` bytes start at
    ``offset`` of the line, from its ``line_errors`` (those that read)."""
    if not isinstance(entries, list):
        return ()
    out = []
    for entry in entries:
        if not isinstance(entry, dict):
            continue
        at, name, detail = entry.get("at"), entry.get("problem"), entry.get("detail", "")
        info = BY_NAME.get(name) if isinstance(name, str) else None
        if info is None or info.category is not LINE or not isinstance(detail, str) \
                or isinstance(at, bool) or not isinstance(at, int) or not 0 <= at < size:
            continue
        out.append(LineFault(line, offset + at, info.problem(detail)))
    return out
