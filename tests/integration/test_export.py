"""``gimbalscope export`` (the Parquet dataset, docs/dataset.md) and the API that
feeds it: ``analyzer.open(filter=...)``, ``Capture.transactions()``,
``to_arrow()``, ``to_pandas()``, ``Event.ts`` and ``Event.source``.

Expected values come from frames built by hand (Table 1) and the spec's result
layout (Table 15: position in hundredths of a degree, signed 16-bit hex), or
from ``stats`` of the same input, as the issue asks the counts to agree."""

from __future__ import annotations

import datetime as dt
import json
import os
import shutil

import pyarrow.parquet as pq
import pytest

import analyzer
from analyzer.dataset.query import connect
from analyzer.info import CaptureInfo
from analyzer.runner import TapRunner
from tests.conftest import BUS, CTL, DEV, SOCAT_LOG, frame, run_cli

START = "2026-03-01T23:59:59Z"   # the hand-made capture crosses midnight (UTC) at 9600 baud


def hand_capture(tmp_path, name="hand"):
    """Line A: P? to 1.1.1, HO to 1.1.2; line B: ACK + position result
    (azimuth 0x0FA0 = 4000 -> 40.00 deg, elevation 0xFC18 = -1000 -> -10.00 deg), NAK."""
    a = tmp_path / f"{name}-a.bin"
    b = tmp_path / f"{name}-b.bin"
    a.write_bytes(frame((1, 1, 1), 0, "P?") + frame((1, 1, 2), 0, "HO"))
    b.write_bytes(b"\x06" + frame((0, 1, 1), 1, "0FA0FC18") + b"\x15")
    return str(a), str(b)


def export(*args):
    return run_cli("export", *args, timeout=300)


def rows(root, table):
    con = connect(str(root))
    order = "capture, code, subject" if table == "findings" else "capture, number"
    cur = con.execute(f"SELECT * FROM {table} ORDER BY {order}")
    names = [d[0] for d in cur.description]
    return [dict(zip(names, r)) for r in cur.fetchall()]


def test_hand_capture_tables(tmp_path):
    a, b = hand_capture(tmp_path)
    out = tmp_path / "ds"
    r = export(f"{a}+{b}", "-o", out, "--site", "north", "--start-time", START)
    assert r.returncode == 0, r.stderr
    events = rows(out, "events")
    # two commands, an ACK, a result, a NAK, in wire order (an ACK or NAK names no command:
    # the event contract; its device is its command's)
    assert [(e["kind"], e["command"], e["device"], e["status"]) for e in events] == [
        ("command", "P?", "1.1.1", "ok"), ("ack", None, "1.1.1", None), ("result", "P?", "1.1.1", None),
        ("command", "HO", "1.1.2", "nak"), ("nak", None, "1.1.2", None)]
    result = events[2]
    assert result["azimuth_deg"] == 40.0 and result["elevation_deg"] == -10.0
    assert result["device"] == "1.1.1" and result["site"] == "north"
    assert result["capture"] == f"{a}+{b}"
    assert events[0]["raw"] == frame((1, 1, 1), 0, "P?")
    assert events[0]["azimuth_deg"] is None   # a field an event does not have is null
    txns = rows(out, "transactions")
    assert [(t["command"], t["device"], t["status"], t["azimuth_deg"]) for t in txns] == [
        ("P?", "1.1.1", "ok", 40.0), ("HO", "1.1.2", "nak", None)]
    assert txns[0]["ack"] == 2 and txns[0]["result"] == 3 and txns[1]["ack"] == 5
    # the schema types: fields typed from the command table, not strings
    schema = pq.read_schema(next(out.glob("events/date=*/*.parquet")))
    assert str(schema.field("azimuth_deg").type) == "double"
    assert str(schema.field("ts").type) == "timestamp[us, tz=UTC]"


