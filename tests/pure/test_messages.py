"""Topic messages (analyzer/formats/mcap_messages.py), their schemas, and the
per-device position topic (analyzer/analysis/positions.py).

Frames are built by hand (Table 1) and decoded through the real pipeline from
two raw dumps; expected values follow from the payloads: positions are signed
16-bit hundredths of a degree in ASCII hex (Table 15), so ``0FA0`` is 40.00°
and ``FC18`` is -10.00°.
"""

from __future__ import annotations

import base64
import json

import jsonschema
import pytest

import analyzer
from analyzer.analysis.positions import PositionTracker
from analyzer.formats import mcap_schemas as S
from analyzer.formats.mcap_messages import Messages, event_message
from analyzer.output import dumps
from dissectors.commands import field_types
from dissectors.dissect import dissect_command
from tests.conftest import frame

ACK = b"\x06"


def validator(key: str) -> jsonschema.Draft202012Validator:
    schema = S.SCHEMAS[key]
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def as_written(msg: dict) -> dict:
    """The message as a reader sees it: JSON (tuples become arrays)."""
    return json.loads(dumps(msg))


def decoded(tmp_path, exchanges) -> list:
    """Events of (command frame, answer bytes) exchanges, from two raw dumps."""
    a, b = tmp_path / "a.bin", tmp_path / "b.bin"
    a.write_bytes(b"".join(cmd for cmd, _ in exchanges))
    b.write_bytes(b"".join(ans for _, ans in exchanges))
    return list(analyzer.open(str(a), str(b), baud=9600))


def go_to(dev, az_hex, el_hex):
    return frame((1, 1, dev), 0, "P" + az_hex + el_hex), ACK


def where_is(dev, az_hex, el_hex):
    return frame((1, 1, dev), 0, "P?"), ACK + frame((0, 1, dev), 1, az_hex + el_hex)   # to the MCU, from group 1


# ------------------------------------------------------------------ schemas

def test_an_empty_object_is_no_event_and_nulls_are_refused():
    event = validator("event")
    assert not event.is_valid({})
    good = {"number": 1, "line": "A", "offset": 0, "kind": "command", "fields": {}, "problems": [],
            "retransmission": False}
    assert event.is_valid(good)
    assert not event.is_valid({**good, "t_end": None})                # optional means absent
    # the time is the message's log time, the bytes are on the raw topic: neither is repeated
    assert not event.is_valid({**good, "t": 0.5})
    assert not event.is_valid({**good, "raw": base64.b64encode(b"\xf8").decode()})
    assert not event.is_valid({**good, "fields": {"azimuth_deg": "12"}})   # a number (Table 15)
    assert not event.is_valid({**good, "fields": {"no_such_field": 1}})
    assert not event.is_valid({**good, "kind": "frame"})               # a paired event's kinds only


def test_each_field_name_has_one_type():
    types = field_types()
    assert types["azimuth_deg"].type == "number" and types["azimuth_deg"].unit == "deg"
    assert types["baud"].type == "integer" and types["baud"].unit == "bps"
    assert types["vector"].type == "boolean" and types["parity"].type == "string"
    assert types["relays_on"].type == "array" and types["relays_on"].items == "integer"
    described = S.FIELDS["properties"]["rate_deg_s"]["description"]
    assert described.startswith("number, deg/s") and "RP" in described


def test_an_unknown_choice_has_no_value_and_is_out_of_range():
    assert dissect_command(b"VM1").fields == {"vector": True}
    bad = dissect_command(b"VM2")
    assert bad.fields == {"vector": None}
    assert any(p.startswith("value out of range: vector") for p in bad.problems)


def test_event_messages_leave_out_what_has_no_value_or_is_held_elsewhere(tmp_path):
    cmd = frame((1, 1, 1), 0, "C9")          # C9: a reserved rate code, no baud (Table 4)
    events = decoded(tmp_path, [(cmd, ACK), go_to(1, "0FA0", "FC18")])
    event = validator("event")
    for ev in events:
        msg = event_message(ev)
        assert event.is_valid(as_written(msg)), msg
        # every JSON Lines key with a value, less t (the log time) and raw (the raw topic)
        assert {k for k, v in ev.to_dict().items() if v is not None} - {"t", "raw"} == set(msg)
    rate_set = events[0]
    assert rate_set.fields["baud"] is None and "baud" not in event_message(rate_set)["fields"]
    assert event_message(rate_set)["fields"] == {"rate_code": 9}
    # the ACK's bytes are where its line and offset say: line B, byte 0
    ack = event_message(events[1])
    assert (ack["line"], ack["offset"], ack["kind"]) == ("B", 0, "ack")


