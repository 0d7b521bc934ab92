"""``gimbalscope query`` over exported datasets, the README's queries
("Queries"), and another reader (Polars) giving the same counts as DuckDB.

The captures are socat logs written by hand (timed, so latencies are known):
socat stamps a read when its last byte is in, so at 9600 baud 8N1 an answer
byte stamped at T began 10/9600 s before T, and its latency is that less the
command's stamp (spec §1.4.2: latency from the command's last byte)."""

from __future__ import annotations

import csv
import datetime as dt
import io
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from analyzer.dataset.query import connect
from tests.conftest import BUS, ROOT, SOCAT_LOG, drain, frame, run_cli

BYTE = 10 / 9600          # seconds per byte at 9600 baud, 8N1
ACK, NAK, NIC = b"\x06", b"\x15", b"?"


def socat_log(path, day: str, entries) -> None:
    """``entries``: (seconds after noon of ``day``, '>' line A or '<' line B, bytes)."""
    offsets = {">": 0, "<": 0}
    out = []
    for secs, way, data in entries:
        stamp = dt.datetime.fromisoformat(f"{day}T12:00:00") + dt.timedelta(seconds=secs)
        start = offsets[way]
        offsets[way] += len(data)
        # socat -x writes 16 bytes a line
        rows = "".join(" " + " ".join(f"{b:02x}" for b in data[i:i + 16]) + "\n" for i in range(0, len(data), 16))
        out.append(f"{way} {stamp:%Y/%m/%d %H:%M:%S}.{stamp.microsecond:06d}000  length={len(data)} "
                   f"from={start} to={start + len(data) - 1}\n{rows}--\n")
    path.write_text("".join(out))


def identity(revision: str) -> bytes:
    """A D? result payload (Table 6): type, revision, name, serial."""
    return f"PT{revision:2}{'GIMBAL':20}{'SN-1':20}".encode()


def day_one(path) -> None:
    """2026-03-02 (a Monday): 1.1.1 identifies as rev 19, ACKs a P? after 10 ms
    and NICs QZ; 1.1.2 NAKs HO after 5 ms."""
    socat_log(path, "2026-03-02", [
        (0.000, ">", frame((1, 1, 1), 0, "D?")),
        (0.010 + BYTE, "<", ACK),
        (0.030, "<", frame((0, 1, 1), 1, identity("19"))),
        (1.000, ">", frame((1, 1, 1), 0, "P?")),
        (1.010 + BYTE, "<", ACK),
        (1.030, "<", frame((0, 1, 1), 1, "0FA0FC18")),
        (2.000, ">", frame((1, 1, 1), 0, "QZ")),
        (2.004 + BYTE, "<", ACK),
        (2.006 + BYTE, "<", NIC),
        (3.000, ">", frame((1, 1, 2), 0, "HO")),
        (3.005 + BYTE, "<", NAK),
    ])


def day_two(path) -> None:
    """2026-03-10 (the next week's Tuesday): 1.1.1 ACKs P? after 30 ms; 1.1.2 is
    silent (HO twice, no answer)."""
    socat_log(path, "2026-03-10", [
        (0.000, ">", frame((1, 1, 1), 0, "P?")),
        (0.030 + BYTE, "<", ACK),
        (0.050, "<", frame((0, 1, 1), 1, "0FA0FC18")),
        (1.000, ">", frame((1, 1, 2), 0, "HO")),
        (4.000, ">", frame((1, 1, 2), 0, "HO")),
    ])


@pytest.fixture
def fleet(tmp_path):
    one, two = tmp_path / "mon.log", tmp_path / "tue.log"
    day_one(one)
    day_two(two)
    out = tmp_path / "fleet"
    for log in (one, two):   # two exports into one dataset, a day each
        r = run_cli("export", log, "-o", out, "--tz", "UTC", timeout=300)
        assert r.returncode == 0, r.stderr
    return out


def query(root, sql, fmt="csv"):
    r = run_cli("query", root, sql, "--format", fmt)
    assert r.returncode == 0, r.stderr
    if fmt == "csv":
        return list(csv.DictReader(io.StringIO(r.stdout)))
    return [json.loads(line) for line in r.stdout.splitlines()]


def readme_queries() -> dict[str, str]:
    """The README's queries ("### Queries": a "#### title" and an sql block each)."""
    text = Path(ROOT, "README.md").read_text(encoding="utf-8")
    part = text.split("### Queries\n", 1)[1]
    part = re.split(r"\n##?#? ", part, maxsplit=1)[0]
    return {m.group(1).strip(): m.group(2) for m in re.finditer(r"####\s*(.+?)\n.*?```sql\n(.*?)```", part, re.DOTALL)}


