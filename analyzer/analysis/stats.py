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
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

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

_LOG_STEP = math.log(1.01)
_CHECKSUM_PROBLEMS = frozenset((P_CHECKSUM, P_LENGTH))
KIND_ORDER = (COMMAND, ACK, NAK, NIC, RESULT, NOISE)   # the order reports list kinds in


def categories(ev: Event) -> list[str]:
    """The event's problem categories, each once, in order."""
    return problem_categories(ev.problems)


def problem_categories(problems) -> list[str]:
    """The categories of a list of problems, each once, in order."""
    out: list[str] = []
    for p in problems:
        info = getattr(p, "id", None)   # a plain string (an event built by hand) has none
        cat = info.text if info is not None else p.split(":", 1)[0]
        if cat not in out:
            out.append(cat)
    return out


def checksum_problem(ev: Event) -> bool:
    """Does the event have a checksum problem (``Stats.checksum_errors`` counts it)?"""
    return any(cat in _CHECKSUM_PROBLEMS for cat in categories(ev))


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
            self.buckets[int(math.floor(math.log(x) / _LOG_STEP))] += 1

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
                mid = math.exp((b + 0.5) * _LOG_STEP)
                return min(max(mid, self.min), self.max)
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


class Stats:
    def __init__(self) -> None:
        self.events = 0
        self.kinds: Counter[str] = Counter()
        self.problems: Counter[str] = Counter()
        self.bytes: Counter[str] = Counter()
        self.noise_bytes = 0
        self.noise_kinds: Counter[str] = Counter()   # noise events by what they are (their problem)
        self.checksum_errors = 0     # events with a checksum problem (frames and broken frames)
        self.broken_frames = 0       # of which: noise events, a frame broken beyond reading
        self.orphans = 0
        self.rate_changes: list[dict[str, Any]] = []   # the link's rate changes (docs/time.md)
        self.first_t: float | None = None
        self.last_t: float | None = None
        self.by_command: dict[str, Counts] = {}
        self.by_device: dict[str, Counts] = {}

    def add(self, ev: Event) -> None:
        self.events += 1
        kind = ev.kind
        self.kinds[kind] += 1
        self.bytes[ev.line] += len(ev.raw)
        if ev.t is not None:
            if self.first_t is None:
                self.first_t = ev.t
            self.last_t = ev.t_end if ev.t_end is not None else ev.t
        cats = categories(ev) if ev.problems else ()
        checksum = False
        for cat in cats:
            self.problems[cat] += 1
            checksum = checksum or cat in _CHECKSUM_PROBLEMS
        if checksum:
            self.checksum_errors += 1
        if kind == RATE:
            self.rate_changes.append({"number": ev.number, "t": ev.t, "request": ev.request, **ev.fields})
            return
        if kind == NOISE:
            self.noise_bytes += len(ev.raw)
            self.noise_kinds[cats[0] if cats else P_NOISE] += 1
            self.broken_frames += checksum
            return
        txn = ev.transaction   # the command's record: an answer counts for its command and device
        if txn is None:
            if kind != COMMAND:
                self.orphans += 1
            return
        key = (txn.command or "?", txn.device or "?")
        if kind == COMMAND:
            for counts in self._counts(key):
                counts.commands += 1
                counts.status[ev.status or PENDING] += 1
                counts.retransmissions += ev.retransmission
                counts.checksum_errors += ev.checksum_ok is False
            return
        for counts in self._counts(key):
            if ev.checksum_ok is False:
                counts.checksum_errors += 1
            if ev.latency is None:
                continue
            if kind == ACK or kind == NAK:
                counts.ack_latency.add(ev.latency)
            elif kind == RESULT:
                counts.result_latency.add(ev.latency)

    def _counts(self, key: tuple[str, str]) -> tuple[Counts, Counts]:
        cmd, dev = key
        c = self.by_command.get(cmd)
        if c is None:
            c = self.by_command[cmd] = Counts()
        d = self.by_device.get(dev)
        if d is None:
            d = self.by_device[dev] = Counts()
        return c, d

    def to_dict(self) -> dict[str, Any]:
        total = Counts()
        for c in self.by_command.values():
            total.commands += c.commands
            total.status.update(c.status)
            total.retransmissions += c.retransmissions
        return {
            "events": self.events,
            "duration": (self.last_t - self.first_t) if self.first_t is not None else None,
            "bytes": dict(sorted(self.bytes.items())),
            "kinds": {k: self.kinds.get(k, 0) for k in KIND_ORDER},
            "commands": total.commands,
            "status": {s: total.status.get(s, 0) for s in STATUSES},
            "timeouts": total.status.get(NO_ACK, 0) + total.status.get(NO_RESULT, 0),
            "retransmissions": total.retransmissions,
            "checksum_errors": self.checksum_errors,
            "broken_frames": self.broken_frames,
            "noise": {"events": self.kinds.get(NOISE, 0), "bytes": self.noise_bytes,
                      "by_problem": dict(self.noise_kinds.most_common())},
            "orphans": self.orphans,
            "rate_changes": self.rate_changes,
            "problems": dict(self.problems.most_common()),
            "by_command": {k: v.to_dict() for k, v in sorted(self.by_command.items())},
            "by_device": {k: v.to_dict() for k, v in sorted(self.by_device.items())},
        }
