"""Marks and notes on events (docs/tui.md, "Marks and notes"): what the engineer
marked, and wrote, while watching a capture, kept with it.

Two places keep them:

- **A recording being made** (a live tap's ``--record``, the TUI's record key)
  gets each mark as it is made, on the topic ``/marks`` (``MARKS_TOPIC``), as a
  ``foxglove.Log`` message, so that Foxglove's Log panel lists them: ``name``
  ``gimbalscope mark`` (or ``gimbalscope unmark``), ``message`` the note, ``line``
  the event's number, at the event's time. The last word on a number counts.
- **Any other capture** (a socat log, a sigrok session, a recording already
  written) gets a sidecar file beside its first input, ``NAME.marks.json``
  (``sidecar_path``), written whole after every change. It is the newest word:
  a capture with a sidecar reads its marks from there (the sidecar of a recording
  was made from a view that had read the recording's own marks).

A sidecar that does not read is said in one line, and the capture opens without
its marks; nothing else depends on them.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from ..outfile import install_text
from . import mcap_schemas as S

SIDECAR_SUFFIX = ".marks.json"
SIDECAR_VERSION = 1
MARK_NAME, UNMARK_NAME = "gimbalscope mark", "gimbalscope unmark"


class MarksError(Exception):
    """A sidecar that does not read (its path and why in the message)."""


@dataclass(frozen=True)
class Mark:
    """Event ``number`` marked, with its ``note`` ("" for none); ``t``: the event's
    time (None: untimed). ``removed``: the mark taken off (a recording's log)."""
    number: int
    note: str = ""
    t: float | None = None
    removed: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {"number": self.number, "t": self.t, "note": self.note}


def sidecar_path(inputs: Sequence[str]) -> str:
    """Where a capture's marks are kept when it is not a recording being made."""
    return inputs[0] + SIDECAR_SUFFIX


def read_marks(inputs: Sequence[str]) -> list[Mark]:
    """The capture's marks, by number: its sidecar's, else its recordings' ``/marks``."""
    path = sidecar_path(inputs)
    if os.path.exists(path):
        return read_sidecar(path)
    found: dict[int, Mark] = {}
    for name in inputs:
        if name.lower().endswith(".mcap") and os.path.isfile(name):
            for mark in recorded_marks(name):
                if mark.removed:
                    found.pop(mark.number, None)
                else:
                    found[mark.number] = mark
    return sorted(found.values(), key=lambda m: m.number)


def notes_of(inputs: Sequence[str]) -> dict[int, str]:
    """The capture's marks as ``read_marks`` finds them: event number -> note ("": none)."""
    return {m.number: m.note for m in read_marks(inputs)}


def marked_text(note: str) -> str:
    """How a marked event says so under it, in ``decode``'s text and the TUI's detail: ``★ marked: note``."""
    return f"★ marked: {note}" if note else "★ marked"


def read_sidecar(path: str) -> list[Mark]:
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        marks = [Mark(int(m["number"]), str(m.get("note") or ""), None if m.get("t") is None else float(m["t"]))
                 for m in data["marks"]]
    except OSError as e:
        raise MarksError(f"{path}: cannot read the marks ({e.strerror})") from None
    except (ValueError, KeyError, TypeError) as e:
        raise MarksError(f"{path}: not a marks file ({type(e).__name__}: {e})") from None
    return sorted({m.number: m for m in marks}.values(), key=lambda m: m.number)


def write_sidecar(inputs: Sequence[str], marks: Iterable[Mark]) -> str:
    """Every mark of the capture into its sidecar (replaced whole); its path. Raises OSError."""
    path = sidecar_path(inputs)
    data = {"version": SIDECAR_VERSION, "capture": list(inputs),
            "marks": [m.to_dict() for m in sorted(marks, key=lambda m: m.number)]}
    install_text(path, json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    return path


def recorded_marks(path: str) -> list[Mark]:
    """The ``/marks`` messages of a recording, in the order they were made (a
    recording that does not read has none: its own reader says why)."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    out: list[Mark] = []
    try:
        with open(path, "rb") as f:
            for _schema, _channel, message in make_reader(f).iter_messages(topics=[S.MARKS_TOPIC]):
                log = json.loads(message.data)
                out.append(Mark(int(log["line"]), str(log.get("message", "")), None,
                                log.get("name") == UNMARK_NAME))
    except (OSError, McapError, ValueError, KeyError, TypeError):
        pass   # the marks read before it stand
    return out
