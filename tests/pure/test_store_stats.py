"""The statistics have one definition (``Stats.add_columns``, analyzer/analysis/stats.py)
and two drivers: events counted as they come, in batches (``gimbalscope stats``),
and the TUI store's columns (analyzer/formats/store_stats.py, ``stats_of``).

The figures are right by hand on a small capture built by hand; a capture counted
in batches of any size, or one event at a time, has the statistics of its events
counted as one batch, whenever they are read; and
the store's columns (of every event, of the first part, of a filtered view's rows)
give the statistics of the same events: every count, every latency bucket, on the
sample captures and hostile lines. The device map (``devices_of``) likewise: right
by hand, and the same however the store was filled."""

from __future__ import annotations

import pytest

import analyzer
from analyzer.analysis.filter import compile_filter
from analyzer.analysis.stats import BATCH, EventColumns, Stats
from analyzer.formats.store import EventStore
from analyzer.formats.store_stats import devices_of, stats_of
from analyzer.listeners import StatsListener
from analyzer.simulation.traffic import generate
from dissectors.event import Event
from tests.pure.test_pairing import cmd, res, run, simple

SAMPLES = [("captures/demo-ctl.bin", "captures/demo-dev.bin"), ("captures/demo-socat.log",),
           ("captures/demo-bus.bin",)]
CAPTURES = [*range(len(SAMPLES)), "hostile two lines", "hostile one line"]


def counted(events, batch: int | None = None) -> dict:
    """The statistics of ``events``, counted as one batch or in batches of ``batch``."""
    s = Stats()
    step = batch or max(1, len(events))
    for k in range(0, len(events), step):
        s.add_events(events[k:k + step])
    return s.to_dict()


def hostile(tmp_path) -> tuple[str, ...]:
    tr = generate(600, baud=9600, seed=7, bit_error_rate=0.03, drop_ack_rate=0.05, noise_rate=0.05)
    (tmp_path / "a.bin").write_bytes(tr.line_bytes("A"))
    (tmp_path / "b.bin").write_bytes(tr.line_bytes("B"))
    (tmp_path / "bus.bin").write_bytes(tr.single_line())
    return str(tmp_path / "a.bin"), str(tmp_path / "b.bin")


def capture(which, tmp_path) -> list[Event]:
    if which == "hostile two lines":
        paths = hostile(tmp_path)
    elif which == "hostile one line":
        hostile(tmp_path)
        paths = (str(tmp_path / "bus.bin"),)
    else:
        paths = SAMPLES[which]
    return list(analyzer.open(*paths))


def stored(events, batch: int = 50) -> EventStore:
    store = EventStore()
    for k in range(0, len(events), batch):
        store.append(events[k:k + batch])
    return store


def by_hand() -> list[Event]:
    """Four gimbal conversations, an orphan, noise, a broken frame, a NIC and a rate
    change; a command is 9 bytes, a result 15, a handshake 1 (test_pairing.py)."""
    noise = Event("B", 0, "noise", b"\x00\x01\x02", 1.5, 1.503)
    noise.note("noise")
    broken = Event("B", 3, "noise", b"\xf8\x01\x01", 1.6, 1.603)   # a frame broken beyond reading
    broken.note("bad checksum: 0x12, expected 0x34")
    rate = Event("A", 0, "rate", b"", 2.8, 2.8)
    rate.fields = {"previous_baud": 9600, "baud": 19200}
    return run([cmd(b"P?", 0.0), simple("ack", 0.012), res(b"0FA0FC18", 0.015),   # ok: ACK 3 ms, result 6 ms
                cmd(b"HO", 1.0, dst=(1, 1, 2)), simple("nak", 1.019),              # nak after 10 ms
                simple("nic", 1.4), noise, broken,                                  # an orphan NIC, two noise events
                cmd(b"HO", 2.0, dst=(1, 1, 2)), simple("ack", 2.014),              # retransmission, ok after 5 ms
                cmd(b"QX", 2.5, dst=(1, 2, 1)), simple("ack", 2.51), simple("nic", 2.511),   # unknown: NIC
                rate,
                cmd(b"PL", 3.0, dst=(1, 1, 2))], ack=0.2)                          # pending


