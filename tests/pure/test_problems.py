"""Problems carry ids (dissectors.problems): every problem the deframer, the
dissectors and pairing attach has one from the table, while its text stays the
"category: detail" of the JSON Lines contract (docs/decoding.md, "Problems").
Captures are built by hand, byte by byte, and decoded by the real pipeline."""

import json
import os
import pickle
import re

import orjson
import pytest

from analyzer.analysis.pairing import Pairer, Timeouts
from dissectors import Deframer, problems
from dissectors.event import P_CHECKSUM, P_UNANSWERED, Event
from dissectors.problems import Problem
from tests.conftest import ROOT, frame

BT = 0.001          # one byte per millisecond
CTL, DEV = 0, 1     # controller and device groups
ACK, NAK, NIC = b"\x06", b"\x15", b"?"


def cmd(payload, device=1):
    return frame((DEV, 1, device), CTL, payload)


def result(payload, device=1):
    return frame((CTL, 1, device), DEV, payload)   # groups swapped (Table 3)


def decode(*items, timed=True, **timeouts):
    """``items``: (t, line, bytes). Each line is deframed, then everything is paired
    in time order (untimed: in the order given)."""
    lines = {"A": Deframer("A", byte_time=BT), "B": Deframer("B", byte_time=BT)}
    events = []
    for t, line, data in items:
        events += lines[line].feed(data, t if timed else None)
    for d in lines.values():
        events += d.finish()
    if timed:
        events.sort(key=lambda e: e.t)
    pairer = Pairer(Timeouts(**timeouts))
    out = pairer.push_many(events) + pairer.finish()
    assert_all_have_ids(out)
    return out


def deframe(data, line="A"):
    """The deframer's events for ``data``, read as one chunk at time 0."""
    d = Deframer(line, byte_time=BT)
    events = d.feed(data, 0.0) + d.finish()
    assert_all_have_ids(events)
    return events


def assert_all_have_ids(events):
    for ev in events:
        for p in ev.problems:
            assert isinstance(p, Problem) and p.id in problems.TABLE, (ev, p)
            # the text starts with the category of the id
            assert p == p.id.text or p.startswith(p.id.text + ": ")


def ids(ev):
    return [p.id for p in ev.problems]


SEEN: set = set()   # every id the scenarios below produced (see the last test)


def only(ev, info):
    """The event carries exactly one problem, ``info``."""
    assert ids(ev) == [info], ev
    SEEN.add(info)
    return ev.problems[0]


# ---------------------------------------------------------------- the deframer
def test_bad_checksum_keeps_its_text():
    raw = bytearray(cmd("P?"))
    # checksum: sum of G P D S L and the payload, modulo 256 (§1.4.1.3)
    want = (DEV + 1 + 1 + CTL + 2 + ord("P") + ord("?")) & 0xFF
    assert want == 0x94
    raw[-1] = 0x92
    (ev,) = decode((0.0, "A", bytes(raw)))
    p = only(ev, problems.CHECKSUM)
    assert p == "bad checksum: expected 0x94, got 0x92"
    assert p.category is problems.CHECKSUM and ev.has_problem(problems.CHECKSUM)


def test_a_broken_frame_before_a_good_one_is_a_checksum_problem():
    # three bytes of a header, then a good frame: read from the first start byte,
    # the length byte is the good frame's port (1), and the checksum fails
    evs = deframe(b"\xf8\x01\x01" + cmd("HO"))
    assert only(evs[0], problems.CHECKSUM) == "bad checksum: broken frame, resynchronised on the frame at offset 3"
    assert evs[1].payload == b"HO" and evs[1].checksum_ok and evs[1].problems == ()


def test_bad_length_byte():
    raw = bytearray(cmd("HO"))
    raw[5] = 3                                 # says 3; the checksum holds with 2
    evs = deframe(bytes(raw) + cmd("HS"))
    p = only(evs[0], problems.LENGTH)
    assert p == "bad length byte: says 3, frame carries 2 payload bytes (the checksum holds with 2)"