def test_untimed_capture_is_dated_by_its_start(tmp_path):
    # raw dumps carry no byte times: ts is null, the partition is the day the capture started
    a, b = hand_capture(tmp_path)
    out = tmp_path / "ds"
    assert export(f"{a}+{b}", "-o", out, "--start-time", START).returncode == 0
    assert [p.name for p in (out / "events").iterdir()] == ["date=2026-03-01"]
    assert all(e["ts"] is None for e in rows(out, "events"))


def test_counts_equal_stats(tmp_path):
    out = tmp_path / "ds"
    r = export(SOCAT_LOG, BUS, f"{CTL}+{DEV}", "-o", out, "-j", "2")
    assert r.returncode == 0, r.stderr
    con = connect(str(out))
    for capture, inputs in ((SOCAT_LOG, [SOCAT_LOG]), (BUS, [BUS]), (f"{CTL}+{DEV}", [CTL, DEV])):
        stats = json.loads(run_cli("stats", *inputs, "--format", "json").stdout)
        got = dict(con.execute("SELECT status, count(*) FROM events WHERE capture = ? AND kind = 'command' "
                               "GROUP BY status", [capture]).fetchall())
        assert {k: v for k, v in stats["status"].items() if v} == got
        by_command = dict(con.execute("SELECT command, count(*) FROM events WHERE capture = ? AND kind = 'command' "
                                      "GROUP BY command", [capture]).fetchall())
        assert by_command == {name: c["commands"] for name, c in stats["by_command"].items()}
        n = con.execute("SELECT count(*) FROM events WHERE capture = ?", [capture]).fetchone()[0]
        assert n == stats["events"]
        txns = con.execute("SELECT count(*) FROM transactions WHERE capture = ?", [capture]).fetchone()[0]
        assert txns == stats["commands"]


