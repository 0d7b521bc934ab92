"""`recover` and the stored columns (docs/mcap.md, "Stored columns"): the record
saying the columns hold every event is kept only when nothing was lost, so a
recovered file with a chunk dropped is decoded from its raw bytes, and one
recovered whole still opens from its columns."""

from __future__ import annotations

import analyzer
from analyzer.capture.stored import stored_events
from analyzer.simulation.traffic import generate
from tests.conftest import SOCAT_LOG, run_cli
from tests.hostile.test_mcap_hostile import chunk_data_offset, chunks_in
from tests.pure.test_tui_store import same


def test_a_recording_recovered_whole_keeps_its_columns(tmp_path):
    rec, fixed = tmp_path / "rec.mcap", tmp_path / "fixed.mcap"
    assert run_cli("convert", SOCAT_LOG, "-o", rec).returncode == 0
    out = run_cli("recover", rec, "-o", fixed)
    assert out.returncode == 0, out.stderr
    stored, why = stored_events(analyzer.open(str(fixed)))
    assert stored is not None and why is None and stored.events == 474   # the sample's events, as decode counts them
    assert sum(len(c.columns["kind"]) for c in stored.chunks()) == 474


def test_a_recovered_recording_that_lost_a_chunk_is_decoded_from_its_bytes(tmp_path):
    rec, damaged, fixed = tmp_path / "rec.mcap", tmp_path / "damaged.mcap", tmp_path / "fixed.mcap"
    log = tmp_path / "tap.log"   # enough traffic for several chunks of raw bytes and events
    log.write_text(generate(4500, baud=115200, seed=5).socat_log())
    assert run_cli("convert", log, "--baud", "115200", "-o", rec).returncode == 0
    whole = rec.read_bytes()
    chunks = chunks_in(whole)
    offset = [o for o, _l, counts in chunks if "/gimbalscope/columns" not in counts][-1]
    at = chunk_data_offset(whole, offset)
    damaged.write_bytes(whole[:at] + b"\0\0\0\0" + whole[at + 4:])
    out = run_cli("recover", damaged, "-o", fixed)
    assert out.returncode == 0 and f"byte {offset}" in out.stderr
    assert stored_events(analyzer.open(str(fixed))) == (None, None)
    decoded = list(analyzer.open(str(fixed), redecode=True))
    assert len(decoded) > 1000
    for a, b in zip(list(analyzer.open(str(fixed))), decoded, strict=True):
        same(a, b)
