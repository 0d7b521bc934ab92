"""Capture statistics for ``gimbalscope stats``: counts, errors and latency per
command and per device. Memory is flat: latencies go into log-spaced buckets
(1% wide), so medians and 95th percentiles are accurate to about 1%; minimum and
maximum are exact.

Errors have one source of truth, the events' problems: ``problems`` counts events
per problem category, and ``checksum_errors`` is the events with a checksum
problem (``bad checksum`` or ``bad length byte``). Some of those are not frames:
the bytes of a frame broken beyond reading (a good frame starts inside it) are a
noise event with a ``bad checksum`` problem, so ``broken_frames`` says how many,
and ``noise`` breaks its events down the same way.

One definition, two drivers. The figures are worked out in one place,
``Stats.add_columns``, over a batch of events given as columns (``EventColumns``:
an array a property, with numpy). Columns because the TUI's store holds a day as
columns (analyzer/formats/store.py), and rebuilding a million events to count them
one by one would take seconds where the arrays take a fraction of one. Events as
they come (``Stats.add`` and ``add_events``: ``gimbalscope stats``, a live tap, a
script) wait in a list until there are ``BATCH`` of them, then are turned into the
same columns (``EventColumns.of``) and counted, so numpy's cost a call is spread
over thousands of events; the TUI's store hands its columns over as one batch
(analyzer/formats/store_stats.py). Each batch is counted straight into the running
figures, and every figure adds up across batches (counts and latency buckets
add, the first time is the first batch's, the last the last's), so a capture
counted in batches of any size has the same statistics as counted whole
(tests/pure/test_store_stats.py). Reading a figure (an attribute or
``to_dict()``) counts the waiting events first (``flush``): it is always of
every event added.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from operator import attrgetter
from typing import Any, Generic, TypeVar, overload

import numpy as np

from dissectors.event import (
    ACK,
    COMMAND,
    NAK,
    NIC,
    NO_ACK,
    NO_RESULT,
    NOISE,
    P_CHECKSUM,
    P_LENGTH,
    P_NOISE,
    PENDING,
    RATE,
    RESULT,
    STATUSES,
    Event,
)
from dissectors.problems import Problem

_LOG_STEP = math.log(1.01)
_VECTOR_FROM = 64   # samples from which ``Latency.extend`` buckets with numpy
CHECKSUM_CATEGORIES = frozenset((P_CHECKSUM, P_LENGTH))   # what ``Stats.checksum_errors`` counts
KIND_ORDER = (COMMAND, ACK, NAK, NIC, RESULT, NOISE)   # the order reports list kinds in
BATCH = 2048   # events counted at a time by ``Stats.add``: numpy's cost a call spread over them


def categories(ev: Event) -> list[str]:
    """The event's problem categories, each once, in order."""
    return problem_categories(ev.problems)


def problem_categories(problems: Iterable[Problem | str]) -> list[str]:
    """The categories of a list of problems, each once, in order."""
    out: list[str] = []
    for p in problems:
        # a plain string (an event built by hand) carries no id: its text names the category
        cat = p.id.text if isinstance(p, Problem) else p.split(":", 1)[0]
        if cat not in out:
            out.append(cat)
    return out


def checksum_problem(ev: Event) -> bool:
    """Does the event have a checksum problem (``Stats.checksum_errors`` counts it)?"""
    return any(cat in CHECKSUM_CATEGORIES for cat in categories(ev))


def bucket_middle(bucket: int) -> float:
    """The latency in the middle of a ``Latency`` bucket (its samples' stand-in)."""
    return math.exp((bucket + 0.5) * _LOG_STEP)


