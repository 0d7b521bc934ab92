"""The pairing record (``analyzer.analysis.pairing.Transaction``): one per command, what
its answers are, referenced by the command and every answer linked to it.
Events are built by hand at 9600 baud, so latencies follow from byte times:
10 bits a byte (8N1), a frame's payload plus 7 bytes of header and checksum."""

import json

import pytest
from mcap.reader import make_reader

from analyzer.analysis.pairing import Pairer, Timeouts, Transaction
from analyzer.writers.mcap_recorder import McapRecorder
from dissectors.event import ACK, COMMAND, NAK, NIC, RESULT, Event

BAUD = 9600
BT = 10 / BAUD          # seconds a byte takes on the wire


def frame(kind, dst, src, payload: bytes, t: float, line: str) -> Event:
    body = bytes([*dst, src, len(payload)]) + payload
    raw = b"\xf8" + body + bytes([sum(body) & 0xFF])
    ev = Event(line, 0, kind, raw, t, t + len(raw) * BT)
    ev.dst, ev.src, ev.payload, ev.checksum_ok = tuple(dst), src, payload, True
    return ev


def command(payload: bytes, t: float, dst=(1, 1, 1)) -> Event:
    return frame(COMMAND, dst, 0, payload, t, "A")


def result(payload: bytes, t: float, dst=(0, 1, 1)) -> Event:
    return frame(RESULT, dst, 1, payload, t, "B")


def answer(kind: str, t: float) -> Event:
    return Event("B", 0, kind, {ACK: b"\x06", NAK: b"\x15", NIC: b"?"}[kind], t, t + BT)


def paired(*events: Event, **timeouts) -> list[Event]:
    pairer = Pairer(Timeouts(**timeouts))
    out = pairer.push_many(list(events))
    return out + pairer.finish()


def test_an_acked_query_and_its_result_share_one_record():
    cmd = command(b"P?", 0.0)                      # 9 bytes: ends at 9 byte times
    ack = answer(ACK, 0.012)
    res = result(b"0FA0FC18", 0.014)               # 15 bytes
    paired(cmd, ack, res)
    txn = cmd.transaction
    assert isinstance(txn, Transaction)
    assert ack.transaction is txn and res.transaction is txn
    assert (txn.number, txn.request, txn.command, txn.device) == (1, 1, "P?", "1.1.1")
    assert (txn.status, txn.settled, txn.retransmission) == ("ok", True, False)
    assert (txn.ack, txn.nic, txn.result) == (2, None, 3) and txn.answers == [2, 3]
    assert txn.ack_latency == pytest.approx(0.012 - 9 * BT)
    assert txn.result_latency == pytest.approx(0.014 - 9 * BT)
    # the events agree with their record; an ACK's device is its transaction's
    assert ack.txn == res.txn == txn.number and ack.request == res.request == cmd.number
    assert ack.latency == txn.ack_latency and res.latency == txn.result_latency
    assert ack.device == "1.1.1" and ack.dst is None


def test_a_nak_is_the_records_ack():
    cmd = command(b"HO", 0.0, dst=(1, 1, 2))       # 9 bytes
    nak = answer(NAK, 0.0150)
    paired(cmd, nak)
    txn = cmd.transaction
    assert nak.transaction is txn and txn.status == "nak" and txn.device == "1.1.2"
    assert (txn.ack, txn.nic, txn.result) == (2, None, None)
    assert txn.ack_latency == pytest.approx(0.0150 - 9 * BT)
    assert nak.device == "1.1.2"


def test_a_nic_after_the_ack():
    cmd = command(b"V?", 0.0)                      # 9 bytes
    ack, nic = answer(ACK, 0.011), answer(NIC, 0.011 + BT)
    paired(cmd, ack, nic)
    txn = cmd.transaction
    assert nic.transaction is txn and txn.status == "nic"
    assert (txn.ack, txn.nic, txn.result) == (2, 3, None) and txn.answers == [2, 3]
    assert txn.ack_latency == pytest.approx(0.011 - 9 * BT) and txn.result_latency is None
    assert nic.latency == pytest.approx(0.011 + BT - 9 * BT)


def test_a_timeout_and_the_late_ack_it_still_links():
    cmd = command(b"HO", 0.0)                      # ends at 9 byte times; ACK due 0.2 s later
    late = answer(ACK, 0.5)
    paired(cmd, late, ack=0.2)
    txn = cmd.transaction
    assert txn.status == "no_ack"                  # the late ACK does not change it
    assert late.transaction is txn and txn.ack == 2 and txn.answers == [2]
    assert txn.ack_latency == pytest.approx(0.5 - 9 * BT)


def test_an_unanswered_command_keeps_an_empty_record():
    first, second = command(b"HO", 0.0), command(b"PL", 1.0)
    paired(first, second, ack=0.2)
    txn = first.transaction
    assert txn.status == "no_ack" and txn.answers == []
    assert txn.ack_latency is None and txn.result_latency is None
    assert second.transaction.number == 2 and second.transaction.status == "pending"


def test_a_retransmission_gets_its_own_record():
    first, nak = command(b"HO", 0.0), answer(NAK, 0.012)
    again, ack = command(b"HO", 0.05), answer(ACK, 0.05 + 9 * BT + 0.004)
    paired(first, nak, again, ack)
    assert first.transaction.status == "nak" and not first.transaction.retransmission
    txn = again.transaction
    assert txn is not first.transaction and txn.number == 2
    assert txn.retransmission and txn.status == "ok" and txn.ack == 4
    assert txn.ack_latency == pytest.approx(0.004)


def test_orphans_have_no_record():
    ack = answer(ACK, 0.0)
    res = result(b"0FA0FC18", 0.01)
    paired(ack, res)
    for ev in (ack, res):
        assert ev.transaction is None and ev.txn is None and ev.request is None
    assert ack.device is None
    assert res.device == "1.1.1"                   # a result names its sender itself


def test_the_record_holds_no_event():
    # the events reference the record: a reference back would make each command
    # a cycle, which reference counting does not free
    cmd, ack, res = command(b"P?", 0.0), answer(ACK, 0.012), result(b"0FA0FC18", 0.014)
    paired(cmd, ack, res)
    assert not any(isinstance(getattr(cmd.transaction, name), Event) for name in Transaction.__slots__)


def test_the_recording_writes_each_transaction_from_its_record(tmp_path):
    """/transactions: a result that comes after the next command is not in its
    command's message (the message is written when the next command comes)."""
    events = paired(command(b"P?", 0.0), answer(ACK, 0.011),
                    command(b"HO", 0.02, dst=(1, 1, 2)), answer(ACK, 0.035),
                    result(b"0FA0FC18", 0.04))
    path = tmp_path / "txn.mcap"
    with McapRecorder(str(path), metadata={}, start_time=0.0) as recorder:
        for ev in events:
            recorder.event(ev)
    with open(path, "rb") as f:
        messages = [json.loads(m.data) for _s, _c, m in make_reader(f).iter_messages(topics=["/transactions"])]
    assert [(m["txn"], m["command"], m["device"], m["status"], m["answers"]) for m in messages] == [
        (1, "P?", "1.1.1", "ok", [2]), (2, "HO", "1.1.2", "ok", [4])]
    assert messages[0]["ack_latency"] == pytest.approx(0.011 - 9 * BT)
    assert "result_latency" not in messages[0] and messages[0]["fields"] == {}   # no value: no key
    assert events[0].transaction.result == 5       # the record has it all the same
