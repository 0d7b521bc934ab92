"""The statistics of a recording without decoding it (docs/mcap.md, "Stored
columns"): ``gimbalscope stats`` reads the figures the recorder kept of every
event (``StoredEvents.figures``), or, for a filter's events, works them out from
the stored columns in one event store (``stats_of``, the one definition the TUI
uses too). What a decoding run would say beside them is said the same way: the
capture's warnings, the wiring check's (from the wiring signs the recorder
kept), an empty capture.

Where decoding would say more than the columns know, the recording is decoded
instead: two clocks (the skew between them is estimated as it decodes) and rate
changes (following them warns as it goes)."""

from __future__ import annotations

from typing import Any

from ..analysis.filter import Predicate
from ..capture import Capture
from ..capture.stored import StoredEvents, stored_events
from ..formats.store_ipc import ColumnsError, sets_a_rate
from ..info import CaptureInfo
from ..listeners import NotePrinter
from ..listeners.wiring_check import warning_text, wiring_findings
from ..runner import RUNNER, WARNING, Note
from .common import quiet, warn


def stored_stats(capture: Capture, keep: Predicate | None, command: str = "stats") -> dict[str, Any] | None:
    """The statistics (``Stats.to_dict``) of the events ``keep`` selects, read
    from what the recording stores, with what a run says said; None when the
    capture is to be decoded."""
    stored, why = stored_events(capture)
    if why:
        warn(why)
    if stored is None or capture.clocks > 1:
        return None
    signs = stored.signs(tuple(capture.lines))
    if signs is None:
        return None
    figures = stored.figures() if keep is None else None
    if figures is None:
        figures = _worked_out(capture, stored, keep)
        if figures is None:
            return None
    info = CaptureInfo.of(capture, command=command)
    printer = NotePrinter(quiet=quiet())
    for text in capture.warnings:
        printer.on_note(Note(text, WARNING))
    for finding in wiring_findings(signs, info):
        printer.on_note(Note(warning_text(finding), WARNING, finding=finding, origin=RUNNER))
    printer.on_stop()
    if not stored.events:
        warn(f"{info.source}: no bytes in this capture")
    capture.source.close()   # a run closes it as it ends
    return figures


def _worked_out(capture: Capture, stored: StoredEvents, keep: Predicate | None) -> dict[str, Any] | None:
    """The statistics of the events ``keep`` selects, from the stored columns;
    None when they are to be decoded (a rate set, columns that do not read)."""
    import numpy as np

    from ..formats.store_filter import matching
    from ..formats.store_stats import stats_of

    try:
        store = stored.store(refuse=sets_a_rate)
    except ColumnsError as e:
        warn(f"{capture.source.description}: stored columns not read ({e}): decoding the raw bytes")
        return None
    if store is None:
        return None
    n = len(store)
    rows = None if keep is None else matching(keep, store, 0, n)
    return stats_of(store, n, None if rows is None else np.asarray(rows)).to_dict()