class Latency:
    __slots__ = ("buckets", "max", "min", "n", "zero")

    def __init__(self) -> None:
        self.n = 0
        self.min = math.inf
        self.max = -math.inf
        self.buckets: Counter[int] = Counter()
        self.zero = 0  # samples <= 0 (clock skew or back-to-back bytes)

    def add(self, x: float) -> None:
        self.n += 1
        self.min = min(self.min, x)
        self.max = max(self.max, x)
        if x <= 1e-9:
            self.zero += 1
        else:
            self.buckets[math.floor(math.log(x) / _LOG_STEP)] += 1

    def extend(self, xs: Iterable[float]) -> None:
        """Add the samples ``xs``, as ``add`` adds each. Many at once are bucketed
        with numpy, whose log is a last digit off math's now and then: the samples
        that fall that near a bucket's edge are bucketed again with math's."""
        values = np.asarray(xs if isinstance(xs, np.ndarray) else list(xs), dtype="f8")
        if len(values) < _VECTOR_FROM or np.isnan(values).any():
            add = self.add
            for x in values.tolist():
                add(x)
            return
        self.n += len(values)
        self.min = min(self.min, float(values.min()))
        self.max = max(self.max, float(values.max()))
        positive = values[values > 1e-9]
        self.zero += len(values) - len(positive)
        scaled = np.log(positive) / _LOG_STEP
        buckets = np.floor(scaled)
        for i in np.flatnonzero(np.abs(scaled - np.rint(scaled)) < 1e-6).tolist():
            buckets[i] = math.floor(math.log(float(positive[i])) / _LOG_STEP)
        found, counts = np.unique(buckets.astype("i8"), return_counts=True)
        self.buckets.update(dict(zip(found.tolist(), counts.tolist(), strict=True)))

    def quantile(self, q: float) -> float | None:
        """Nearest-rank quantile: the ceil(q·n)-th smallest sample (to bucket precision)."""
        if not self.n:
            return None
        rank = max(1, math.ceil(q * self.n))
        if rank <= self.zero:
            return min(self.min, 0.0)
        seen = self.zero
        for b in sorted(self.buckets):
            seen += self.buckets[b]
            if seen >= rank:
                return min(max(bucket_middle(b), self.min), self.max)
        return self.max

    def to_dict(self) -> dict[str, Any]:
        if not self.n:
            return {"count": 0, "min": None, "median": None, "p95": None, "max": None}
        return {"count": self.n, "min": self.min, "median": self.quantile(0.5),
                "p95": self.quantile(0.95), "max": self.max}


# The columns of the per-command and per-device tables, named as Counts.to_dict()
# names them, in ``stats`` and the TUI's statistics screen alike (and in the fleet
# report where it shows the same: analyzer/dataset/report.py). In groups kept side
# by side when a table is split to fit the terminal.
COUNT_COLUMNS = (("commands", *STATUSES), ("retransmissions", "checksum_errors"))
# latencies: (the column's name, the key of Counts.to_dict() and of its latency)
LATENCY_COLUMNS = (
    (("ACK min", "ack_latency", "min"), ("ACK median", "ack_latency", "median"),
     ("ACK p95", "ack_latency", "p95"), ("ACK max", "ack_latency", "max")),
    (("result median", "result_latency", "median"), ("result max", "result_latency", "max")),
)


class Counts:
    """What is counted per command id and per device."""
    __slots__ = (
        "ack_latency",
        "checksum_errors",
        "commands",
        "result_latency",
        "retransmissions",
        "status",
    )

    def __init__(self) -> None:
        self.commands = 0
        self.status: Counter[str] = Counter()
        self.retransmissions = 0
        self.checksum_errors = 0
        self.ack_latency = Latency()
        self.result_latency = Latency()

    def to_dict(self) -> dict[str, Any]:
        return {
            "commands": self.commands,
            **{s: self.status.get(s, 0) for s in STATUSES},
            "retransmissions": self.retransmissions,
            "checksum_errors": self.checksum_errors,
            "ack_latency": self.ack_latency.to_dict(),
            "result_latency": self.result_latency.to_dict(),
        }


# ------------------------------------------------------------------ columns
@dataclass(frozen=True, slots=True)
class Coded:
    """A column of values that repeat, as small codes: row k's value is
    ``values[codes[k]]`` (several codes may have the same value)."""
    codes: np.ndarray
    values: Sequence[Any]

    @classmethod
    def of(cls, values: Sequence[Any]) -> Coded:
        """``values`` coded in the order they first appear."""
        index = {v: i for i, v in enumerate(dict.fromkeys(values))}
        return cls(np.fromiter(map(index.__getitem__, values), np.intp, len(values)), list(index))

    def among(self, *wanted: Any) -> np.ndarray:
        """Rows whose value is one of ``wanted``."""
        return np.array([v in wanted for v in self.values], dtype=bool)[self.codes]


