"""`export` of a recording that carries its decoded columns (docs/dataset.md,
"Exporting a recording") makes its dataset from them, column by column, and that
dataset is the one decoding the raw bytes (``--redecode``) makes: every table,
row and value, the doctor's findings included; what the command says is the same."""

from __future__ import annotations

import pyarrow.dataset as ds
import pytest

import analyzer.capture.capture as capture_module
from analyzer.formats.parquet_schema import TABLES
from tests.conftest import CTL, DEV, run_cli
from tests.integration.test_stored_columns_cli import converted, recording  # noqa: F401 - the fixture


def tables(root) -> dict[str, list[dict]]:
    """Every table's rows, in the order of their event or transaction numbers."""
    out = {}
    for name in TABLES:
        folder = root / name
        rows = (ds.dataset(str(folder), format="parquet", partitioning="hive").to_table().to_pylist()
                if folder.exists() else [])
        key = {"events": "number", "transactions": "txn"}.get(name, "code")
        out[name] = sorted(rows, key=lambda r: (r["capture"], r.get(key) or 0, r.get("subject") or ""))
    return out


def exported(tmp_path, name: str, inputs: list[str], *extra: str) -> tuple[dict[str, list[dict]], str, str]:
    root = tmp_path / name
    done = run_cli("export", "+".join(inputs), "-o", str(root), "-j", "1", *extra)
    assert done.returncode == 0, done.stderr
    return tables(root), done.stdout.replace(str(root), "DIR"), done.stderr.replace(str(root), "DIR")


def test_the_dataset_of_the_columns_is_that_of_decoding(recording, tmp_path):   # noqa: F811 - the fixture
    stored, out, err = exported(tmp_path, "stored", recording)
    decoded, out_decoded, err_decoded = exported(tmp_path, "decoded", recording, "--redecode")
    assert (out, err) == (out_decoded, err_decoded)
    assert len(stored["events"]) > 100 and stored["transactions"]
    for table in TABLES:
        assert len(stored[table]) == len(decoded[table]), table
        for a, b in zip(stored[table], decoded[table], strict=True):
            assert a == b, (table, a.get("number"), {k: (a[k], b[k]) for k in a if a[k] != b[k]})


def test_a_noisy_recording_of_many_messages_gives_what_decoding_gives(tmp_path, monkeypatch):
    # rows made message by message: transactions open across messages, garbled
    # command ids coming in most of them (the tables grow), payloads repeated
    # within and across messages, fields of the wrong type
    from analyzer.simulation.traffic import generate
    from analyzer.writers import mcap_columns
    from tests.integration.test_mcap_parts import record
    from tests.integration.test_recorded_columns import columns_record

    tr = generate(1_500, baud=9600, seed=11, bit_error_rate=0.03, drop_ack_rate=0.05, noise_rate=0.05)
    (tmp_path / "bus.bin").write_bytes(tr.single_line())
    monkeypatch.setattr(mcap_columns, "BATCH", 300)
    monkeypatch.setattr(mcap_columns, "STORE_EVERY", 100)
    [rec], _info = record(tmp_path / "rec.mcap", [str(tmp_path / "bus.bin")])
    assert int(columns_record(rec)["messages"]) > 10
    stored, out, err = exported(tmp_path, "stored", [rec])
    decoded, out_decoded, err_decoded = exported(tmp_path, "decoded", [rec], "--redecode")
    assert (out, err) == (out_decoded, err_decoded)
    assert len(stored["events"]) > 3_000 and len(stored["transactions"]) > 1_000
    for table in TABLES:
        assert stored[table] == decoded[table], table


def test_an_empty_recording_gives_what_decoding_gives(tmp_path):
    # a silent bus recorded: no events, so no findings (not even "no frames") and no marks
    (tmp_path / "silent.bin").write_bytes(b"")
    rec = tmp_path / "silent.mcap"
    done = run_cli("convert", tmp_path / "silent.bin", "-o", rec)
    assert done.returncode == 0, done.stderr
    stored, out, err = exported(tmp_path, "stored", [str(rec)])
    decoded, out_decoded, err_decoded = exported(tmp_path, "decoded", [str(rec)], "--redecode")
    assert (out, err) == (out_decoded, err_decoded)
    assert stored == decoded
    assert not stored["events"] and not stored["findings"]