def test_the_figures_by_hand():
    events = by_hand()
    d = counted(events)
    assert d["events"] == 15 and d["duration"] == pytest.approx(3.009)
    assert d["bytes"] == {"A": 45, "B": 27}
    assert d["kinds"] == {"command": 5, "ack": 3, "nak": 1, "nic": 2, "result": 1, "noise": 2}
    assert d["commands"] == 5 and d["retransmissions"] == 1 and d["orphans"] == 1
    assert d["status"] == {"ok": 2, "nak": 1, "nic": 1, "no_ack": 0, "no_result": 0, "pending": 1}
    assert d["checksum_errors"] == d["broken_frames"] == 1
    assert d["noise"] == {"events": 2, "bytes": 6, "by_problem": {"noise": 1, "bad checksum": 1}}
    # pairing takes a rate change right after an answer for the answered command's doing (#11)
    assert d["rate_changes"] == [{"number": 14, "t": 2.8, "request": 11, "previous_baud": 9600, "baud": 19200}]
    assert {"orphan", "noise", "bad checksum", "retransmission", "unknown command"} <= set(d["problems"])
    assert all(n == 1 for n in d["problems"].values())
    assert list(d["by_command"]) == ["HO", "P?", "PL", "QX"] and list(d["by_device"]) == ["1.1.1", "1.1.2", "1.2.1"]
    ho, p, dev = d["by_command"]["HO"], d["by_command"]["P?"], d["by_device"]["1.1.2"]
    assert (ho["commands"], ho["ok"], ho["nak"], ho["retransmissions"]) == (2, 1, 1, 1)
    assert (dev["commands"], dev["ok"], dev["nak"], dev["pending"], dev["retransmissions"]) == (3, 1, 1, 1, 1)
    assert d["by_command"]["QX"]["nic"] == 1 and d["by_device"]["1.2.1"]["nic"] == 1
    assert ho["ack_latency"]["count"] == 2 and ho["result_latency"]["count"] == 0
    assert ho["ack_latency"]["min"] == pytest.approx(0.005) and ho["ack_latency"]["max"] == pytest.approx(0.010)
    assert ho["ack_latency"]["p95"] == pytest.approx(0.010, rel=0.01)   # nearest rank: the second of two
    assert p["ack_latency"]["median"] == pytest.approx(0.003, rel=0.01)
    assert p["result_latency"]["max"] == pytest.approx(0.006) and d["by_device"]["1.1.1"] == p
    # every batch size, and the store's columns, say the same
    for size in range(1, len(events) + 1):
        assert counted(events, size) == d, size
    assert stats_of(stored(events, 4), len(events)).to_dict() == d
    # a line is counted even with no bytes: a rate change alone
    alone = Event("B", 0, "rate", b"", 0.5, 0.5)
    assert counted([alone])["bytes"] == stats_of(stored([alone]), 1).to_dict()["bytes"] == {"B": 0}


@pytest.mark.parametrize("which", CAPTURES)
def test_batches_of_any_size_count_as_one(which, tmp_path):
    events = capture(which, tmp_path)
    whole = counted(events)
    assert whole["by_command"] and whole["events"] == len(events)
    for size in (7, 97, 1000, 4096):
        assert counted(events, size) == whole, size
    assert counted(events[:300], 1) == counted(events[:300])
    listener = StatsListener()   # as a live tap feeds it: a few events at a time
    for k in range(0, len(events), 13):
        listener.on_events(events[k:k + 13])
        if k % 1300 == 0:
            assert listener.stats.events == k + len(events[k:k + 13])   # the figures so far, whenever read
    assert listener.stats.to_dict() == whole


