"""Two captures compared (``gimbalscope diff``, docs/diff.md): per device and per
command, the rates of what goes wrong and the latencies, each change with a
verdict a person can read and a test of whether it is more than chance.

What is compared is what ``stats`` counts (``Stats.to_dict``: one definition of
every figure). A rate is its count over the commands sent (``RATES``); fewer is
better for every one. Whether a rate's change is more than chance is a two-sided
test of two proportions: Fisher's exact test while the counts are small, the
pooled z-test (its normal approximation) beyond ``EXACT_UP_TO`` commands. A
latency's change is tested on the samples themselves (Mann-Whitney U, normal
approximation with the ties' correction), and counts only when the median also
moved by ``LATENCY_STEP`` or more: a shift of microseconds is not news even when
a million samples make it certain.

Many figures are tested at once, so some would pass a 5 % test by chance alone:
the tests of one comparison are held to ``ALPHA`` together (Holm's step-down
correction), and a change is "better" or "worse" only when it passes that.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

ALPHA = 0.05          # the chance, over every test of one comparison, of calling a change that is not one
EXACT_UP_TO = 5_000   # commands of both captures together up to which a rate is tested exactly (Fisher)
LATENCY_STEP = 0.10   # the median's relative move below which a latency change is not called
MIN_SAMPLES = 8       # latency samples each side below which no test is made

# (the name said, how a rate's count is read from ``Counts.to_dict``)
RATES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("NAKs", ("nak",)),
    ("NICs", ("nic",)),
    ("timeouts", ("no_ack", "no_result")),
    ("retransmissions", ("retransmissions",)),
    ("checksum errors", ("checksum_errors",)),
)
LATENCIES = (("ACK latency", "ack_latency"), ("result latency", "result_latency"))
_LATENCY_NAMES = frozenset(name for name, _ in LATENCIES)

BETTER, WORSE, SAME = "better", "worse", "no clear change"


@dataclass
class Change:
    """One figure of one device or command, before and after."""
    scope: str            # "device", "command" or "capture"
    key: str              # the device's address, the command's id, or "all"
    figure: str           # "NAKs", "ACK latency", ...
    before: float | None  # a rate (0..1) or a median latency (s); None: not seen
    after: float | None
    counts: tuple[int, int, int, int] = (0, 0, 0, 0)   # rates: (count, commands) before, then after
    p: float | None = None                            # the test's p-value; None: no test
    p95: tuple[float | None, float | None] = (None, None)   # latencies: the 95th percentiles
    verdict: str = SAME

    @property
    def latency(self) -> bool:
        """A latency's median (seconds), not a rate."""
        return self.figure in _LATENCY_NAMES

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"scope": self.scope, "key": self.key, "figure": self.figure,
                               "before": self.before, "after": self.after, "p": self.p, "verdict": self.verdict}
        if self.latency:
            out["p95"] = list(self.p95)
        else:
            out["counts"] = {"before": self.counts[0], "before_commands": self.counts[1],
                             "after": self.counts[2], "after_commands": self.counts[3]}
        return out


@dataclass
class Latencies:
    """The latency samples of each device and command (and of the capture:
    key ``all``), as ``stats`` counts them: an ACK's or NAK's, a result's."""
    samples: dict[tuple[str, str, str], list[float]] = field(default_factory=dict)

    def add(self, which: str, device: str | None, command: str | None, latency: float) -> None:
        for scope, key in (("device", device or "?"), ("command", command or "?"), ("capture", "all")):
            self.samples.setdefault((which, scope, key), []).append(latency)

    def of(self, which: str, scope: str, key: str) -> list[float]:
        return self.samples.get((which, scope, key), [])


# ------------------------------------------------------------------ tests
def fisher_exact(k1: int, n1: int, k2: int, n2: int) -> float:
    """Two-sided p-value of Fisher's exact test of k1/n1 against k2/n2: the
    chance, with the margins fixed, of a table no likelier than the one seen."""
    k, n = k1 + k2, n1 + n2
    if n == 0 or k in (0, n):
        return 1.0
    lo, hi = max(0, k - n2), min(k, n1)

    def log_p(x: int) -> float:   # hypergeometric: x of the k in the first n1 of n
        return (_log_choose(n1, x) + _log_choose(n2, k - x)) - _log_choose(n, k)

    seen = log_p(k1)
    total = 0.0
    for x in range(lo, hi + 1):
        lp = log_p(x)
        if lp <= seen + 1e-9:   # as likely as the table seen, or less (a relative tolerance for rounding)
            total += math.exp(lp)
    return min(1.0, total)


def _log_choose(n: int, k: int) -> float:
    return math.lgamma(n + 1) - math.lgamma(k + 1) - math.lgamma(n - k + 1)


def two_proportions(k1: int, n1: int, k2: int, n2: int) -> float:
    """Two-sided p-value that k1/n1 and k2/n2 differ by chance: exact while the
    counts are small, the pooled z-test beyond."""
    if n1 == 0 or n2 == 0:
        return 1.0
    if n1 + n2 <= EXACT_UP_TO:
        return fisher_exact(k1, n1, k2, n2)
    pooled = (k1 + k2) / (n1 + n2)
    spread = math.sqrt(pooled * (1 - pooled) * (1 / n1 + 1 / n2))
    if spread == 0:
        return 1.0
    z = (k1 / n1 - k2 / n2) / spread
    return math.erfc(abs(z) / math.sqrt(2))


