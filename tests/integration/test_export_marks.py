"""The dataset carries the marks and notes kept with a capture as its `marks`
table: from a sidecar, whether the capture is decoded or exported from a
recording's stored columns; a sidecar that does not read is one warning and the
rest is exported."""

from __future__ import annotations

import json
import shutil

import pyarrow.parquet as pq

from analyzer.formats.marks import Mark, write_sidecar
from tests.conftest import SOCAT_LOG, run_cli


def _marks_rows(root) -> list[tuple]:
    files = sorted(root.glob("marks/date=*/*.parquet"))
    rows = []
    for f in files:
        table = pq.read_table(f)
        rows += list(zip(*(table.column(c).to_pylist() for c in ("number", "t", "note")), strict=True))
    return sorted(rows)


def test_a_captures_marks_are_a_table(tmp_path):
    log = tmp_path / "tap.log"
    shutil.copy(SOCAT_LOG, log)
    write_sidecar([str(log)], [Mark(3, "late ACK", 0.018435), Mark(5, "")])
    done = run_cli("export", log, "-o", tmp_path / "ds")
    assert done.returncode == 0, done.stderr
    assert "2 marks" in done.stderr
    assert _marks_rows(tmp_path / "ds") == [(3, 0.018435, "late ACK"), (5, None, "")]
    # a recording of it, exported from its stored columns, carries its own sidecar's
    rec = tmp_path / "tap.mcap"
    assert run_cli("convert", log, "-o", rec).returncode == 0
    write_sidecar([str(rec)], [Mark(7, "from the recording", 0.1)])
    done = run_cli("export", rec, "-o", tmp_path / "ds2")
    assert done.returncode == 0, done.stderr
    assert _marks_rows(tmp_path / "ds2") == [(7, 0.1, "from the recording")]


def test_a_sidecar_that_does_not_read_is_a_warning(tmp_path):
    log = tmp_path / "tap.log"
    shutil.copy(SOCAT_LOG, log)
    (tmp_path / "tap.log.marks.json").write_text(json.dumps({"marks": "no"}))
    done = run_cli("export", log, "-o", tmp_path / "ds")
    assert done.returncode == 0, done.stderr
    assert "tap.log.marks.json: not a marks file" in done.stderr
    assert not list((tmp_path / "ds").glob("marks/*/*.parquet"))
    assert list((tmp_path / "ds").glob("events/*/*.parquet"))


def test_a_cut_capture_says_its_sidecar_did_not_read_beside_the_cut(tmp_path):
    # the capture is skipped (it ends early), and what the dataset's writer said of
    # its marks is said too: the sidecar is as unreadable for the next export
    import gzip

    from analyzer.capture import Options
    from analyzer.dataset.export import Job, run_job

    with open(SOCAT_LOG, "rb") as f:
        data = gzip.compress(f.read())
    log = tmp_path / "tap.log.gz"
    log.write_bytes(data[:len(data) // 2])
    (tmp_path / "tap.log.gz.marks.json").write_text("not json")
    out = run_job(Job(0, (str(log),), str(tmp_path / "ds"), Options()))
    assert out.error is not None and "ends early" in out.error
    assert any("tap.log.gz.marks.json" in w and "exported without its marks" in w for w in out.warnings), out.warnings
    assert not list((tmp_path / "ds").glob("*/*/*.parquet"))
