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


def test_answers_read_late_in_a_burst_pair_with_the_commands_before_them():
    # line B's reader lags: three commands (polled every 55 ms, each 9.4 ms long)
    # are read before the ACKs of the first two, each ACK 5.4 ms after its command.
    # Paired with the last command read, the second ACK would seem to start 46.7 ms
    # before it ended and invent a 46.9 ms skew; paired with the command that ended
    # before it, every latency is 5.4 ms and there is no skew.
    s = SkewEstimator(guard=0.0002)
    ends = [1.000, 1.055, 1.110]
    for end in ends:
        assert not s.observe(cmd(end - 0.0094, end))
    for end in ends[:2]:
        s.observe(ack(end + 0.0054))
    assert s.skew == 0.0
    # the third command's ACK, read in time, still pairs with it
    s.observe(ack(ends[2] + 0.0054))
    assert s.skew == 0.0


def test_an_answer_read_ahead_of_its_command_still_measures_the_skew():
    # the command is read first, but its ACK's time is 3 ms before the command
    # ended (line B reads ahead): no earlier command is waiting, so it pairs with
    # this one and the skew is 3 ms and the guard
    s = SkewEstimator(guard=0.0002)
    s.observe(cmd(2.0, 2.0094))
    s.observe(ack(2.0064))
    assert s.skew == pytest.approx(0.0032)


def test_a_late_answer_is_not_read_as_one_ahead_of_the_next_command():
    # a command ends at 1.000; its ACK comes 51.5 ms later, just past the 50 ms in
    # which answers pair; the next command ends at 1.095. Taken as read ahead of
    # that command, the ACK would give a -43.5 ms latency and a 43.7 ms skew; a
    # command was still waiting for an answer, so it is that one's (late) answer
    s = SkewEstimator(guard=0.0002)
    s.observe(cmd(0.9906, 1.000))
    s.observe(ack(1.0515))
    s.observe(cmd(1.0856, 1.095))
    assert s.skew == 0.0
    # once that command is answered (5.4 ms), an answer no command waits for,
    # read 12 ms before the next command ends, is still read ahead of it
    s.observe(ack(1.1004))
    assert s.skew == 0.0
    s.observe(ack(1.2855))
    s.observe(cmd(1.2881, 1.2975))
    assert s.skew == pytest.approx(0.0122)


@pytest.mark.parametrize("lag", [4, 8, 9, 12, 30])
def test_answers_read_many_commands_late_still_pair_with_theirs(lag):
    # line B's reader lags by ``lag`` commands (polled every 47 ms; a busy screen
    # held it 0.4 s in the demo): each ACK, 5.4 ms after its command, is read after
    # the next ``lag`` commands; still no skew
    s = SkewEstimator(guard=0.0002)
    ends = [1.0 + 0.047 * k for k in range(80)]
    for k, end in enumerate(ends):
        s.observe(cmd(end - 0.0094, end))
        if k >= lag:
            s.observe(ack(ends[k - lag] + 0.0054))
    assert s.skew == 0.0