def rate_change(ev: Event) -> dict[str, Any]:
    """A rate-change event as ``Stats.rate_changes`` lists it (docs/time.md)."""
    return {"number": ev.number, "t": ev.t, "request": ev.request, **ev.fields}


@dataclass(frozen=True, slots=True)
class EventColumns:
    """A batch of events as the statistics read them: row k is the batch's k-th
    event, in wire order."""
    kind: Coded
    line: Coded
    status: Coded                # None: not a command (a command without one is pending)
    command: Coded               # linked rows: the command id of their transaction
    device: Coded                # linked rows: the device of their transaction
    size: np.ndarray             # bytes
    t: np.ndarray                # the first byte's time, on ``timed`` rows
    t_end: np.ndarray            # the last byte's (NaN: none)
    timed: np.ndarray
    linked: np.ndarray           # has a pairing record (``Event.transaction``)
    checksum_bad: np.ndarray
    retransmission: np.ndarray
    latency: np.ndarray          # NaN: none
    problems: Sequence[tuple[int, Sequence[Problem | str]]]   # (row, its problems) of rows with any, ascending
    rate_changes: Sequence[dict[str, Any]]                     # of the rate-change rows, in order (``rate_change``)

    def __len__(self) -> int:
        return len(self.size)

    @classmethod
    def of(cls, events: Sequence[Event]) -> EventColumns:
        """The columns of ``events``."""
        n = len(events)
        # a comprehension a property: attribute reads in a loop of their own are the quickest
        kinds = Coded.of([ev.kind for ev in events])
        txns = [ev.transaction for ev in events]
        times = np.array([ev.t for ev in events], dtype=np.float64)   # None is NaN
        return cls(
            kinds, Coded.of([ev.line for ev in events]), Coded.of([ev.status for ev in events]),
            Coded.of([None if x is None else x.command for x in txns]),
            Coded.of([None if x is None else x.device for x in txns]),
            np.fromiter([len(ev.raw) for ev in events], np.int64, n), times,
            np.array([ev.t_end for ev in events], dtype=np.float64), ~np.isnan(times),
            np.array([x is not None for x in txns], dtype=bool),
            np.array([ev.checksum_ok is False for ev in events], dtype=bool),
            np.array([ev.retransmission for ev in events], dtype=bool),
            np.array([ev.latency for ev in events], dtype=np.float64),
            [(i, ev.problems) for i, ev in enumerate(events) if ev.problems],
            [rate_change(events[i]) for i in np.flatnonzero(kinds.among(RATE)).tolist()])


T = TypeVar("T")


