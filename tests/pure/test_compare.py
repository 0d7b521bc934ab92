"""The tests behind `gimbalscope diff`'s verdicts (analysis/compare.py), against
values worked out by hand."""

from __future__ import annotations

import math

import pytest

from analyzer.analysis.compare import (
    BETTER,
    SAME,
    WORSE,
    Latencies,
    compare,
    fisher_exact,
    holm,
    mann_whitney,
    two_proportions,
)


def test_fisher_exact_the_tea_tasting_table():
    # 3 of 4 against 1 of 4: the hypergeometric weights of x = 0..4 are 1, 16, 36, 16, 1 (of 70);
    # the tables no likelier than x = 3 are x = 0, 1, 3, 4: 34/70
    assert fisher_exact(3, 4, 1, 4) == pytest.approx(34 / 70)
    assert fisher_exact(4, 4, 0, 4) == pytest.approx(2 / 70)
    assert fisher_exact(2, 4, 2, 4) == pytest.approx(1.0)
    assert fisher_exact(0, 10, 0, 12) == 1.0


def test_two_proportions_beyond_the_exact_range_is_the_pooled_z_test():
    # 250/5000 against 300/5000: pooled 0.055, spread sqrt(0.055 * 0.945 * 2/5000) = 0.0045596,
    # z = 0.01 / 0.0045596 = 2.1932, two-sided p = erfc(2.1932 / sqrt 2) = 0.0283
    assert two_proportions(250, 5000, 300, 5000) == pytest.approx(0.0283, abs=5e-4)
    assert two_proportions(3, 4, 1, 4) == pytest.approx(34 / 70)   # small: exact
    assert two_proportions(1, 0, 1, 5) == 1.0


def test_mann_whitney_of_two_samples_apart():
    # ranks of a: 1, 2, 3: U = 6 - 6 = 0; mean 4.5, variance 3 * 3 / 12 * 7 = 5.25;
    # z = -4.5 / 2.2913 = -1.964, p = 0.0495
    assert mann_whitney([1, 2, 3], [4, 5, 6]) == pytest.approx(0.0495, abs=5e-4)
    assert mann_whitney([1, 2, 3], [1, 2, 3]) == pytest.approx(1.0)
    assert mann_whitney([2, 2, 2], [2, 2, 2]) == 1.0   # all tied: nothing to tell


def test_holm_holds_every_test_together():
    # sorted: 0.01 <= 0.05/3 passes; 0.03 > 0.05/2 stops there
    assert holm([0.01, 0.04, 0.03]) == [True, False, False]
    assert holm([0.001, 0.02, 0.04]) == [True, True, True]
    assert holm([]) == []


def _stats(**by_device: dict) -> dict:
    devices = {d: {"commands": 0, "ok": 0, "nak": 0, "nic": 0, "no_ack": 0, "no_result": 0, "pending": 0,
                   "retransmissions": 0, "checksum_errors": 0, **v} for d, v in by_device.items()}
    total = {k: sum(v[k] for v in devices.values()) for k in ("commands", "retransmissions", "checksum_errors")}
    status = {s: sum(v[s] for v in devices.values()) for s in ("ok", "nak", "nic", "no_ack", "no_result", "pending")}
    return {**total, "status": status, "by_device": devices, "by_command": {}}


def _verdict(changes, key, figure):
    return next(c for c in changes if c.key == key and c.figure == figure)


def test_a_rate_that_rose_beyond_chance_is_worse_and_one_that_fell_better():
    before = _stats(**{"1.1.1": {"commands": 1000, "ok": 960, "nak": 40}, "1.1.2": {"commands": 1000, "ok": 1000}})
    after = _stats(**{"1.1.1": {"commands": 1000, "ok": 998, "nak": 2}, "1.1.2": {"commands": 1000, "ok": 985,
                                                                                  "no_ack": 15}})
    changes = compare(before, after, Latencies(), Latencies())
    assert _verdict(changes, "1.1.1", "NAKs").verdict == BETTER
    assert _verdict(changes, "1.1.2", "timeouts").verdict == WORSE
    assert _verdict(changes, "1.1.2", "NAKs").verdict == SAME
    nak = _verdict(changes, "1.1.1", "NAKs")
    assert (nak.before, nak.after, nak.counts) == (0.04, 0.002, (40, 1000, 2, 1000))


def test_a_small_change_in_few_commands_is_no_clear_change():
    before = _stats(**{"1.1.1": {"commands": 20, "ok": 19, "nak": 1}})
    after = _stats(**{"1.1.1": {"commands": 20, "ok": 17, "nak": 3}})
    assert _verdict(compare(before, after, Latencies(), Latencies()), "1.1.1", "NAKs").verdict == SAME


def test_latency_changes_count_when_tested_and_large_enough():
    before, after, nudged = Latencies(), Latencies(), Latencies()
    for k in range(200):
        before.add("ack_latency", "1.1.1", "P?", 0.010 + k * 1e-5)
        after.add("ack_latency", "1.1.1", "P?", 0.020 + k * 1e-5)     # twice as slow
        nudged.add("ack_latency", "1.1.1", "P?", 0.0105 + k * 1e-5)   # certain, but 5 % of the median
    stats = _stats(**{"1.1.1": {"commands": 200, "ok": 200}})
    slower = _verdict(compare(stats, stats, before, after), "1.1.1", "ACK latency")
    assert slower.verdict == WORSE and slower.p is not None and slower.p < 1e-6
    assert math.isclose(slower.before, 0.010 + 99 * 1e-5) and math.isclose(slower.after, 0.020 + 99 * 1e-5)
    assert _verdict(compare(stats, stats, before, nudged), "1.1.1", "ACK latency").verdict == SAME
    assert _verdict(compare(stats, stats, after, before), "1.1.1", "ACK latency").verdict == BETTER
