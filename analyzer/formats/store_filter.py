"""A filter over the event store's columns, with numpy: the rows of a loaded day
found in a fraction of a second, where the closure would rebuild every event
(seconds a million).

A compiled filter carries its plan (analyzer/analysis/filter_plan.py). Each node
of the plan gives two masks over the rows: those it surely selects, and those
it cannot decide from the columns (``maybe``). The closure, the ground truth,
then runs on the ``maybe`` rows only: the filter's answer is ``sure`` plus the
``maybe`` rows the closure selects. So a name the columns do not hold (a decoded
field, the payload) costs the closure only on the rows that can have it:
``kind == "result" and azimuth_deg < -10`` runs the closure on results alone.

A leaf on a column of codes (kind, status, line, command, device, the flags'
booleans) runs the leaf's own closure once per distinct value, on a stand-in
event holding that value, and picks the answers by code: its rules (types,
absent values, list members, problem prefixes) are the closure's. A leaf on a
column of numbers is numpy's comparison for a number constant; for any other
constant it is the closure's answer for a present number and for an absent one,
which the type rules make the same for every number. tests/pure/test_store_filter.py
holds the rows to the closure's over random filters.

Why numpy: the store's columns are stdlib arrays, which numpy reads without a
conversion; a comparison over ten million rows is a few milliseconds. A copy of
the rows asked for is taken first (one memcpy a column), so the store can go on
growing in another thread while a filter runs.
"""

from __future__ import annotations

from array import array
from collections.abc import Callable
from typing import Any

import numpy as np

from dissectors.event import COMMAND, NO_FIELDS, NO_PROBLEMS, RESULT, Event

from ..analysis.filter import FIELD_NAMES, TOP_LEVEL, Predicate
from ..analysis.filter_plan import AllOf, Const, Leaf, Not, Plan
from . import sweep
from .store import CHECKSUM_BAD, CHECKSUM_OK, FRAMED, KINDS, RETRANSMISSION, STATUSES, UNTIMED, EventStore
from .sweep import Cancelled

_OPS = {"==": np.equal, "!=": np.not_equal, "<": np.less, ">": np.greater, "<=": np.less_equal,
        ">=": np.greater_equal}
_DISSECTED = np.array([k in (COMMAND, RESULT) for k in KINDS])
# names a frame's header gives (raw bytes): absent on every event that is not a frame
_FRAME_NAMES = {"dst", "src", "payload"}


def _stand_in(name: str, value: Any) -> Event:
    """An event holding ``name``'s value, no fields and no problems: what a leaf's
    closure reads (a decoded field's name reads the fields, which it has none of)."""
    ev = Event("", 0, "", b"")
    if name in TOP_LEVEL:
        setattr(ev, name, value)
    return ev


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class Columns:
    """Rows ``start``..``stop`` of a store, each column copied once when first asked for."""

    def __init__(self, store: EventStore, start: int, stop: int) -> None:
        self.store, self.start, self.stop = store, start, stop
        self.n = stop - start
        self._cache: dict[str, np.ndarray] = {}

    def column(self, name: str) -> np.ndarray:
        got = self._cache.get(name)
        if got is None:
            a = self.store.column(name)[self.start:self.stop]   # a copy: the store keeps growing
            got = self._cache[name] = np.frombuffer(a, dtype=a.typecode) if len(a) else np.zeros(0, a.typecode)
        return got

    def flag(self, bit: int) -> np.ndarray:
        return (self.column("flags") & bit) != 0

    # ------------------------------------------------------------ names
    def coded(self, name: str) -> tuple[np.ndarray, list[Any]] | None:
        """(codes, the value of each code) of a name held as codes; None otherwise."""
        s = self.store
        if name == "kind":
            return self.column("kind"), list(KINDS)
        if name == "status":
            return self.column("status"), list(STATUSES)
        if name == "line":
            return self.column("line"), s.line_values
        if name == "command":
            return self.column("command"), s.command_ids
        if name == "device":
            return self.column("device"), s.device_values
        if name == "checksum_ok":
            codes = self.flag(CHECKSUM_OK).astype(np.uint8) * 2 + self.flag(CHECKSUM_BAD)
            return codes, [None, False, True]
        if name == "retransmission":
            return self.flag(RETRANSMISSION).astype(np.uint8), [False, True]
        return None

    def numeric(self, name: str) -> tuple[np.ndarray, np.ndarray] | None:
        """(present, values) of a name held as numbers; None otherwise."""
        if name == "number":
            return np.ones(self.n, bool), np.arange(self.start + 1, self.stop + 1, dtype=np.int64)
        if name == "offset":
            return np.ones(self.n, bool), self.column("offset")
        if name in ("t", "t_end"):
            return ~self.flag(UNTIMED), self.column(name)
        if name == "latency":
            v = self.column("latency")
            return ~np.isnan(v), v
        if name in ("request", "txn"):
            v = self.column(name)
            return v != 0, v.astype(np.int64) - (1 if name == "txn" else 0)
        return None

    def default_rows(self, name: str) -> np.ndarray | None:
        """Rows where ``name`` surely has the value a stand-in event gives it
        (no fields, no problems, no frame header); None: any row may differ."""
        if name == "problems":
            return None   # sparse: handled by ``sparse``
        if name == "fields" or name in FIELD_NAMES:
            # commands and results have their payload's fields; other events only kept ones
            rows = ~_DISSECTED[self.column("kind")]
            kept = [i - self.start for i in list(self.store.fields) if self.start <= i < self.stop]
            rows[kept] = False
            return rows
        if name in _FRAME_NAMES:
            return ~self.flag(FRAMED)
        return None