def mann_whitney(a: Sequence[float], b: Sequence[float]) -> float:
    """Two-sided p-value that samples ``a`` and ``b`` come from one distribution
    (Mann-Whitney U, normal approximation, corrected for ties)."""
    n1, n2 = len(a), len(b)
    if not n1 or not n2:
        return 1.0
    import numpy as np

    values = np.concatenate((np.asarray(a, "f8"), np.asarray(b, "f8")))
    order = np.argsort(values, kind="mergesort")
    ranked = values[order]
    # average ranks of ties: each run of equal values gets the mean of its ranks
    starts = np.flatnonzero(np.concatenate(([True], ranked[1:] != ranked[:-1])))
    ends = np.append(starts[1:], len(ranked))
    mean_rank = (starts + ends + 1) / 2.0
    ranks = np.empty(len(values))
    ranks[order] = np.repeat(mean_rank, ends - starts)
    u = float(ranks[:n1].sum()) - n1 * (n1 + 1) / 2.0
    n = n1 + n2
    ties = ends - starts
    variance = n1 * n2 / 12.0 * ((n + 1) - float((ties ** 3 - ties).sum()) / (n * (n - 1)))
    if variance <= 0:
        return 1.0
    z = (u - n1 * n2 / 2.0) / math.sqrt(variance)
    return math.erfc(abs(z) / math.sqrt(2))


def holm(ps: Sequence[float], alpha: float = ALPHA) -> list[bool]:
    """Which of the p-values ``ps`` pass, all held to ``alpha`` together (Holm)."""
    order = sorted(range(len(ps)), key=ps.__getitem__)
    passed = [False] * len(ps)
    m = len(ps)
    for rank, i in enumerate(order):
        if ps[i] > alpha / (m - rank):
            break
        passed[i] = True
    return passed


# ------------------------------------------------------------------ the comparison
def _nearest_rank(ordered: Sequence[float], q: float) -> float | None:
    """The ceil(q·n)-th smallest of the sorted samples (a sample seen, as ``Latency.quantile`` takes one)."""
    if not ordered:
        return None
    return ordered[max(0, math.ceil(q * len(ordered)) - 1)]


def _table(stats: dict[str, Any], scope: str) -> dict[str, dict[str, Any]]:
    if scope == "capture":
        return {"all": {"commands": stats["commands"], **stats["status"],
                        "retransmissions": stats["retransmissions"], "checksum_errors": stats["checksum_errors"]}}
    return stats["by_" + scope]


def compare(before: dict[str, Any], after: dict[str, Any], lat_before: Latencies,
            lat_after: Latencies) -> list[Change]:
    """Every figure of every device and command of either capture (``before`` and
    ``after``: ``Stats.to_dict``), and the capture's as a whole, with verdicts."""
    changes: list[Change] = []
    for scope in ("capture", "device", "command"):
        old, new = _table(before, scope), _table(after, scope)
        for key in sorted(set(old) | set(new)):
            a, b = old.get(key, {}), new.get(key, {})
            n1, n2 = int(a.get("commands", 0)), int(b.get("commands", 0))
            for name, parts in RATES:
                k1, k2 = sum(int(a.get(p, 0)) for p in parts), sum(int(b.get(p, 0)) for p in parts)
                if not n1 or not n2:
                    changes.append(Change(scope, key, name, k1 / n1 if n1 else None, k2 / n2 if n2 else None,
                                          (k1, n1, k2, n2)))
                    continue
                changes.append(Change(scope, key, name, k1 / n1, k2 / n2, (k1, n1, k2, n2),
                                      p=two_proportions(k1, n1, k2, n2)))
            for name, which in LATENCIES:
                xs, ys = lat_before.of(which, scope, key), lat_after.of(which, scope, key)
                if not xs and not ys:
                    continue
                tested = len(xs) >= MIN_SAMPLES and len(ys) >= MIN_SAMPLES
                old_sorted, new_sorted = sorted(xs), sorted(ys)
                changes.append(Change(scope, key, name, _nearest_rank(old_sorted, 0.5), _nearest_rank(new_sorted, 0.5),
                                      p=mann_whitney(xs, ys) if tested else None,
                                      p95=(_nearest_rank(old_sorted, 0.95), _nearest_rank(new_sorted, 0.95))))
    _judge(changes)
    return changes


def _judge(changes: list[Change]) -> None:
    """Each tested change's verdict, every test held to ``ALPHA`` together."""
    tested = [c for c in changes if c.p is not None]
    for c, passed in zip(tested, holm([c.p for c in tested if c.p is not None]), strict=True):
        if not passed or c.before is None or c.after is None or c.after == c.before:
            continue
        if c.latency and abs(c.after - c.before) < LATENCY_STEP * max(c.before, 1e-9):
            continue   # a latency's move too small to be news, however certain
        c.verdict = WORSE if c.after > c.before else BETTER


def worse(changes: Iterable[Change]) -> list[Change]:
    return [c for c in changes if c.verdict == WORSE]


_VERDICT_ORDER = {WORSE: 0, BETTER: 1, SAME: 2}


def reading_order(changes: Iterable[Change]) -> list[Change]:
    """As the text and the page list them: worse, better, the rest; the capture's
    own figures first, then by device or command."""
    return sorted(changes, key=lambda c: (_VERDICT_ORDER[c.verdict], c.scope != "capture", c.scope, c.key,
                                          c.figure))
