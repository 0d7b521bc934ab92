"""The TUI's event store: events kept in columns and rebuilt on demand must be
the events that were stored, field for field, whatever the wire held."""

from __future__ import annotations

import pytest

import analyzer
from analyzer.formats.store import EventStore
from analyzer.simulation.traffic import generate
from analyzer.tui.model.plots import Series
from dissectors.event import ACK, COMMAND, NOISE, RATE, Event
from tests.conftest import frame

SAMPLES = [("captures/demo-ctl.bin", "captures/demo-dev.bin"), ("captures/demo-socat.log",),
           ("captures/demo-bus.bin",)]


def same(rebuilt: Event, ev: Event) -> None:
    assert rebuilt.to_dict() == ev.to_dict()
    assert rebuilt.entry is ev.entry
    assert (rebuilt.transaction is None) == (ev.transaction is None)
    if ev.transaction is not None:
        assert (rebuilt.transaction.command, rebuilt.transaction.device) == \
            (ev.transaction.command, ev.transaction.device)


def check(events: list[Event], batches: int = 3) -> EventStore:
    store = EventStore()
    step = max(1, len(events) // batches)
    for k in range(0, len(events), step):
        store.append(events[k:k + step])
    assert len(store) == len(events)
    for i, ev in enumerate(events):
        same(store.event(i), ev)
    return store


@pytest.mark.parametrize("paths", SAMPLES, ids=lambda p: p[0].split("/")[-1])
def test_sample_captures_come_back_whole(paths):
    events = list(analyzer.open(*paths))
    store = check(events)
    # the error keys stop where the old index did: problems, NAKs, noise, commands not ok
    expected = [e.number for e in events if e.problems or e.kind in ("nak", "noise")
                or e.status in ("nak", "nic", "no_ack", "no_result")]
    assert list(store.errors) == expected


def test_a_hostile_line_comes_back_whole(tmp_path):
    # bit errors, dropped ACKs and noise: broken frames, orphans, retransmissions
    tr = generate(600, baud=9600, seed=7, bit_error_rate=0.03, drop_ack_rate=0.05, noise_rate=0.05)
    (tmp_path / "bus.bin").write_bytes(tr.single_line())
    (tmp_path / "a.bin").write_bytes(tr.line_bytes("A"))
    (tmp_path / "b.bin").write_bytes(tr.line_bytes("B"))
    single = list(analyzer.open(str(tmp_path / "bus.bin")))
    two = list(analyzer.open(str(tmp_path / "a.bin"), str(tmp_path / "b.bin")))
    for events in (single, two):
        assert any(e.problems for e in events) and any(e.kind == NOISE for e in events)
        check(events)


@pytest.mark.parametrize("paths", SAMPLES, ids=lambda p: p[0].split("/")[-1])
def test_the_store_names_the_value_of_each_code(paths):
    """What the store's readers (statistics, filters) read: each column of codes
    with the value each code stands for."""
    events = list(analyzer.open(*paths))
    store = check(events)
    lines, devices, commands = store.line_values, store.device_values, store.command_ids
    assert lines[0] is devices[0] is commands[0] is None   # code 0: none
    for i, ev in enumerate(events):
        assert lines[store.column("line")[i]] == ev.line
        assert devices[store.column("device")[i]] == ev.device
        assert commands[store.column("command")[i]] == ev.command
    with pytest.raises(KeyError):
        store.column("raw")   # not a column of one value an event


def test_answers_are_chained_to_their_command():
    # P? to 1.1.1 (Table 15): ACK then a result; the next command is unanswered
    cmd = Event("A", 0, COMMAND, frame((1, 1, 1), 0, "P?"), 0.0, 0.01, (1, 1, 1), 0, b"P?", True)
    ack = Event("B", 0, ACK, b"\x06", 0.012, 0.013)
    res = Event("B", 1, "result", frame((0, 1, 1), 1, "03E8FE0C"), 0.02, 0.03, (0, 1, 1), 1, b"03E8FE0C", True)
    other = Event("A", 9, COMMAND, frame((1, 1, 2), 0, "HO"), 0.1, 0.11, (1, 1, 2), 0, b"HO", True)
    for n, ev in enumerate((cmd, ack, res, other), 1):
        ev.number = n
    ack.request = res.request = 1
    store = EventStore()
    store.append([cmd, ack, res, other])
    assert store.answers_of(1) == [2, 3]
    assert store.answers_of(1, upto=2) == [2]
    assert store.answers_of(4) == []


def test_what_dissection_cannot_give_back_is_kept():
    # a rate change's fields are not a payload's decode; an untimed event has no time
    rate = Event("A", 0, RATE, b"", 1.0, 1.0)
    rate.fields = {"baud": 115200, "previous_baud": 9600}
    untimed = Event("B", 5, NOISE, b"\x00\x01")
    untimed.add_problem("noise", "2 bytes outside any frame")
    for n, ev in enumerate((rate, untimed), 1):
        ev.number = n
    store = check([rate, untimed], batches=1)
    assert store.event(1).t is None and store.event(1).problems == untimed.problems
    assert store.t[1] == 1.0   # the timeline's order: the index


def test_series_reads_as_points():
    s = Series()
    s.append(1.5, 10.0)
    s.append(2.0, -5.0)
    assert len(s) == 2 and s[1] == (2.0, -5.0) and list(s) == [(1.5, 10.0), (2.0, -5.0)]


def test_offsets_past_4_gb_widen_their_column():
    # a line read for days: byte offsets beyond 32 bits
    far = Event("A", 5_000_000_000, NOISE, b"\x00", 1.0, 1.0)
    far.add_problem("noise", "1 byte outside any frame")
    near = Event("A", 7, NOISE, b"\x00", 0.5, 0.5)
    near.add_problem("noise", "1 byte outside any frame")
    near.number, far.number = 1, 2
    store = check([near, far], batches=2)
    assert store.event(1).offset == 5_000_000_000 and store.event(0).offset == 7


def commands_to_many_devices(n: int = 70_000) -> list[Event]:
    """``HO`` to ``n`` addresses, one each: garbled input can name any of 256³."""
    events = []
    for k in range(1, n + 1):
        dst = (k >> 16, (k >> 8) & 0xFF, k & 0xFF)
        raw = frame(dst, 0, "HO")
        ev = Event("A", k * len(raw), COMMAND, raw, None, None, dst, 0, b"HO", True)
        ev.number = k
        events.append(ev)
    return events


def test_more_devices_than_a_16_bit_code_widens_the_column():
    events = commands_to_many_devices()
    store = EventStore()
    store.append(events[:60_000])
    store.append(events[60_000:])
    assert store.device.itemsize >= 4
    for i in (0, 65_534, 65_535, 69_999):
        assert store.event(i).device == events[i].device == f"{(i + 1) >> 16}.{((i + 1) >> 8) & 0xFF}.{(i + 1) & 0xFF}"
