"""Skew between the lines: an answer cannot start before its command ended."""

import pytest

from analyzer.analysis.skew import SkewEstimator
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


def noise_a(t, t_end):
    return Event("A", 0, "noise", b"\x7f\x01", t, t_end)


ORDERS = ("line A lags", "line B lags", "time order")


def as_read(order, line_a, line_b):
    """Both lines' events as a tap reads them: all of one line's before the other's
    (the other line's reader lagged), or in time order."""
    if order == "line A lags":
        return line_b + line_a
    if order == "line B lags":
        return line_a + line_b
    return sorted(line_a + line_b, key=lambda ev: ev.t_end)


@pytest.mark.parametrize("order", ORDERS)
def test_the_answer_to_a_command_garbled_into_noise_is_not_read_ahead_of_the_next(order):
    # the demo's noisy line A: a command ending at 42.9620 is ACKed 5.4 ms later;
    # the next command's start byte is garbled, so the tap sees it as noise (ending
    # 43.0095), but the device read it whole and ACKs it 5.4 ms later (43.0149);
    # the command after it ends 48.3 ms after that ACK. Taken as read ahead of that
    # command, the ACK would give a -48.3 ms latency and a 48.5 ms skew; the garbled
    # frame that ended 5.4 ms before it explains it better
    s = SkewEstimator(guard=0.0002)
    line_a = [cmd(42.9526, 42.9620), noise_a(43.0001, 43.0095), cmd(43.0538, 43.0632)]
    line_b = [ack(42.9620 + 0.0054), ack(43.0095 + 0.0054)]
    for ev in as_read(order, line_a, line_b):
        s.observe(ev)
    assert s.skew == 0.0
    # the next command's ACK, read ahead by 3 ms, still measures the skew
    s.observe(ack(43.0602))
    assert s.skew == pytest.approx(0.0032)


@pytest.mark.parametrize("order", ORDERS)
def test_noise_long_before_an_answer_read_ahead_does_not_hide_the_skew(order):
    # line A's noise ended 20 ms before an ACK that is read 7 ms before its
    # command ended: the command is the nearer explanation, so it is skew
    s = SkewEstimator(guard=0.0002)
    for ev in as_read(order, [noise_a(1.975, 1.980), cmd(1.9976, 2.007)], [ack(2.000)]):
        s.observe(ev)
    assert s.skew == pytest.approx(0.0072)


@pytest.mark.parametrize("order", ORDERS)
def test_a_late_answer_is_not_read_ahead_of_the_next_command_whichever_line_lags(order):
    # from a demo recording: commands end at 38.8978, 38.9451, 38.9876, 39.0372 and
    # 39.1519; the answers come at 38.9242 (NAK), 38.9504, 38.9933 and 39.1076, the
    # last one 70.4 ms after the command ending at 39.0372: a late answer (past the
    # 50 ms in which answers pair). Taken as read ahead of the command ending at
    # 39.1519, it would give -44.3 ms and a 44.5 ms skew. Judged by the times,
    # whichever line's reader lagged, it is the late answer to the waiting command.
    s = SkewEstimator(guard=0.0002)
    ends = [38.8978, 38.9451, 38.9876, 39.0372, 39.1519]
    answers = [38.9242, 38.9504, 38.9933, 39.1076]
    for ev in as_read(order, [cmd(end - 0.0094, end) for end in ends], [ack(t) for t in answers]):
        s.observe(ev)
    assert s.skew == 0.0
    # the last command is still waiting: its ACK, read 3 ms ahead, measures the skew
    s.observe(ack(39.1489))
    assert s.skew == pytest.approx(0.0032)


@pytest.mark.parametrize("lag", [1, 3, 8])
def test_answers_read_ahead_while_line_a_lags_each_measure_the_skew(lag):
    # line B reads 12 ms ahead and the device answers in 5 ms: each ACK's time is
    # 7 ms before its command ended (commands every 47 ms). Line A's reader lags by
    # ``lag`` commands, so that many ACKs are read before their commands: each still
    # pairs with its own, and the first pair already gives the skew (7 ms and the guard)
    s = SkewEstimator(guard=0.0002)
    ends = [1.0 + 0.047 * k for k in range(lag)]
    for end in ends:
        s.observe(ack(end - 0.007))
    assert s.skew == 0.0
    s.observe(cmd(ends[0] - 0.0094, ends[0]))
    assert s.skew == pytest.approx(0.0072)
    for end in ends[1:]:
        s.observe(cmd(end - 0.0094, end))
    assert s.skew == pytest.approx(0.0072)