def test_the_readme_has_the_four_queries():
    assert set(readme_queries()) == {"NAK rate per device per day", "p95 ACK latency per device per week",
                                     "Devices silent since a date", "Commands each firmware NICs"}


def test_nak_rate_per_device_per_day(fleet):
    rows = query(fleet, readme_queries()["NAK rate per device per day"])
    got = [(r["date"], r["device"], int(r["commands"]), int(r["naks"]), float(r["nak_rate"])) for r in rows]
    assert got == [("2026-03-02", "1.1.1", 3, 0, 0.0), ("2026-03-02", "1.1.2", 1, 1, 1.0),
                   ("2026-03-10", "1.1.1", 1, 0, 0.0), ("2026-03-10", "1.1.2", 2, 0, 0.0)]


def test_p95_ack_latency_per_device_per_week(fleet):
    rows = query(fleet, readme_queries()["p95 ACK latency per device per week"])
    got = [(r["week"], r["device"], int(r["acks"]), float(r["ack_p95_ms"])) for r in rows]
    # week of Monday 2026-03-02: 1.1.1's ACKs after 10, 10 and 4 ms: p95 by linear
    # interpolation between the two largest (10, 10) is 10; 1.1.2's NAK after 5 ms
    assert got == [("2026-03-02", "1.1.1", 3, 10.0), ("2026-03-02", "1.1.2", 1, 5.0),
                   ("2026-03-09", "1.1.1", 1, 30.0)]


def test_devices_silent_since_a_date(fleet):
    sql = readme_queries()["Devices silent since a date"].replace("2026-11-22", "2026-03-05")
    rows = query(fleet, sql)
    assert [(r["device"], r["last_answered_day"], r["last_commanded_day"]) for r in rows] == [
        ("1.1.2", "2026-03-02", "2026-03-10")]


def test_commands_each_firmware_nics(fleet):
    rows = query(fleet, readme_queries()["Commands each firmware NICs"])
    assert [(r["firmware"], r["command"], int(r["nics"])) for r in rows] == [("19", "QZ", 1)]


def test_jsonl_and_table_formats(fleet):
    rows = query(fleet, "SELECT date, kind, count(*) AS n FROM events WHERE kind = 'nak' GROUP BY ALL", "jsonl")
    assert rows == [{"date": "2026-03-02", "kind": "nak", "n": 1}]
    r = run_cli("query", fleet, "SELECT 1 AS one", "--format", "table")
    assert r.returncode == 0 and "one" in r.stdout and "1 row" in r.stdout


def test_bad_sql_and_bad_dataset(tmp_path, fleet):
    r = run_cli("query", fleet, "SELEC 1")
    assert r.returncode == 2 and r.stderr.startswith("gimbalscope: error: query:") and "Traceback" not in r.stderr
    r = run_cli("query", fleet, "SELECT nope FROM events")
    assert r.returncode == 2 and "nope" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = run_cli("query", tmp_path / "missing", "SELECT 1")
    assert r.returncode == 2 and "no such dataset" in r.stderr
    (tmp_path / "empty").mkdir()
    r = run_cli("query", tmp_path / "empty", "SELECT 1")
    assert r.returncode == 2 and "no dataset here" in r.stderr


def test_duckdb_and_polars_give_the_same_counts(tmp_path):
    pl = pytest.importorskip("polars")
    one = tmp_path / "mon.log"
    day_one(one)
    out = tmp_path / "fleet"
    assert run_cli("export", SOCAT_LOG, BUS, one, "-o", out, "--tz", "UTC", timeout=300).returncode == 0
    con = connect(str(out))

    def duck(sql):
        return [tuple(r) for r in con.execute(sql).fetchall()]

    def polars(table, keys):
        frame = pl.scan_parquet(str(out / table / "**" / "*.parquet"), hive_partitioning=True)
        got = frame.group_by(keys).len().collect().rows()
        return sorted(got, key=lambda r: tuple("" if v is None else str(v) for v in r))

    def same(table, keys):
        cols = ", ".join(keys)
        d = duck(f"SELECT {cols}, count(*) FROM {table} GROUP BY ALL")
        p = polars(table, keys)
        assert sorted(d, key=lambda r: tuple("" if v is None else str(v) for v in r)) == p, (table, keys)
        assert sum(r[-1] for r in d) > 0

    same("events", ["kind"])
    same("events", ["status"])
    same("events", ["date", "device"])
    same("transactions", ["status"])


