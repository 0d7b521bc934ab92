"""Skew between the lines: an answer cannot start before its command ended."""

import pytest

from analyzer.skew import SkewEstimator
from dissectors.event import Event


def cmd(t, t_end):
    return Event("A", 0, "command", b"\xf8", t, t_end)


def ack(t):
    return Event("B", 0, "ack", b"\x06", t, t + 0.001)


def test_no_skew_when_answers_follow_commands():
    s = SkewEstimator()
    for k in range(10):
        s.observe(cmd(k, k + 0.01))
        s.observe(ack(k + 0.015))
    assert s.skew == 0.0


def test_answers_before_their_commands_measure_the_skew():
    s = SkewEstimator(guard=0.0002)
    # line A's adapter is 20 ms late; true latency 8 ms: answers appear 12 ms early
    for k in range(5):
        s.observe(ack(k + 0.010 + 0.008 - 0.020 + 0.010))   # read before the (late) command
        s.observe(cmd(k + 0.010 - 0.010 + 0.010, k + 0.010 + 0.010))
    # measured latency = ack.t - cmd.t_end = -0.012 -> skew = 0.012 + guard
    assert s.skew == pytest.approx(0.0122)


def test_far_apart_events_are_not_paired():
    s = SkewEstimator()
    s.observe(ack(0.0))
    s.observe(cmd(0.2, 0.21))   # an answer to something earlier, not to this command
    assert s.skew == 0.0
