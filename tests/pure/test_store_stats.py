"""The statistics screen's figures from the store's columns (analyzer/tui/store_stats.py)
equal ``Stats`` fed the events themselves: every count, every latency bucket, for
the sample captures, a hostile line, and a filtered view's rows."""

from __future__ import annotations

import pytest

import analyzer
from analyzer.analysis.filter import compile_filter
from analyzer.analysis.stats import Stats
from analyzer.simulation.traffic import generate
from analyzer.tui.store import EventStore
from analyzer.tui.store_stats import stats_of

SAMPLES = [("captures/demo-ctl.bin", "captures/demo-dev.bin"), ("captures/demo-socat.log",),
           ("captures/demo-bus.bin",)]


def fed(events) -> dict:
    s = Stats()
    for ev in events:
        s.add(ev)
    return s.to_dict()


def hostile(tmp_path) -> tuple[str, ...]:
    tr = generate(600, baud=9600, seed=7, bit_error_rate=0.03, drop_ack_rate=0.05, noise_rate=0.05)
    (tmp_path / "a.bin").write_bytes(tr.line_bytes("A"))
    (tmp_path / "b.bin").write_bytes(tr.line_bytes("B"))
    (tmp_path / "bus.bin").write_bytes(tr.single_line())
    return str(tmp_path / "a.bin"), str(tmp_path / "b.bin")


@pytest.mark.parametrize("which", [*range(len(SAMPLES)), "hostile two lines", "hostile one line"])
def test_column_statistics_equal_the_events(which, tmp_path):
    if which == "hostile two lines":
        paths = hostile(tmp_path)
    elif which == "hostile one line":
        hostile(tmp_path)
        paths = (str(tmp_path / "bus.bin"),)
    else:
        paths = SAMPLES[which]
    events = list(analyzer.open(*paths))
    store = EventStore()
    for k in range(0, len(events), 50):
        store.append(events[k:k + 50])
    expected = fed(events)
    assert expected["by_command"] and expected["events"] == len(events)
    assert stats_of(store, len(store)).to_dict() == expected
    # the first part only (what was shown while loading)
    half = len(events) // 2
    assert stats_of(store, half).to_dict() == fed(events[:half])
    # a filtered view's rows
    for text in ('device == "1.1.2"', 'kind in ["ack", "nak"] or problems', 'status != "ok"'):
        pred = compile_filter(text)
        rows = [i for i, ev in enumerate(events) if pred(store.event(i))]
        assert stats_of(store, len(store), rows).to_dict() == fed([events[i] for i in rows]), text


def fed_devices(events) -> dict:
    """The device map worked out event by event, from the events' own attributes:
    a command counts for its device; a paired answer (result, ACK, NAK, NIC) says
    the line its device answers on, an ACK or NAK counts as answered; a command
    that got NIC names what the device does not know (§1.4.2)."""
    from analyzer.tui.model.devices import DeviceInfo

    out: dict = {}
    for ev in events:
        if ev.kind not in ("command", "result", "ack", "nak", "nic") or ev.device is None:
            continue
        if ev.kind != "command" and ev.transaction is None:
            continue
        info = out.setdefault(ev.device, DeviceInfo(ev.device))
        if ev.kind == "command":
            info.commands += 1
            if ev.status == "nic" and ev.command:
                info.nic.add(ev.command)
            continue
        info.lines.add(ev.line)
        info.answered += ev.kind in ("ack", "nak")
    return out


@pytest.mark.parametrize("which", [*range(len(SAMPLES)), "hostile"])
def test_the_device_map_from_the_columns_equals_the_map_fed_the_events(which, tmp_path):
    from analyzer.tui.store_stats import devices_of

    events = list(analyzer.open(*(hostile(tmp_path) if which == "hostile" else SAMPLES[which])))
    store = EventStore()
    store.append(events)
    expected = fed_devices(events)
    assert expected and devices_of(store, len(store)) == expected
    assert list(devices_of(store, len(store))) == list(expected)   # in the order they first appear
    assert devices_of(store, len(events) // 2) == fed_devices(events[:len(events) // 2])
    assert any(info.nic for info in expected.values()) or which != 0