# ------------------------------------------------------------ on a terminal; one statement; DuckDB's words
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def on_terminal(*args, columns: int = 80) -> tuple[int, str]:
    """The command with standard output on a pseudo-terminal ``columns`` wide:
    (exit code, what the terminal shows, without colours)."""
    master, slave = os.openpty()
    exe = shutil.which("gimbalscope")
    cmd = [exe] if exe else [sys.executable, "-m", "analyzer"]
    proc = subprocess.Popen(cmd + [str(a) for a in args], cwd=ROOT, stdin=subprocess.DEVNULL, stdout=slave,
                            stderr=subprocess.DEVNULL, env={**os.environ, "COLUMNS": str(columns)})
    os.close(slave)
    seen = drain(master)
    code = proc.wait(timeout=120)
    os.close(master)
    return code, ANSI.sub("", seen.decode()).replace("\r\n", "\n")


def records(text: str) -> list[dict[str, str]]:
    """What a vertical display shows: a dict per record of column → value."""
    out: list[dict[str, str]] = []
    name = ""
    for line in text.splitlines():
        if re.match(r"\d[\d,]* rows?\b", line):
            break                       # the count: the records are above it
        if line.startswith("record ") and "─" in line:
            out.append({})
        elif line.startswith(" "):      # a long value wrapped under itself
            out[-1][name] += line.strip()
        elif out:
            name, _, value = line.partition(" ")
            out[-1][name] = value.strip()
    return out


def test_records_shown_a_column_a_line_when_the_columns_do_not_fit(fleet):
    code, text = on_terminal("query", fleet, "SELECT * FROM events WHERE kind = 'nak'", columns=80)
    assert code == 0
    assert all(len(line) <= 80 for line in text.splitlines())
    got = records(text)
    # day_one: 1.1.2 NAKs HO, the fleet's only NAK
    assert len(got) == 1
    assert (got[0]["kind"], got[0]["device"], got[0]["date"], got[0]["line"]) == ("nak", "1.1.2", "2026-03-02", "B")
    assert float(got[0]["latency"]) == pytest.approx(0.005, abs=1e-5)   # 5 ms after HO's last byte
    # a value longer than the room after the names, wrapped under itself
    assert got[0]["capture"] == str(fleet.parent / "mon.log")
    assert any(line.startswith(" ") for line in text.splitlines())   # the path, too long for its room
    assert " ".join(text.split("\n1 row ")[1].split()) == (
        "(a record at a time: the columns are wider than the terminal; --format table or csv for a table)")


def test_a_result_that_fits_stays_a_table(fleet):
    code, text = on_terminal("query", fleet, "SELECT device, count(*) AS n FROM transactions GROUP BY ALL "
                                             "ORDER BY device", columns=80)
    assert code == 0 and "┃ device ┃ n ┃" in text and "record 1" not in text
    # day one: 1.1.1 D?, P?, QZ and 1.1.2 HO; day two: 1.1.1 P? and 1.1.2 HO twice
    assert "│ 1.1.1  │ 4 │" in text and "│ 1.1.2  │ 3 │" in text


def test_vertical_on_request_and_piped_ends_no_line_in_spaces(fleet):
    r = run_cli("query", fleet, "SELECT device, kind FROM events WHERE kind = 'nic'", "--format", "vertical")
    assert r.returncode == 0, r.stderr
    assert records(r.stdout) == [{"device": "1.1.1", "kind": "nic"}]   # 1.1.1 NICs QZ
    assert all(line == line.rstrip() for line in r.stdout.splitlines())
    assert "a record at a time" not in r.stdout      # asked for: nothing to explain


def test_exactly_one_statement_as_duckdb_parses_it(fleet):
    r = run_cli("query", fleet, "SELECT 1; SELECT 2")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.splitlines() == [
        "gimbalscope: error: query: 2 SQL statements given; a query runs exactly one (run each on its own)"]
    r = run_cli("query", fleet, ";")
    assert r.returncode == 2 and r.stderr.splitlines() == ["gimbalscope: error: query: no SQL statement given"]
    # a ; in a string or a comment, or one at the end, separates nothing
    r = run_cli("query", fleet, "SELECT 'a;b' AS s; -- and; more")
    assert r.returncode == 0 and r.stdout.splitlines() == ["s", "a;b"]


def test_duckdb_messages_are_said_whole_on_one_line(fleet):
    r = run_cli("query", fleet, "SELECT * FROM event")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.splitlines() == [('gimbalscope: error: query: Catalog Error: Table with name event does not '
                                      'exist! Did you mean "events"? (at line 1: "event")')]
    r = run_cli("query", fleet, "SELECT device,\n  nope FROM events")
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1
    assert r.stderr.startswith('gimbalscope: error: query: Binder Error: Referenced column "nope" not found')
    assert "Candidate bindings" in r.stderr and r.stderr.rstrip().endswith('(at line 2: "nope")')