def test_truncated_frame_and_header():
    raw = cmd("P0FA0FC18")                     # 9 payload bytes + 7 = 16
    (ev,) = decode((0.0, "A", raw[:10]))
    assert only(ev, problems.TRUNCATED) == "truncated frame: 10 of 16 bytes, then end of capture"
    (ev,) = decode((0.0, "A", raw[:3]))
    assert only(ev, problems.TRUNCATED) == "truncated frame: header cut after 3 bytes"


def test_noise():
    (ev,) = decode((0.0, "A", b"\x00\x01\x02"))
    assert only(ev, problems.NOISE) == "noise: 3 bytes outside any frame"


# -------------------------------------------------------------- the dissectors
def command_problems(payload):
    evs = decode((0.0, "A", cmd(payload)), (0.02, "B", ACK))
    return evs[0]


PAYLOADS = [
    ("P?zz", problems.MALFORMED),              # P?nn wants two hex digits
    ("QX", problems.UNKNOWN_COMMAND),
    ("L0", problems.RESERVED),                 # relay 0 is "Reserved" (Table 4)
    ("C9", problems.RESERVED),                 # rate codes C8..CF are reserved
    ("GRP01", problems.OUT_OF_RANGE),          # gain 0.1 < 0.3 (Table 7)
    ("*x0c,9600,8,1,5", problems.OUT_OF_RANGE),    # parity 5 is none of 0, 1, 2 (Table 18)
    ("*x0t" + "A" * 201, problems.OUT_OF_RANGE),   # more than 200 data bytes (Table 16)
    ("P0fa0fc18", problems.LOWERCASE_HEX),
]


@pytest.mark.parametrize("payload, info", PAYLOADS)
def test_payload_problems(payload, info):
    ev = command_problems(payload)
    assert ids(ev)[0] is info
    SEEN.add(info)


def test_malformed_and_reserved_results():
    evs = decode((0.0, "A", cmd("P?")), (0.02, "B", ACK), (0.03, "B", result("XYZ")))
    assert only(evs[2], problems.MALFORMED).startswith("malformed payload: expected ")
    evs = decode((0.0, "A", cmd("AW")), (0.02, "B", ACK), (0.03, "B", result("10")))
    assert only(evs[2], problems.RESERVED) == "reserved code: status bits 4..7 are reserved (Table 5)"


# ------------------------------------------------------------------ pairing
def test_unanswered_by_timeout_then_a_late_answer():
    c, a = decode((0.0, "A", cmd("HO")), (0.8, "B", ACK))      # the ACK timeout is 0.5 s
    assert only(c, problems.UNANSWERED_TIMEOUT) == "unanswered: no ACK/NAK within 500 ms"
    assert only(a, problems.LATE) == "late answer: after the 500 ms ACK timeout"
    assert c.has_problem(problems.UNANSWERED) and c.has_problem(P_UNANSWERED)


def test_unanswered_superseded_by_the_next_command():
    evs = decode((0.0, "A", cmd("HO")), (0.1, "A", cmd("HS")), (0.12, "B", ACK))
    p = only(evs[0], problems.UNANSWERED_SUPERSEDED)
    assert p == "unanswered: no ACK/NAK before the next command"
    assert p.id is problems.UNANSWERED_SUPERSEDED and p.category is problems.UNANSWERED
    assert not evs[0].has_problem(problems.UNANSWERED_TIMEOUT)


def test_a_result_without_its_ack():
    c, r = decode((0.0, "A", cmd("P?")), (0.02, "B", result("0FA0FC18")))
    assert only(c, problems.UNANSWERED_NO_ACK) == "unanswered: no ACK seen, but the result arrived"
    assert r.problems == ()


