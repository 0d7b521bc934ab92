"""`view` of a recording that carries its decoded columns (docs/mcap.md, "Stored
columns") maps them into the screen's store without decoding: what the screen
holds is what it holds when the raw bytes are decoded (``--redecode``), column
for column, event for event, with the same plots, counts, device map,
statistics and filter rows; times to the nanosecond, as recordings keep them."""

from __future__ import annotations

import asyncio
import subprocess

import numpy as np
import pytest

import analyzer
from analyzer.formats.store import COLUMNS
from analyzer.simulation.traffic import generate
from analyzer.tui.decode_process import ProcessFeed
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import SOCAT_LOG
from tests.pure.test_tui_store import same
from tests.ui.test_pilot import settle


def gimbalscope() -> str:
    import os
    import sys
    return os.path.join(os.path.dirname(sys.executable), "gimbalscope")


def loaded(path: str, **kw):
    """The model of `view PATH` once every event has come, and whether it was fed
    by the decoding process."""
    app = make_app(analyzer.open(path, **kw), mode="view", filter_text='status == "nak" or kind == "noise"')

    async def drive():
        async with app.run_test(size=(120, 30)) as pilot:
            # every event and the doctor's say (a file's doctor may start once the load
            # is done, and on a busy machine say its findings well after it): the status
            # shows both
            await settle(pilot, app, lambda a: a.model.done and (a.model.findings_known or a.model.doctor_error))
            await pilot.pause(0.1)
            return str(app.status_bar.render())
    try:
        status = asyncio.run(drive())
    finally:
        stop_feed(app)
    return app.model, isinstance(app.feed, ProcessFeed), status


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("stored")
    tr = generate(500, baud=9600, seed=11, bit_error_rate=0.02, drop_ack_rate=0.04, noise_rate=0.04)
    (tmp / "a.bin").write_bytes(tr.line_bytes("A"))
    (tmp / "b.bin").write_bytes(tr.line_bytes("B"))
    out = {}
    for name, inputs in (("socat", [SOCAT_LOG]), ("hostile", [str(tmp / "a.bin"), str(tmp / "b.bin")])):
        path = str(tmp / f"{name}.mcap")
        subprocess.run([gimbalscope(), "convert", *inputs, "-o", path, "-q"], check=True)
        out[name] = path
    return out


@pytest.mark.parametrize("name", ["socat", "hostile"])
def test_view_from_the_columns_holds_what_decoding_gives(recordings, name):
    path = recordings[name]
    got, by_process, status = loaded(path)
    want, _, decoded_status = loaded(path, redecode=True)
    assert by_process
    assert status == decoded_status and "loaded" in status   # how much of the file, in its bytes
    a, b = got.store, want.store
    assert len(a) == len(b) > 400
    for column in COLUMNS:
        x, y = np.asarray(a.column(column)), np.asarray(b.column(column))
        if column in ("t", "t_end"):   # to the nanosecond (NaN: no end time)
            assert np.allclose(x, y, rtol=0, atol=1e-9, equal_nan=True), column
        else:
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), column
    assert a.raw == b.raw and a.problems == b.problems and a.fields == b.fields
    for i in range(len(b)):
        same(a.event(i), b.event(i))
    assert got.totals.checksum_errors == want.totals.checksum_errors
    assert got.totals.devices == want.totals.devices
    assert got.totals.stats.to_dict() == want.totals.stats.to_dict()
    assert got.filter.view == want.filter.view and got.filter.errors == want.filter.errors
    assert {d: {n: (len(s), list(s.v)) for n, s in named.items()} for d, named in got.series.items()} == \
        {d: {n: (len(s), list(s.v)) for n, s in named.items()} for d, named in want.series.items()}