class Figure(Generic[T]):
    """A figure of ``Stats``, held in the attribute of its name with an underscore
    before it. Read, it counts the events still waiting first (``Stats.flush``),
    so a figure read mid-capture is of every event added."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.held = "_" + name

    @overload
    def __get__(self, stats: None, owner: type) -> Figure[T]: ...

    @overload
    def __get__(self, stats: Stats, owner: type) -> T: ...

    def __get__(self, stats: Stats | None, owner: type) -> Figure[T] | T:
        if stats is None:
            return self
        stats.flush()
        value: T = getattr(stats, self.held)
        return value


# ------------------------------------------------------------------ the figures
class Stats:
    """The statistics of the events added so far. Events added one by one or a
    few at a time wait in a list and are counted ``BATCH`` at a time; reading a
    figure counts those waiting first (``flush``)."""

    # every event added, counted (``Figure``: a read counts those waiting first)
    events = Figure[int]()
    kinds = Figure[Counter[str]]()
    problems = Figure[Counter[str]]()                # events per problem category
    bytes = Figure[Counter[str]]()                   # bytes per line
    noise_bytes = Figure[int]()
    noise_kinds = Figure[Counter[str]]()             # noise events by what they are (their problem)
    checksum_errors = Figure[int]()                  # events with a checksum problem (frames and broken frames)
    broken_frames = Figure[int]()                    # of those: noise events, a frame broken beyond reading
    orphans = Figure[int]()
    rate_changes = Figure[list[dict[str, Any]]]()    # the link's rate changes (docs/time.md)
    first_t = Figure[float | None]()
    last_t = Figure[float | None]()
    by_command = Figure[dict[str, Counts]]()
    by_device = Figure[dict[str, Counts]]()

    def __init__(self) -> None:
        self._pending: list[Event] = []   # added, not counted yet
        self._events = 0
        self._kinds: Counter[str] = Counter()
        self._problems: Counter[str] = Counter()
        self._bytes: Counter[str] = Counter()
        self._noise_bytes = 0
        self._noise_kinds: Counter[str] = Counter()
        self._checksum_errors = 0
        self._broken_frames = 0
        self._orphans = 0
        self._rate_changes: list[dict[str, Any]] = []
        self._first_t: float | None = None
        self._last_t: float | None = None
        self._by_command: dict[str, Counts] = {}
        self._by_device: dict[str, Counts] = {}

    def add(self, ev: Event) -> None:
        """Count one event, the next in wire order."""
        pending = self._pending
        pending.append(ev)
        if len(pending) >= BATCH:
            self.flush()

    def add_events(self, events: Sequence[Event]) -> None:
        """Count ``events``, the next in wire order."""
        pending = self._pending
        if not pending and len(events) >= BATCH:
            self._count(EventColumns.of(events))
            return
        pending.extend(events)
        if len(pending) >= BATCH:
            self.flush()

    def add_columns(self, batch: EventColumns) -> None:
        """Count the events of ``batch``, the next in wire order."""
        self.flush()
        self._count(batch)

    def flush(self) -> None:
        """Count the events waiting to be (every figure read does it first)."""
        if self._pending:
            pending, self._pending = self._pending, []
            self._count(EventColumns.of(pending))

    def _count(self, batch: EventColumns) -> None:
        """Count the events of ``batch``, the next in wire order: the definition
        of every figure."""
        n = len(batch)
        if not n:
            return
        self._events += n
        kind = batch.kind
        _add_up(self._kinds, kind)
        _add_up(self._bytes, batch.line, batch.size)
        self._times(batch)
        noise = kind.among(NOISE)
        self._count_problems(batch, noise)
        self._noise_bytes += int(batch.size[noise].sum())
        self._rate_changes.extend(batch.rate_changes)
        counted = ~(noise | kind.among(RATE))   # a rate change and noise are in no table
        self._orphans += int(np.count_nonzero(counted & ~batch.linked & ~kind.among(COMMAND)))
        linked = counted & batch.linked   # an answer counts for its command's id and device
        if linked.any():
            _tables(batch, linked, self._by_command, batch.command)
            _tables(batch, linked, self._by_device, batch.device)

    def _times(self, batch: EventColumns) -> None:
        timed = np.flatnonzero(batch.timed)
        if not len(timed):
            return
        if self._first_t is None:
            self._first_t = float(batch.t[timed[0]])
        last = timed[-1]
        end = float(batch.t_end[last])
        self._last_t = float(batch.t[last]) if math.isnan(end) else end

    def _count_problems(self, batch: EventColumns, noise: np.ndarray) -> None:
        """Events per problem category, checksum errors, broken frames, and the
        noise events by what they are (their first problem's category)."""
        noise_kind: dict[int, str] = {}
        for row, problems in batch.problems:
            cats = problem_categories(problems)
            self._problems.update(cats)
            checksum = any(cat in CHECKSUM_CATEGORIES for cat in cats)
            self._checksum_errors += checksum
            if noise[row]:
                noise_kind[row] = cats[0] if cats else P_NOISE
                self._broken_frames += checksum
        for row in np.flatnonzero(noise).tolist():
            self._noise_kinds[noise_kind.get(row, P_NOISE)] += 1

    def to_dict(self) -> dict[str, Any]:
        """Every figure, as ``stats --format json`` prints them."""
        self.flush()
        total = Counts()
        for c in self._by_command.values():
            total.commands += c.commands
            total.status.update(c.status)
            total.retransmissions += c.retransmissions
        first, last = self._first_t, self._last_t
        return {
            "events": self._events,
            # to the nanosecond, as event times are written (and recordings' stored columns keep them)
            "duration": round(round(last, 9) - round(first, 9), 9) if first is not None and last is not None else None,
            "bytes": dict(sorted(self._bytes.items())),
            "kinds": {k: self._kinds.get(k, 0) for k in KIND_ORDER},
            "commands": total.commands,
            "status": {s: total.status.get(s, 0) for s in STATUSES},
            "timeouts": total.status.get(NO_ACK, 0) + total.status.get(NO_RESULT, 0),
            "retransmissions": total.retransmissions,
            "checksum_errors": self._checksum_errors,
            "broken_frames": self._broken_frames,
            "noise": {"events": self._kinds.get(NOISE, 0), "bytes": self._noise_bytes,
                      "by_problem": dict(self._noise_kinds.most_common())},
            "orphans": self._orphans,
            "rate_changes": self._rate_changes,
            "problems": dict(self._problems.most_common()),
            "by_command": {k: v.to_dict() for k, v in sorted(self._by_command.items())},
            "by_device": {k: v.to_dict() for k, v in sorted(self._by_device.items())},
        }


def _add_up(counter: Counter[str], coded: Coded, weights: np.ndarray | None = None) -> None:
    """Add to ``counter`` the rows of each value, or the sum of their ``weights``
    (a value some row has is counted even when its sum is 0)."""
    rows = np.bincount(coded.codes, minlength=len(coded.values))
    sums = rows if weights is None else np.bincount(coded.codes, weights=weights, minlength=len(coded.values))
    for code in np.flatnonzero(rows).tolist():
        counter[coded.values[code]] += int(sums[code])


def _tables(batch: EventColumns, linked: np.ndarray, table: dict[str, Counts], key: Coded) -> None:
    """``by_command`` or ``by_device`` (``key`` says which): a command counts its
    status, retransmission and checksum; an answer its checksum, an ACK's or
    NAK's latency and a result's."""
    size = len(key.values)
    codes = key.codes
    kind = batch.kind
    commands = linked & kind.among(COMMAND)

    def per_key(rows: np.ndarray) -> np.ndarray:
        return np.bincount(codes[rows], minlength=size)

    n_status = len(batch.status.values)
    by_status = np.bincount(codes[commands] * n_status + batch.status.codes[commands],
                            minlength=size * n_status).reshape(size, n_status)
    sent, again, bad = per_key(commands), per_key(commands & batch.retransmission), per_key(linked & batch.checksum_bad)
    for code in np.flatnonzero(per_key(linked)).tolist():   # every key an event counts for, even with nothing to add
        c = _entry(table, key.values[code] or "?")
        c.commands += int(sent[code])
        for s in np.flatnonzero(by_status[code]).tolist():
            c.status[batch.status.values[s] or PENDING] += int(by_status[code, s])
        c.retransmissions += int(again[code])
        c.checksum_errors += int(bad[code])
    timed = linked & ~commands & ~np.isnan(batch.latency)
    _latencies(table, key, timed & kind.among(ACK, NAK), batch.latency, attrgetter("ack_latency"))
    _latencies(table, key, timed & kind.among(RESULT), batch.latency, attrgetter("result_latency"))


def _latencies(table: dict[str, Counts], key: Coded, rows: np.ndarray, latency: np.ndarray,
               which: Callable[[Counts], Latency]) -> None:
    """The latencies at ``rows`` into the ``which`` latency of their key's entry."""
    codes = key.codes[rows]
    if not len(codes):
        return
    order = np.argsort(codes, kind="stable")
    codes, xs = codes[order], latency[rows][order]
    starts = np.flatnonzero(np.concatenate(([True], codes[1:] != codes[:-1])))
    for code, part in zip(codes[starts].tolist(), np.split(xs, starts[1:])):
        which(_entry(table, key.values[code] or "?")).extend(part)


def _entry(table: dict[str, Counts], key: str) -> Counts:
    c = table.get(key)
    if c is None:
        c = table[key] = Counts()
    return c