def test_missing_result_by_timeout_and_by_sending_again():
    evs = decode((0.0, "A", cmd("P?")), (0.02, "B", ACK), (3.0, "A", cmd("HO")), (3.02, "B", ACK))
    assert only(evs[0], problems.NO_RESULT_TIMEOUT) == "missing result: none within 2 s of the ACK"
    evs = decode((0.0, "A", cmd("P?")), (0.02, "B", ACK), (0.1, "A", cmd("P?")), (0.12, "B", ACK),
                 (0.13, "B", result("0FA0FC18")))
    p = only(evs[0], problems.NO_RESULT_SENT_AGAIN)
    assert p == "missing result: the command was sent again before it came"
    assert evs[0].has_problem(problems.NO_RESULT) and not evs[0].has_problem(problems.NO_RESULT_TIMEOUT)
    # the second copy repeats the bytes of one that failed
    assert only(evs[2], problems.RETRANSMISSION) == "retransmission: repeats #1 after no_result"


def test_missing_result_untimed_after_the_window_of_commands():
    items = [(None, "A", cmd("P?")), (None, "B", ACK)]
    for k in range(33):
        items += [(None, "A", cmd("HO")), (None, "B", ACK)]
    evs = decode(*items, timed=False)
    assert only(evs[0], problems.NO_RESULT_TIMEOUT) == "missing result: none within the next 32 commands"


def test_missing_result_when_too_many_wait():
    items = []
    for device in range(1, 66):               # 65 queries from 65 devices, each ACKed
        t = device * 0.02
        items += [(t, "A", cmd("P?", device)), (t + 0.015, "B", ACK)]
    evs = decode(*items)
    assert only(evs[0], problems.NO_RESULT_OVERFLOW) == "missing result: too many commands waiting for results"


def test_retransmission_after_a_nak():
    evs = decode((0.0, "A", cmd("HO")), (0.02, "B", NAK), (0.1, "A", cmd("HO")), (0.12, "B", ACK))
    assert only(evs[2], problems.RETRANSMISSION) == "retransmission: repeats #1 after nak"


def test_orphans():
    (a,) = decode((0.0, "B", ACK))
    assert only(a, problems.ORPHAN) == "orphan: no command awaits an ACK/NAK"
    (q,) = decode((0.0, "B", NIC))
    assert only(q, problems.ORPHAN) == "orphan: NIC not right after an ACK"
    (r,) = decode((0.0, "B", result("0FA0FC18")))
    assert only(r, problems.ORPHAN) == "orphan: no command awaits this result"


# ------------------------------------------------------- the value and the table
def test_json_writes_a_problem_as_its_plain_text():
    p = problems.CHECKSUM.problem("expected 0x94, got 0x92")
    assert p == "bad checksum: expected 0x94, got 0x92" and "bad checksum: expected 0x94, got 0x92" == p
    assert hash(p) == hash("bad checksum: expected 0x94, got 0x92")
    assert json.dumps([p]) == '["bad checksum: expected 0x94, got 0x92"]'
    assert orjson.dumps([p]) == b'["bad checksum: expected 0x94, got 0x92"]'
    ev = Event("A", 0, "command", b"")
    ev.note(p)
    assert json.loads(orjson.dumps(ev.to_dict()))["problems"] == ["bad checksum: expected 0x94, got 0x92"]


def test_pickle_keeps_the_id():
    p = problems.UNANSWERED_SUPERSEDED.problem("no ACK/NAK before the next command")
    q = pickle.loads(pickle.dumps(p, protocol=pickle.HIGHEST_PROTOCOL))
    assert q == p == "unanswered: no ACK/NAK before the next command"
    assert q.id is problems.UNANSWERED_SUPERSEDED and q.category is problems.UNANSWERED
    assert pickle.loads(pickle.dumps(problems.LATE)) is problems.LATE
    (ev,) = decode((0.0, "A", b"\x00\x01"))
    back = pickle.loads(pickle.dumps(ev))
    assert back.problems == ["noise: 2 bytes outside any frame"] and back.problems[0].id is problems.NOISE


def test_plain_strings_get_their_category_id_and_unknown_categories_are_refused():
    ev = Event("A", 0, "command", b"")
    ev.note("unknown command: one")
    ev.add_problem(P_CHECKSUM, "two")
    assert ids(ev) == [problems.UNKNOWN_COMMAND, problems.CHECKSUM]
    assert ev.problems == ["unknown command: one", "bad checksum: two"]
    with pytest.raises(ValueError):
        ev.note("something else: three")


