"""The time model (docs/time.md): byte order within a line, one clock or two,
following the link's rate. Frames are built by hand with the checksum rule of
§1.4.1.3 (sum of bytes 2 … last payload byte, modulo 256), and byte times
computed by hand: 10 bits a character at 8N1."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from analyzer.analysis.rate import RateFollower
from analyzer.capture import Capture, Options
from analyzer.sources import Chunk, Source
from dissectors import Deframer
from dissectors.event import ACK, COMMAND, RATE, RESULT

BT_9600 = 10 / 9600
BT_115200 = 10 / 115200


def frame(dst: tuple[int, int, int], src: int, payload: bytes) -> bytes:
    body = bytes([*dst, src, len(payload)]) + payload
    return b"\xf8" + body + bytes([sum(body) % 256])


def test_frame_helper_matches_the_worked_checksum():
    # 01 01 01 00 02 50 3F ("P?" to 1.1.1): 1+1+1+0+2+0x50+0x3F = 0x94
    assert frame((1, 1, 1), 0, b"P?") == bytes.fromhex("f8 01 01 01 00 02 50 3f 94")


class Timed(Source):
    """Chunks with the read times a tap gave them (start = read − n × byte time)."""
    timed = True

    def __init__(self, reads: list[tuple[str, bytes, float]], lines=("A", "B"), clocks: int = 1,
                 bt: float = BT_9600) -> None:
        super().__init__()
        self.lines, self.clocks = lines, clocks
        self.reads, self.bt = reads, bt

    def chunks(self) -> Iterator[Chunk]:
        for line, data, read in self.reads:
            # the byte time of the moment: the capture's line settings follow rate changes
            yield Chunk(line, data, read - len(data) * self.settings_of(line).byte_time)


def decode(source: Source, **options) -> tuple[list, list[str]]:
    cap = Capture(source, Options(**options))
    return list(cap), cap.warnings


CMD = frame((1, 1, 1), 0, b"P?")
RES = frame((0, 1, 1), 1, b"0FA0FC18")


def test_an_answer_read_at_once_is_never_placed_before_its_command():
    # a pty delivers the ACK and the 15-byte result together, 0.2 ms after the
    # command was read: back-dated by 16 byte times they would start 16.5 ms
    # before the command ended
    reads = [("A", CMD, 1.0), ("B", b"\x06" + RES, 1.0002)]
    events, warnings = decode(Timed(reads))
    kinds = [(e.kind, e.line) for e in events]
    assert kinds == [(COMMAND, "A"), (ACK, "B"), (RESULT, "B")]
    cmd, ack, res = events
    assert cmd.t == pytest.approx(1.0 - 9 * BT_9600)
    assert ack.t == pytest.approx(1.0) and res.t_end == pytest.approx(1.0002)   # spread over 0.2 ms
    assert 0 <= ack.latency < 0.001 and res.latency >= 0
    assert not [w for w in warnings if "ahead" in w]   # one clock: no skew to correct


def test_one_line_keeps_its_byte_order():
    # the result read in its own chunk right after the ACK: never before the ACK
    reads = [("A", CMD, 1.0), ("B", b"\x06", 1.0010), ("B", RES, 1.0012)]
    events, _ = decode(Timed(reads))
    ack, res = events[1], events[2]
    assert (ack.kind, res.kind) == (ACK, RESULT)
    assert res.t >= ack.t_end and res.t == pytest.approx(1.0010)
    assert res.t_end == pytest.approx(1.0012)


def test_two_clocks_still_estimate_the_skew():
    # line B's adapter reads 20 ms ahead: the ACK seems to start before the command ended
    reads = []
    for k in range(5):
        at = 1.0 + k * 0.2
        reads += [("A", CMD, at), ("B", b"\x06", at - 0.020 + 0.003)]
    events, warnings = decode(Timed(reads, clocks=2))
    assert any("ahead of line A" in w for w in warnings)
    acks = [e for e in events if e.kind == ACK]
    assert all(a.latency >= 0 for a in acks)


def test_answers_read_before_their_commands_are_made_causal_as_the_skew_grows():
    # line B reads ahead, and its ACKs arrive before their commands (line A's
    # adapter is the late one): 12 ms early, then 16 ms early from the fourth round
    # (the adapters' delays drift). Every ACK ends up after its command, by the
    # guard, whatever the skew was when it arrived.
    reads = []
    for k in range(6):
        at = 1.0 + k * 0.2
        early = 0.012 if k < 3 else 0.016
        reads += [("B", b"\x06", at - early), ("A", CMD, at)]
    events, warnings = decode(Timed(reads, clocks=2))
    assert any("ahead of line A" in w for w in warnings)
    acks = [e for e in events if e.kind == ACK]
    assert len(acks) == 6 and all(a.latency is not None for a in acks)
    # ACK.t is its read time less a byte time, the command ends when it is read:
    # ACK.t - cmd.t_end = -early - 1 byte time before correction
    raw = [-(0.012 if k < 3 else 0.016) - BT_9600 for k in range(6)]
    assert all(a.latency >= 0 for a in acks), [round(a.latency, 6) for a in acks]
    # the correction is the most negative latency yet (plus the guard, 0.2 ms):
    # the rounds that taught it answer in exactly the guard
    assert acks[0].latency == pytest.approx(0.0002) and acks[3].latency == pytest.approx(0.0002)
    assert acks[4].latency == pytest.approx(raw[4] - raw[3] + 0.0002)


def test_a_skew_that_ends_is_said_to_end():
    # line B reads 20 ms ahead for three rounds, then the adapters agree again: once
    # the early pairs have left the estimate's window (64 pairs), the times are no
    # longer moved, and the tap says so rather than "about 0.0 ms ahead"
    reads = []
    for k in range(70):
        at = 1.0 + k * 0.2
        ack_read = at - 0.020 + 0.003 if k < 3 else at + 0.003
        reads += [("A", CMD, at), ("B", b"\x06", ack_read)]
    events, warnings = decode(Timed(reads, clocks=2))
    said = [w for w in warnings if "line B" in w]
    assert said[0].startswith("line B reads about ") and "ms ahead of line A" in said[0]
    assert said[-1] == "line B no longer reads ahead of line A: its times are no longer moved"
    assert not [w for w in said if "about 0.0 ms" in w]
    last = [e for e in events if e.kind == ACK][-1]
    assert last.latency == pytest.approx(0.003 - BT_9600)   # as read: no correction left


def test_one_clock_gets_no_skew_correction():
    reads = []
    for k in range(5):
        at = 1.0 + k * 0.2
        reads += [("A", CMD, at), ("B", b"\x06", at + 0.003)]
    events, warnings = decode(Timed(reads, clocks=1))
    assert not warnings
    for a in (e for e in events if e.kind == ACK):
        # ACK read 3 ms after the command: it started one byte time before that
        assert a.latency == pytest.approx(0.003 - BT_9600)


# ------------------------------------------------------------------ rate changes
C7 = frame((1, 1, 1), 0, b"C7")


def test_rate_follower_reads_table_4():
    d = Deframer("A")
    f = RateFollower(9600)
    (cmd,) = d.feed(C7)
    ack_line = Deframer("B")
    (ack,) = ack_line.feed(b"\x06")
    assert f.observe(cmd) is None
    change = f.observe(ack)
    assert (change.previous, change.baud) == (9600, 115200) and f.baud == 115200
    ev = change.event()
    assert ev.kind == RATE and ev.fields == {"baud": 115200, "previous_baud": 9600}


@pytest.mark.parametrize("payload, answer, baud", [
    (b"C7", b"\x15", 9600),     # NAKed
    (b"C8", b"\x06", 9600),     # reserved code
    (b"C4", b"\x06", 19200),    # 4 = 19,200
    (b"C0", b"\x06", 1200),
    (b"CN", b"\x06", 9600),     # camera power on, not a rate
])
def test_what_is_and_is_not_a_rate_change(payload, answer, baud):
    f = RateFollower(9600)
    (cmd,) = Deframer("A").feed(frame((1, 1, 1), 0, payload))
    events = [cmd, *Deframer("B").feed(answer)]
    f.follow(events)
    assert f.baud == baud


def test_a_nic_after_the_ack_takes_the_change_back():
    f = RateFollower(9600)
    (cmd,) = Deframer("A").feed(C7)
    ack, nic = Deframer("B").feed(b"\x06?")
    changes = f.follow([cmd, ack, nic])
    assert [(c.baud, c.taken_back) for c in changes] == [(115200, False), (9600, True)] and f.baud == 9600


def test_an_unanswered_wildcard_rate_set_is_kept_for_a_warning():
    f = RateFollower(9600)
    (bcast,) = Deframer("A").feed(frame((255, 255, 255), 0, b"C7"))
    (nxt,) = Deframer("A").feed(CMD)
    f.follow([bcast, nxt])
    assert f.baud == 9600 and [baud for _cmd, baud in f.unconfirmed] == [115200]


def test_decoding_follows_an_acked_rate_change_on_both_lines():
    # at 9600: C7 sent and ACKed; then a P? and its answer at 115200
    reads = [("A", C7, 1.0), ("B", b"\x06", 1.0030),
             ("A", CMD, 1.2), ("B", b"\x06", 1.2005), ("B", RES, 1.2030)]
    events, warnings = decode(Timed(reads))
    kinds = [e.kind for e in events]
    assert kinds == [COMMAND, ACK, RATE, COMMAND, ACK, RESULT]
    rate = events[2]
    assert rate.fields == {"baud": 115200, "previous_baud": 9600} and rate.request == events[0].number
    assert rate.t == pytest.approx(1.0030) and rate.device == "1.1.1"
    cmd, res = events[3], events[5]
    # after the change a byte takes 10/115200 s: the 9-byte command started 9 of them before its read
    assert cmd.t == pytest.approx(1.2 - 9 * BT_115200)
    assert len(RES) == 15 and res.t_end - res.t == pytest.approx(15 * BT_115200)
    assert not warnings


def test_no_follow_rate_keeps_the_first_rate():
    reads = [("A", C7, 1.0), ("B", b"\x06", 1.0030), ("A", CMD, 1.2)]
    events, _ = decode(Timed(reads), follow_rate=False)
    assert RATE not in [e.kind for e in events]
    assert events[-1].t == pytest.approx(1.2 - 9 * BT_9600)


def test_single_line_and_untimed_inputs_follow_too():
    single = Timed([("AB", C7, 1.0), ("AB", b"\x06", 1.003), ("AB", CMD, 1.2)], lines=("AB",))
    events, _ = decode(single)
    assert [e.kind for e in events][:3] == [COMMAND, ACK, RATE]
    assert events[-1].t == pytest.approx(1.2 - 9 * BT_115200)

    class Untimed(Source):
        def __init__(self):
            super().__init__()
            self.data = {"A": C7 + CMD, "B": b"\x06\x06" + RES}

        def chunks(self):
            for line in self.lines:
                yield Chunk(line, self.data[line])

    events, _ = decode(Untimed())
    assert [e.kind for e in events] == [COMMAND, ACK, RATE, COMMAND, ACK, RESULT]
    assert events[2].fields["baud"] == 115200


def test_the_doctor_names_a_device_silent_since_a_rate_change():
    from analyzer.analysis.doctor import WiringDoctor

    reads = [("A", CMD, 0.5), ("B", b"\x06" + RES, 0.52), ("A", C7, 1.0), ("B", b"\x06", 1.0030)]
    reads += [("A", CMD, 2.0 + k) for k in range(4)]     # at 115200 now: never answered
    events, _ = decode(Timed(reads))
    doctor = WiringDoctor()
    for ev in events:
        doctor.add(ev)
    found = {f.code: f for f in doctor.findings()}
    rate_set = next(e for e in events if e.kind == COMMAND and e.payload == b"C7").number
    f = found["silent_after_rate"]
    assert f.title == f"1.1.1 was set to 115200 bps at #{rate_set} and has not answered since"
    # the last one is still within its ACK timeout when the capture ends: pending, not evidence
    assert f.subject == "1.1.1" and f.severity == "error" and len(f.evidence) == 3
    assert "silent_device" not in found and "dead_link" not in found


def test_a_rate_set_read_a_byte_at_a_time_is_followed():
    # a live adapter can deliver every byte in a read of its own: the frame is split
    # everywhere, the capture still finds it in the bytes and follows it
    reads = [("A", bytes([b]), 1.0 + k * BT_9600) for k, b in enumerate(C7)]
    reads += [("B", b"\x06", 1.02), ("A", CMD, 1.2)]
    events, _ = decode(Timed(reads))
    assert [e.kind for e in events][:3] == [COMMAND, ACK, RATE]
    assert events[-1].t == pytest.approx(1.2 - 9 * BT_115200)


def test_a_followed_rate_change_changes_the_line_settings_every_reader_holds():
    reads = [("A", C7, 1.0), ("B", b"\x06", 1.0030), ("A", CMD, 1.2)]
    source = Timed(reads)
    cap = Capture(source, Options())
    list(cap)
    (change,) = cap.rate_changes
    assert (change.previous, change.baud) == (9600, 115200) and cap.baud == 115200
    for line in ("A", "B"):
        settings = cap.line_settings[line]
        # one object per line: the source reads the very settings the capture changed
        assert source.settings_of(line) is settings
        assert settings.baud == 115200 and settings.byte_time == pytest.approx(BT_115200)
        assert settings.changes == [change]


def test_frames_that_only_look_like_rate_sets_are_let_go():
    # CN and CX (camera power, Table 16) are two-byte payloads starting with "C" too
    reads = []
    for k in range(20):
        reads += [("A", frame((1, 1, 1), 0, b"CN" if k % 2 else b"CX"), 1.0 + k * 0.1),
                  ("B", b"\x06", 1.02 + k * 0.1)]
    cap = Capture(Timed(reads), Options())
    events = list(cap)
    assert RATE not in [e.kind for e in events] and cap.baud == 9600
    assert cap.rates.marks == 0   # every mark was seen to be a frame: no more looking at every event


def test_the_deframer_keeps_its_line_in_order():
    # a 9-byte command read at 1.0, then an ACK-less 15-byte frame read 0.5 ms later:
    # back-dated by 15 byte times it would start 15.1 ms before the command ended
    d = Deframer("B", byte_time=BT_9600)
    (first,) = d.feed(CMD, 1.0 - 9 * BT_9600)
    (second,) = d.feed(RES, 1.0005 - 15 * BT_9600)
    assert second.t == pytest.approx(first.t_end) and second.t_end == pytest.approx(1.0005)
    assert d.last_end == pytest.approx(1.0005)
    # and not before a time the caller gives (the other line's latest read, one clock)
    (third,) = d.feed(b"\x06", 1.0006 - BT_9600, not_before=1.0010)
    assert third.t == pytest.approx(1.0010) and third.t_end == pytest.approx(1.0010)


def test_bytes_a_live_tap_passed_over_stay_undecoded_with_the_lines_swapped():
    # a tap behind the line hands its backlog over undecoded (for the recording
    # only): read on physical line B, which --swap-lines makes line A, the two
    # commands in it must not become events, whichever line they count on
    from analyzer.sources.serialport import UndecodedChunk

    class Behind(Timed):
        def chunks(self) -> Iterator[Chunk]:
            yield UndecodedChunk("B", CMD + CMD, 0.05)

    for swap in (False, True):
        cap = Capture(Behind([]), Options(swap_lines=swap))
        events = list(cap)
        assert [e for e in events if e.kind == "command"] == [], f"swap_lines={swap}"
        assert cap.undecoded == {("A" if swap else "B"): 2 * len(CMD)}
