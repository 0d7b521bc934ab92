"""A file viewed is decoded in a process of its own, which hands the screen its
events as store columns (analyzer/tui/model/chunks.py, decode_process.py). What
the screen's model holds after taking those chunks, pickled as they cross the
pipe, must be what it holds after storing the same events itself: every
column, every rebuilt event, the plots, the checksum count, the statistics,
the device map and a filter's rows."""

from __future__ import annotations

import pickle

import pytest

import analyzer
from analyzer.formats.store import COLUMNS, EventStore
from analyzer.simulation.traffic import generate
from analyzer.tui.model import CaptureModel
from analyzer.tui.model.chunks import ChunkMaker
from dissectors.event import NOISE, Event
from tests.pure.test_tui_store import SAMPLES, commands_to_many_devices, same


def by_chunks(events: list[Event], sizes: list[int], filter_text: str = "") -> CaptureModel:
    """A model fed ``events`` as the decoding process would send them: made into
    chunks of ``sizes`` events (the rest in one more), each through pickle."""
    maker, model = ChunkMaker(), CaptureModel(follow=False)
    if filter_text:
        model.set_filter(filter_text)
    k = 0
    for n in [*sizes, len(events)]:
        maker.add(events[k:k + n])
        k += n
        model.add_chunk(pickle.loads(pickle.dumps(maker.take(), protocol=pickle.HIGHEST_PROTOCOL)))
    return model


def directly(events: list[Event], filter_text: str = "") -> CaptureModel:
    model = CaptureModel(follow=False)
    if filter_text:
        model.set_filter(filter_text)
    for k in range(0, len(events), 97):
        model.extend(events[k:k + 97])
    return model


def same_model(got: CaptureModel, want: CaptureModel, events: list[Event]) -> None:
    a, b = got.store, want.store
    assert len(a) == len(b) == got.shown == want.shown == len(events)
    for name in COLUMNS:
        x, y = getattr(a, name), getattr(b, name)
        assert (x.typecode, x.tobytes()) == (y.typecode, y.tobytes()), name   # bytes: NaN is no number
    assert a.raw == b.raw and a.problems == b.problems and a.fields == b.fields
    for i, ev in enumerate(events):
        same(a.event(i), ev)
    assert got.totals.checksum_errors == want.totals.checksum_errors
    assert {d: {n: (list(s.t), list(s.v)) for n, s in named.items()} for d, named in got.series.items()} == \
        {d: {n: (list(s.t), list(s.v)) for n, s in named.items()} for d, named in want.series.items()}
    assert got.totals.devices == want.totals.devices
    assert got.totals.stats.to_dict() == want.totals.stats.to_dict()
    assert got.filter.view == want.filter.view and got.filter.errors == want.filter.errors
    assert got.row_count == want.row_count


@pytest.mark.parametrize("paths", SAMPLES, ids=lambda p: p[0].split("/")[-1])
def test_sample_captures_arrive_whole_in_chunks(paths):
    events = list(analyzer.open(*paths))
    for sizes, text in (([1, 50, 0, 200], ""), ([len(events) // 2], 'kind == "result" and azimuth_deg < -10'),
                        ([7] * 30, "problems or status != \"ok\"")):
        model = by_chunks(events, sizes, text)
        assert not text or 0 < len(model.filter.view) < len(events)
        same_model(model, directly(events, text), events)


def test_a_hostile_line_arrives_whole_in_chunks(tmp_path):
    tr = generate(600, baud=9600, seed=7, bit_error_rate=0.03, drop_ack_rate=0.05, noise_rate=0.05)
    (tmp_path / "a.bin").write_bytes(tr.line_bytes("A"))
    (tmp_path / "b.bin").write_bytes(tr.line_bytes("B"))
    (tmp_path / "bus.bin").write_bytes(tr.single_line())
    for paths in ((tmp_path / "a.bin", tmp_path / "b.bin"), (tmp_path / "bus.bin",)):
        events = list(analyzer.open(*map(str, paths)))
        assert any(e.problems for e in events) and any(e.kind == NOISE for e in events)
        text = 'kind == "noise" or checksum_ok == false'
        # garbled command ids and addresses keep arriving: new codes in many chunks
        same_model(by_chunks(events, [3, 100, 100, 100]), directly(events), events)
        filtered = by_chunks(events, [100] * 5, text)
        assert 0 < len(filtered.filter.view) < len(events) and filtered.filter.errors
        same_model(filtered, directly(events, text), events)


def test_a_chunk_wider_than_the_store_widens_it():
    # offsets past 4 GB (a line read for days) in the second chunk only
    near = Event("A", 7, NOISE, b"\x00", 0.5, 0.5)
    far = Event("A", 5_000_000_000, NOISE, b"\x00", 1.0, 1.0)
    for n, ev in enumerate((near, far), 1):
        ev.number = n
        ev.add_problem("noise", "1 byte outside any frame")
    model = by_chunks([near, far], [1])
    assert model.store.offset.itemsize == 8
    assert [model.store.event(i).offset for i in (0, 1)] == [7, 5_000_000_000]


def test_70000_devices_across_chunks():
    events = commands_to_many_devices()
    model = by_chunks(events, [30_000, 30_000])
    assert model.store.device.itemsize >= 4
    for i in (0, 65_534, 65_535, 69_999):
        assert model.store.event(i).device == events[i].device


def test_a_chunk_that_does_not_follow_is_refused():
    events = list(analyzer.open("captures/demo-socat.log"))[:20]
    maker = ChunkMaker()
    maker.add(events[:10])
    maker.take()               # never delivered
    maker.add(events[10:])
    store = EventStore()
    with pytest.raises(ValueError, match="does not follow"):
        store.append_chunk(maker.take().stored)
