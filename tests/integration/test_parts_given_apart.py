"""The parts of a recording in parts given as files of their own, in any order and
with no `+`: `export` and `stats` take them as one capture, by the `capture_id`
their metadata names; the parts of another recording stay another capture
(docs/dataset.md, "Inputs")."""

from __future__ import annotations

import json

import pyarrow.dataset as ds

from tests.conftest import BUS, SOCAT_LOG, run_cli
from tests.integration.test_mcap_parts import record, shuffled


def exported_captures(root) -> dict[str, int]:
    table = ds.dataset(str(root / "events"), format="parquet", partitioning="hive").to_table(columns=["capture"])
    counts: dict[str, int] = {}
    for name in table.column("capture").to_pylist():
        counts[name] = counts.get(name, 0) + 1
    return counts


def test_export_joins_a_recordings_parts_and_keeps_another_apart(tmp_path):
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    parts, _info = record(tmp_path / "one" / "tap.mcap", [BUS], rotate_bytes=16_000)
    others, _info = record(tmp_path / "two" / "tap.mcap", [SOCAT_LOG], rotate_bytes=16_000)
    assert len(parts) >= 3 and len(others) >= 2
    mixed = shuffled(parts)
    given = [*mixed[:2], *reversed(others[1:]), *mixed[2:], others[0]]
    done = run_cli("export", *given, "-o", tmp_path / "ds", "-j", "1")
    assert done.returncode == 0, done.stderr
    assert "exported 2 of 2 captures" in done.stderr
    counts = exported_captures(tmp_path / "ds")
    # each capture named by its parts in their order, as `+` would give them
    assert set(counts) == {"+".join(parts), "+".join(others)}
    whole = run_cli("export", "+".join(parts), "-o", tmp_path / "joined", "-j", "1")
    assert whole.returncode == 0, whole.stderr
    assert exported_captures(tmp_path / "joined") == {"+".join(parts): counts["+".join(parts)]}


def test_stats_of_parts_in_any_order_is_that_of_the_recording(tmp_path):
    parts, _info = record(tmp_path / "tap.mcap", [BUS], rotate_bytes=16_000)
    assert len(parts) >= 3
    apart = run_cli("stats", *shuffled(parts), "--format", "json")   # stats takes its inputs apart anyway
    joined = run_cli("stats", *parts, "--format", "json")   # in their order
    assert apart.returncode == joined.returncode == 0, apart.stderr + joined.stderr
    assert json.loads(apart.stdout) == json.loads(joined.stdout)
    assert json.loads(apart.stdout)["events"] > 100


def test_stats_refuses_the_parts_of_two_recordings_in_one_line(tmp_path):
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    parts, _info = record(tmp_path / "one" / "tap.mcap", [BUS], rotate_bytes=16_000)
    others, _info = record(tmp_path / "two" / "tap.mcap", [BUS], rotate_bytes=16_000)
    done = run_cli("stats", parts[0], others[1])
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "capture" in lines[0] and "Traceback" not in done.stderr