def test_the_table():
    names = [info.name for info in problems.TABLE]
    assert len(set(names)) == len(names)
    for info in problems.TABLE:
        assert getattr(problems, info.name) is info
        assert info.severity in ("error", "warning", "note") and info.summary
        if info.parent is not None:      # a sub-case shares its category's text
            assert info.parent.parent is None and info.text == info.parent.text
    # the categories are the ones docs/decoding.md lists
    with open(os.path.join(ROOT, "docs", "decoding.md"), encoding="utf-8") as f:
        doc = f.read()
    listed = doc[doc.index("### Problems"):]
    listed = listed[listed.index("Categories:"):]
    listed = listed[:listed.index(".\n")]
    assert set(re.findall(r"`([^`]+)`", listed)) == {i.text for i in problems.TABLE if i.parent is None}


def test_line_faults_land_on_the_event_holding_their_byte():
    # a command (byte offsets 0-14 on line A), then its ACK on line B: the
    # receiver's errors are told at byte offsets, as a logic capture's UART or a
    # USB adapter's line status tells them (analyzer/capture/faults.py)
    from analyzer.capture.faults import with_faults
    from analyzer.lines import LineFault

    command = cmd(b"P?")
    a, b = Deframer("A", byte_time=BT), Deframer("B", byte_time=BT)
    faults = [LineFault("A", 3, problems.LINE_FRAMING.problem("stop bit low")),
              LineFault("B", 0, problems.LINE_PARITY.problem("parity bit wrong"))]
    batches = [a.feed(command, 0.0) + a.finish(), b.feed(ACK, 0.02) + b.finish()]
    later = [LineFault("A", len(command) + 1, problems.LINE_BREAK.problem("held low 3 bytes")),
             LineFault("A", len(command) + 1, problems.LINE_OVERRUN.problem("lost bytes"))]
    noise = Deframer("A", byte_time=BT)
    noise.feed(command, 0.0)
    batches.append(noise.feed(b"\x00\x00", 0.5) + noise.finish())

    def source_reading():   # faults are told before the chunk holding their byte
        yield batches[0]
        yield batches[1]
        faults.extend(later)
        yield batches[2]

    out = [ev for batch in with_faults(source_reading(), faults, lambda: False) for ev in batch]
    assert_all_have_ids(out)
    command_ev, ack_ev, noise_ev = out
    only(command_ev, problems.LINE_FRAMING)
    only(ack_ev, problems.LINE_PARITY)
    assert ids(noise_ev) == [problems.NOISE, problems.LINE_BREAK, problems.LINE_OVERRUN]
    SEEN.update({problems.LINE_BREAK, problems.LINE_OVERRUN})
    assert command_ev.problems == ["line error: stop bit low"]


def test_line_faults_follow_a_swap_of_the_lines():
    from analyzer.capture.faults import with_faults
    from analyzer.lines import LineFault

    a = Deframer("A", byte_time=BT)   # read as line A: wired as line B
    batch = a.feed(cmd(b"P?"), 0.0) + a.finish()
    faults = [LineFault("B", 0, problems.LINE_FRAMING.problem("x"))]
    (ev,) = [ev for b in with_faults(iter([batch]), faults, lambda: True) for ev in b]
    assert ids(ev) == [problems.LINE_FRAMING]


def test_every_id_is_produced_somewhere():
    # run every scenario of this file again (in whatever order or selection pytest
    # ran them): together they must produce every id of the table
    SEEN.clear()
    scenarios = [f for name, f in globals().items()
                 if name.startswith("test_") and callable(f) and f.__code__.co_argcount == 0
                 and f is not test_every_id_is_produced_somewhere]
    for scenario in scenarios:
        scenario()
    for payload, info in PAYLOADS:
        test_payload_problems(payload, info)
    categories_only = {problems.UNANSWERED, problems.NO_RESULT, problems.LINE}   # always made as a sub-case
    assert SEEN == set(problems.TABLE) - categories_only