@pytest.mark.parametrize("which", CAPTURES)
def test_added_one_by_one_or_in_any_batches_and_read_whenever(which, tmp_path):
    """``add`` and ``add_events`` gather events into batches of ``BATCH``, and a
    figure read counts those waiting first: one by one, in batches of any size,
    read in the middle or not, the figures are those of the events as one batch."""
    once = capture(which, tmp_path)
    events = once * (3 * BATCH // len(once) + 1)   # more than a few batches
    whole = counted(events)
    one_by_one = Stats()
    for ev in events:
        one_by_one.add(ev)
    assert one_by_one.to_dict() == whole
    for size in (1, 13, BATCH - 1, BATCH, BATCH + 1, 2 * BATCH + 7):
        assert counted(events, size) == whole, size
    # read after 13 events, then more: one by one, a few at a time, a big batch, columns
    s = Stats()
    for ev in events[:13]:
        s.add(ev)
    early = s.to_dict()
    assert early == counted(events[:13]) and s.events == 13
    cut = [13, 20, BATCH + 5, BATCH + 9, len(events) - 40]
    for ev in events[cut[0]:cut[1]]:
        s.add(ev)
    assert s.events == 20 and sum(s.kinds.values()) == 20   # every figure read sees the events waiting
    assert {k: c.to_dict() for k, c in sorted(s.by_command.items())} == counted(events[:20])["by_command"]
    s.add_events(events[cut[1]:cut[2]])
    for k in range(cut[2], cut[3]):
        s.add_events(events[k:k + 1])
    s.add_events(events[cut[3]:cut[4]])
    s.add(events[cut[4]])
    s.add_columns(EventColumns.of(events[cut[4] + 1:]))   # counted after the one waiting
    assert s.to_dict() == whole
    one = Stats()
    one.add_columns(EventColumns.of(events))
    assert (s.events, s.first_t, s.last_t, s.by_device.keys()) == (one.events, one.first_t, one.last_t,
                                                                   one.by_device.keys())


@pytest.mark.parametrize("which", CAPTURES)
def test_column_statistics_equal_the_events(which, tmp_path):
    events = capture(which, tmp_path)
    store = stored(events)
    assert stats_of(store, len(store)).to_dict() == counted(events)
    # the first part only (what was shown while loading)
    half = len(events) // 2
    assert stats_of(store, half).to_dict() == counted(events[:half])
    # a filtered view's rows
    for text in ('device == "1.1.2"', 'kind in ["ack", "nak"] or problems', 'status != "ok"'):
        pred = compile_filter(text)
        rows = [i for i, ev in enumerate(events) if pred(store.event(i))]
        assert stats_of(store, len(store), rows).to_dict() == counted([events[i] for i in rows]), text
    assert stats_of(store, 0).to_dict() == Stats().to_dict()


def test_the_device_map_by_hand():
    events = by_hand()
    devices = devices_of(stored(events, 4), len(events))
    assert list(devices) == ["1.1.1", "1.1.2", "1.2.1"]   # in the order they first appear
    one, two, three = devices.values()
    assert (one.commands, one.answered, one.lines, one.nic) == (1, 1, {"B"}, set())      # ACK and result
    assert (two.commands, two.answered, two.lines, two.nic) == (3, 2, {"B"}, set())      # NAK and ACK
    assert (three.commands, three.answered, three.lines, three.nic) == (1, 1, {"B"}, {"QX"})
    assert devices_of(stored(events, 4), 3) == {"1.1.1": one}   # the first three events: one conversation


@pytest.mark.parametrize("which", [*range(len(SAMPLES)), "hostile"])
def test_the_device_map_is_the_same_however_the_store_was_filled(which, tmp_path):
    events = list(analyzer.open(*(hostile(tmp_path) if which == "hostile" else SAMPLES[which])))
    whole = devices_of(stored(events, len(events)), len(events))
    assert whole and devices_of(stored(events, 1), len(events)) == whole
    assert list(devices_of(stored(events, 97), len(events))) == list(whole)   # in the order they first appear
    half = len(events) // 2
    assert devices_of(stored(events), half) == devices_of(stored(events[:half]), half)
    # the commands each device was sent, as the statistics count them
    by_device = stats_of(stored(events), len(events)).by_device
    assert {a: info.commands for a, info in whole.items()} == {a: c.commands for a, c in by_device.items() if c.commands}
    assert any(info.nic for info in whole.values()) or which != 0