def test_a_recording_whose_columns_are_set_aside_leaves_no_temporary_copy(tmp_path, monkeypatch):
    # a compressed recording is read from a decompressed copy; when its columns
    # cannot stand for decoding (a rate change), that first copy goes at once, not
    # whenever the interpreter collects it (an export of many keeps none of them)
    import tempfile

    import zstandard

    from analyzer.capture import Options
    from analyzer.dataset.export import Job, run_job
    from analyzer.simulation.traffic import Write, generate
    from dissectors.wire import ACK, build_frame
    from tests.integration.test_mcap_parts import record

    tr = generate(200, baud=9600, seed=5)
    t = max(w.t for w in tr.writes) + 0.1
    tr.writes += [Write("A", build_frame((1, 1, 1), 0, "C3"), t), Write("B", bytes([ACK]), t + 0.02)]
    (tmp_path / "bus.log").write_text(tr.socat_log())
    [rec], _info = record(tmp_path / "rec.mcap", [str(tmp_path / "bus.log")])
    packed = tmp_path / "rec.mcap.zst"
    with open(rec, "rb") as f:
        packed.write_bytes(zstandard.ZstdCompressor().compress(f.read()))
    copies = tmp_path / "tmp"
    copies.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(copies))
    import gc
    gc.disable()   # what is left is what the export left, not what a collection happened to take
    try:
        out = run_job(Job(0, (str(packed),), str(tmp_path / "ds"), Options()))
        assert out.error is None and out.events > 200
        assert list(copies.glob("gimbalscope-*.mcap")) == []
    finally:
        gc.enable()


def test_the_doctors_findings_come_from_the_recording(tmp_path):
    # the dumps given the other way round: the wiring signs say so, and what the
    # lines swapped explain is not raised (the kept findings and the reading rules joined)
    rec = converted(tmp_path, DEV, CTL)
    stored, _out, err = exported(tmp_path, "stored", [rec])
    decoded, _out, err_decoded = exported(tmp_path, "decoded", [rec], "--redecode")
    assert err == err_decoded and "swapped" in err
    codes = [f["code"] for f in stored["findings"]]
    assert "lines_swapped" in codes
    assert stored["findings"] == decoded["findings"]


def test_the_columns_are_read_not_decoded(tmp_path, monkeypatch, capsys):
    from analyzer.cli.main import main

    rec = converted(tmp_path, CTL, DEV)

    def no_deframing(*_args, **_kwargs):
        raise AssertionError("the raw bytes were decoded")

    monkeypatch.setattr(capture_module, "Deframer", no_deframing)
    assert main(["export", rec, "-o", str(tmp_path / "ds"), "-j", "1"]) == 0
    assert "exported 1 of 1 capture" in capsys.readouterr().err
    assert len(tables(tmp_path / "ds")["events"]) > 100


def test_a_decoding_option_says_the_raw_bytes_are_decoded(tmp_path):
    rec = converted(tmp_path, CTL, DEV)
    done = run_cli("export", rec, "-o", str(tmp_path / "ds"), "--baud", "19200")
    assert done.returncode == 0, done.stderr
    assert "--baud given: decoding the raw bytes, not the stored columns" in done.stderr


@pytest.mark.parametrize("lean", [False, True])
def test_a_recording_without_columns_is_decoded_silently(tmp_path, lean):
    rec = str(tmp_path / "rec.mcap")
    assert run_cli("convert", CTL, DEV, "-o", rec, *(["--lean"] if lean else [])).returncode == 0
    done = run_cli("export", rec, "-o", str(tmp_path / "ds"))
    assert done.returncode == 0, done.stderr
    assert "stored columns" not in done.stderr
    if lean:
        assert len(tables(tmp_path / "ds")["events"]) > 100