def test_messages_go_to_their_topics_with_capture_times(tmp_path):
    events = decoded(tmp_path, [where_is(2, "0FA0", "FC18")])
    seen = []
    messages = Messages(lambda *m: seen.append(m), start_time=1000.0, wire_byte_time=10 / 9600)
    for ev in events:
        messages.event(ev)
    messages.finish()
    topics = [topic for topic, _key, _ts, _msg in seen]
    assert topics == ["/events", "/events", "/events", "/gimbal/1.1.2/position", "/transactions"]
    for topic, key, ts, msg in seen:
        assert validator(key).is_valid(as_written(msg)), (topic, msg)
        assert ts >= 1000 * 10**9
    txn = seen[-1][3]
    assert txn["command"] == "P?" and txn["answers"] == [2, 3] and txn["status"] == "ok"


# ---------------------------------------------------------------- positions

def positions(events) -> list[tuple[str, dict]]:
    tracker = PositionTracker()
    return [p for p in map(tracker.see, events) if p is not None]


def test_a_target_then_reports_on_the_devices_topic(tmp_path):
    events = decoded(tmp_path, [go_to(12, "0FA0", "FC18"), where_is(12, "07D0", "FE0C")])
    out = positions(events)
    assert [(dev, m["source"]) for dev, m in out] == [("1.1.12", "command"), ("1.1.12", "result")]
    target = {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    assert out[0][1]["target"] == target and "reported" not in out[0][1]
    assert out[1][1]["reported"] == {"azimuth_deg": 20.0, "elevation_deg": -5.0}    # 07D0, FE0C
    assert out[1][1]["target"] == target                                           # still in force
    position = validator("position")
    assert all(position.is_valid(as_written(m)) for _dev, m in out)


def test_a_preset_target_is_known_once_its_position_was_read(tmp_path):
    go_preset = (frame((1, 1, 3), 0, "P05"), ACK)
    ask_preset = (frame((1, 1, 3), 0, "P?05"), ACK + frame((0, 1, 3), 1, "0BB80064"))
    events = decoded(tmp_path, [go_preset, ask_preset, go_preset])
    out = positions(events)
    assert len(out) == 1                                      # the first Pnn: preset 5 not known yet
    dev, msg = out[0]
    assert dev == "1.1.3" and msg["preset"] == 5
    assert msg["target"] == {"azimuth_deg": 30.0, "elevation_deg": 1.0}   # 0BB8 = 3000, 0064 = 100


def test_bad_checksums_and_wildcards_move_nothing(tmp_path):
    bad = bytearray(frame((1, 1, 1), 0, "P0FA0FC18"))
    bad[-1] ^= 0xFF
    wildcard = frame((1, 1, 255), 0, "P0FA0FC18")
    events = decoded(tmp_path, [(bytes(bad), b"\x15"), (wildcard, b"")])
    assert positions(events) == []


@pytest.mark.parametrize("lines", [1, 2])
def test_a_recording_has_one_position_topic_per_device(tmp_path, lines):
    from mcap.reader import make_reader

    from tests.conftest import run_cli

    exchanges = [go_to(1, "0FA0", "FC18"), where_is(2, "0000", "0000"), where_is(1, "07D0", "FE0C")]
    if lines == 2:
        decoded(tmp_path, exchanges)   # writes a.bin and b.bin
        inputs = [tmp_path / "a.bin", tmp_path / "b.bin"]
    else:
        bus = tmp_path / "bus.bin"
        bus.write_bytes(b"".join(c + a for c, a in exchanges))
        inputs = [bus]
    out = tmp_path / "rec.mcap"
    r = run_cli("convert", *inputs, "--baud", "9600", "-o", out)
    assert r.returncode == 0, r.stderr
    with open(out, "rb") as f:
        found = [(c.topic, json.loads(m.data)) for _s, c, m in make_reader(f).iter_messages()
                 if c.topic.startswith("/gimbal/")]
    assert [(t, m["source"]) for t, m in found] == [
        ("/gimbal/1.1.1/position", "command"), ("/gimbal/1.1.2/position", "result"),
        ("/gimbal/1.1.1/position", "result")]
    assert found[2][1]["reported"] == {"azimuth_deg": 20.0, "elevation_deg": -5.0}