def _leaf(leaf: Leaf, cols: Columns) -> tuple[np.ndarray, np.ndarray]:
    """(sure, maybe) of one leaf."""
    test, op, value, negate = leaf.test, leaf.op, leaf.value, leaf.negate
    name = leaf.name.name
    n = cols.n
    plain = not leaf.name.keys   # a name, not a path into it
    if plain and (coded := cols.coded(name)) is not None:
        codes, values = coded
        table = np.array([bool(test(_stand_in(name, v))) for v in values], dtype=np.bool_)
        return table[codes], np.zeros(n, bool)
    if plain and (numeric := cols.numeric(name)) is not None:
        present, v = numeric
        absent = bool(test(_stand_in(name, None)))
        if op in _OPS and _number(value):
            hit = _OPS[op](v, value)
        elif op == "in" and isinstance(value, list):
            members = [x for x in value if _number(x)]
            hit = np.isin(v, members) if members else np.zeros(n, bool)
            if negate:
                hit = ~hit
        elif op == "truth":
            hit = v != 0
        else:   # a constant of another type: the same answer for every number (the type rules)
            hit = np.full(n, bool(test(_stand_in(name, 0))))
        return np.where(present, hit, absent), np.zeros(n, bool)
    if plain and name == "problems":
        sure = np.full(n, bool(test(_stand_in(name, NO_PROBLEMS))))
        for i, problems in list(cols.store.problems.items()):
            if cols.start <= i < cols.stop:
                sure[i - cols.start] = bool(test(_stand_in(name, problems)))
        return sure, np.zeros(n, bool)
    rows = cols.default_rows(name)
    if rows is None:
        return np.zeros(n, bool), np.ones(n, bool)
    # a path (fields.azimuth_deg, dst[2]) reads None from a stand-in, as from an event without the name
    usual = bool(test(_stand_in(name, None if name != "fields" else NO_FIELDS)))
    return (rows if usual else np.zeros(n, bool)), ~rows


def evaluate(plan: Plan | None, cols: Columns) -> tuple[np.ndarray, np.ndarray]:
    """(sure, maybe) of a plan over ``cols``: the rows it surely selects, and those
    only the closure can decide."""
    n = cols.n
    if plan is None:
        return np.zeros(n, bool), np.ones(n, bool)
    if isinstance(plan, Const):
        return np.full(n, plan.value), np.zeros(n, bool)
    if isinstance(plan, Leaf):
        return _leaf(plan, cols)
    if isinstance(plan, Not):
        sure, maybe = evaluate(plan.plan, cols)
        return ~(sure | maybe), maybe
    parts = [evaluate(p, cols) for p in plan.plans]
    if isinstance(plan, AllOf):
        sure = np.logical_and.reduce([s for s, _ in parts])
        possible = np.logical_and.reduce([s | m for s, m in parts])
        return sure, possible & ~sure
    sure = np.logical_or.reduce([s for s, _ in parts])   # AnyOf
    maybe = np.logical_or.reduce([m for _, m in parts])
    return sure, maybe & ~sure


def matching(pred: Predicate, store: EventStore, start: int, stop: int, *,
             progress: Callable[[int, int], None] | None = None,
             cancelled: Callable[[], bool] | None = None) -> array:
    """Indices ``i`` in [start, stop) whose event ``pred`` selects, ascending
    (``array('i')``): the columns decide what they can, the closure the rest
    (on rebuilt events, in steps: ``progress(done, total)`` between them, and
    Cancelled when ``cancelled()``)."""
    if stop <= start:
        return array("i")
    cols = Columns(store, start, stop)
    sure, maybe = evaluate(pred.plan, cols)
    rows = np.flatnonzero(maybe)
    if len(rows):
        total = len(rows)
        event = store.event
        step = sweep.STEP
        for a in range(0, total, step):
            if cancelled is not None and cancelled():
                raise Cancelled
            chunk = rows[a:a + step]
            picked = [r for r in chunk.tolist() if pred(event(start + r))]
            sure[picked] = True
            if progress is not None:
                progress(min(total, a + step), total)
    out = array("i")
    out.frombytes((np.flatnonzero(sure) + start).astype(np.int32).tobytes())
    return out