def test_one_worker_and_two_give_the_same_rows(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    assert export(SOCAT_LOG, BUS, "-o", one, "-j", "1").returncode == 0
    assert export(SOCAT_LOG, BUS, "-o", two, "-j", "2").returncode == 0
    for table in ("events", "transactions", "findings"):
        assert rows(one, table) == rows(two, table)


def test_export_again_replaces_its_own_files_only(tmp_path):
    out = tmp_path / "ds"
    assert export(SOCAT_LOG, BUS, "-o", out).returncode == 0
    files = sorted(str(p.relative_to(out)) for p in out.rglob("*.parquet"))
    before = rows(out, "events")
    bus_files = {p: p.stat().st_mtime_ns for p in out.rglob("demo-bus.bin-*.parquet")}
    r = export(SOCAT_LOG, "-o", out)                          # the socat log again, the bus dump not
    assert r.returncode == 0, r.stderr
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*.parquet")) == files
    assert rows(out, "events") == before                      # nothing twice, nothing lost
    assert {p: p.stat().st_mtime_ns for p in out.rglob("demo-bus.bin-*.parquet")} == bus_files
    assert not list(out.rglob("*.tmp"))


def test_a_capture_that_moved_day_leaves_no_old_partition(tmp_path):
    a, b = hand_capture(tmp_path)
    out = tmp_path / "ds"
    assert export(f"{a}+{b}", "-o", out, "--start-time", START).returncode == 0
    assert export(f"{a}+{b}", "-o", out, "--start-time", "2026-05-02T10:00:00Z").returncode == 0
    assert sorted(p.name for p in (out / "events").iterdir()) == ["date=2026-05-02"]
    assert len(rows(out, "events")) == 5


def test_a_commit_leaves_other_captures_partitions_alone(tmp_path):
    # export -j: another capture's job has made its partition folder and not yet
    # its file when this capture commits; the empty folder is not this one's to remove
    out = tmp_path / "ds"
    waiting = out / "events" / "date=1999-12-31"
    waiting.mkdir(parents=True)
    assert export(SOCAT_LOG, "-o", out).returncode == 0
    assert waiting.is_dir()


def test_a_partition_folder_removed_before_its_file_is_made_again(tmp_path, monkeypatch):
    # the other side of the same race, in one process: the folder goes between
    # being made and the file being opened in it (once); the export still succeeds
    from analyzer.writers import dataset_folder, parquet

    real_makedirs = dataset_folder.os.makedirs
    removed = []

    def makedirs_then_lose(path, exist_ok=False):
        real_makedirs(path, exist_ok=exist_ok)
        if not removed and os.path.basename(path).startswith("date="):
            os.rmdir(path)          # another capture's commit, just now
            removed.append(path)

    monkeypatch.setattr(dataset_folder.os, "makedirs", makedirs_then_lose)
    out = tmp_path / "ds"
    capture = analyzer.open(SOCAT_LOG)
    info = CaptureInfo.of(capture, command="export")
    writer = parquet.ParquetDatasetWriter(str(out), info)
    TapRunner(capture, [writer], info=info).run()   # as an export job runs it
    writer.commit()
    assert removed
    assert len(rows(out, "events")) == sum(1 for _ in analyzer.open(SOCAT_LOG))


def test_cut_and_unreadable_inputs_are_skipped(tmp_path):
    whole = tmp_path / "whole.mcap"
    assert run_cli("convert", SOCAT_LOG, "-o", whole).returncode == 0
    cut = tmp_path / "cut.mcap"
    data = whole.read_bytes()
    cut.write_bytes(data[: len(data) * 2 // 3])
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"\x89MCAP0\r\n" + os.urandom(300))
    out = tmp_path / "ds"
    r = export(cut, BUS, garbage, tmp_path / "missing.log", "-o", out)
    assert r.returncode == 1
    assert "Traceback" not in r.stderr
    assert f"skipped {cut}: cut short" in r.stderr
    assert "skipped 3:" in r.stderr and str(tmp_path / "missing.log") in r.stderr.splitlines()[-1]
    assert {e["capture"] for e in rows(out, "events")} == {BUS}   # the good one went on


def test_bad_output_and_usage(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    r = export(BUS, "-o", f)
    assert r.returncode != 0 and "is a file" in r.stderr and "Traceback" not in r.stderr
    r = export(BUS, "-o", tmp_path / "out.mcap")
    assert r.returncode != 0 and "gimbalscope convert" in r.stderr
    r = export("-", "-o", tmp_path / "ds")
    assert r.returncode == 2 and "standard input" in r.stderr


def test_a_capture_across_midnight_is_split_by_day(tmp_path):
    # a socat log whose events run over midnight UTC: each row goes to its own day
    log = tmp_path / "midnight.log"
    f1 = frame((1, 1, 1), 0, "HO")
    f2 = frame((1, 1, 2), 0, "HO")
    hexed = lambda bs: " " + " ".join(f"{x:02x}" for x in bs)
    log.write_text(f"> 2026/03/01 23:59:59.900000000  length={len(f1)} from=0 to={len(f1) - 1}\n{hexed(f1)}\n--\n"
                   f"> 2026/03/02 00:00:00.500000000  length={len(f2)} from={len(f1)} to={len(f1) + len(f2) - 1}\n"
                   f"{hexed(f2)}\n--\n")
    out = tmp_path / "ds"
    r = export(log, "-o", out, "--tz", "UTC")
    assert r.returncode == 0, r.stderr
    con = connect(str(out))
    got = con.execute("SELECT date, device FROM events ORDER BY number").fetchall()
    assert got == [(dt.date(2026, 3, 1), "1.1.1"), (dt.date(2026, 3, 2), "1.1.2")]


# ------------------------------------------------------------------ the API

def test_events_carry_source_and_absolute_time(tmp_path):
    a, b = hand_capture(tmp_path)
    cap = analyzer.open(a, b, start_time=dt.datetime(2026, 3, 1, 12, tzinfo=dt.UTC).timestamp())
    events = list(cap)
    assert {ev.source for ev in events} == {f"{a}+{b}"}
    assert all(ev.ts is None for ev in events)   # raw dumps: no byte times
    log = tmp_path / "one.log"
    f1 = frame((1, 1, 1), 0, "HO")
    log.write_text(f"> 2026/03/01 12:00:01.250000000  length={len(f1)} from=0 to={len(f1) - 1}\n "
                   + " ".join(f"{x:02x}" for x in f1) + "\n--\n")
    ev = next(iter(analyzer.open(str(log), tz="UTC")))
    assert ev.source == str(log)
    # socat stamps a read when its last byte is in: the frame's first byte came 9 bytes of
    # 10 bits (8N1) at 9600 baud before it (docs/time.md)
    first_byte = dt.datetime(2026, 3, 1, 12, 0, 1, 250000, tzinfo=dt.UTC) - dt.timedelta(seconds=9 * 10 / 9600)
    assert abs(ev.datetime - first_byte) < dt.timedelta(microseconds=1)
    assert ev.ts == pytest.approx(first_byte.timestamp(), abs=1e-6)


def test_filter_transactions_and_arrow(tmp_path):
    a, b = hand_capture(tmp_path)
    naks = list(analyzer.open(a, b, filter='status == "nak"'))
    assert [(e.kind, e.command) for e in naks] == [("command", "HO")]
    txns = list(analyzer.open(a, b).transactions())
    assert [(t["command"], t["device"], t["status"], t["answers"]) for t in txns] == [
        ("P?", "1.1.1", "ok", [2, 3]), ("HO", "1.1.2", "nak", [5])]
    assert txns[0]["fields"] == {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    assert [t["command"] for t in analyzer.open(a, b, filter='device == "1.1.2"').transactions()] == ["HO"]
    table = analyzer.open(a, b, filter='kind == "result"').to_arrow()
    assert table.num_rows == 1 and table.column("azimuth_deg").to_pylist() == [40.0]
    with pytest.raises(analyzer.FilterError):
        analyzer.open(a, b, filter="status ==")


def test_to_pandas(tmp_path):
    pytest.importorskip("pandas")
    a, b = hand_capture(tmp_path)
    df = analyzer.open(a, b).to_pandas()
    assert list(df["kind"]) == ["command", "ack", "result", "command", "nak"]


@pytest.mark.skipif(shutil.which("gimbalscope") is None, reason="the console command is not installed")
def test_progress_bar_on_a_terminal_is_one_bar(tmp_path):
    # the bar is drawn on standard error only when it is a terminal: run under a pty
    import pty
    import subprocess

    out = tmp_path / "ds"
    master, slave = pty.openpty()
    env = dict(os.environ, GIMBALSCOPE_PROGRESS_DELAY="0")
    proc = subprocess.Popen([shutil.which("gimbalscope"), "export", SOCAT_LOG, BUS, "-o", str(out), "-j", "2"],
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=slave, env=env)
    os.close(slave)
    seen = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:
            break
        if not chunk:
            break
        seen += chunk
    assert proc.wait(timeout=120) == 0
    os.close(master)
    text = seen.decode(errors="replace")
    assert "exporting" in text and "exported 2 of 2 captures" in text, text[-500:]



def test_site_from_the_recording_and_from_the_option(tmp_path):
    rec = tmp_path / "rec.mcap"
    assert run_cli("convert", SOCAT_LOG, "-o", rec, "--site", "south yard").returncode == 0
    out = tmp_path / "ds"
    assert export(rec, "-o", out).returncode == 0
    assert {e["site"] for e in rows(out, "events")} == {"south yard"}
    assert export(rec, "-o", out, "--site", "north").returncode == 0   # the option wins
    assert {e["site"] for e in rows(out, "events")} == {"north"}
    assert {f["site"] for f in rows(out, "findings")} == {"north"}
