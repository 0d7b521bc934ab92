"""CSV (docs/json-lines.md, "CSV"): `decode --format csv` and `convert -o x.csv`,
one row per event in wire order, the event's columns then one per decoded field,
values only, RFC 4180 quoting; read back by the standard library's csv module and
by pandas. Expected values are worked out by hand from the frames (Table 1) and
the position encoding (Table 11, Table 15: hundredths of a degree, 16-bit hex)."""

from __future__ import annotations

import csv
import io
import json

import pandas as pd

from tests.conftest import SOCAT_LOG, frame, run_cli


def two_dumps(tmp_path) -> list[str]:
    a = tmp_path / "a.bin"
    b = tmp_path / "b.bin"
    # P to 1.1.1: azimuth 0x0FA0 = 4000 -> 40.00 deg, elevation 0xFC18 = -1000 -> -10.00 deg;
    # then a position query, answered: 0x07D0 = 2000 -> 20.00, 0x0064 = 100 -> 1.00
    a.write_bytes(frame((1, 1, 1), 0, "P0FA0FC18") + frame((1, 1, 1), 0, "P?"))
    b.write_bytes(b"\x06" + b"\x06" + frame((0, 1, 1), 1, "07D00064"))
    return [str(a), str(b)]


def rows(text: str) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(text, newline="")))


def test_rows_hold_the_events_values(tmp_path):
    done = run_cli("decode", *two_dumps(tmp_path), "--format", "csv")
    assert done.returncode == 0, done.stderr
    out = tmp_path / "x.csv"
    assert run_cli("convert", *two_dumps(tmp_path), "-o", out).returncode == 0
    text = out.read_bytes()
    assert text.count(b"\r\n") == 6 and text.count(b"\n") == 6   # RFC 4180 line ends: a header, 5 rows
    assert text.decode().replace("\r\n", "\n") == done.stdout   # convert writes what decode prints
    got = rows(done.stdout)
    assert [r["kind"] for r in got] == ["command", "ack", "command", "ack", "result"]
    go, query, answer = got[0], got[2], got[4]
    assert (go["number"], go["command"], go["device"], go["dst"], go["src"]) == ("1", "P", "1.1.1", "1.1.1", "0")
    assert (float(go["azimuth_deg"]), float(go["elevation_deg"])) == (40.0, -10.0)
    assert go["payload"] == "P0FA0FC18" and go["checksum_ok"] == "true" and go["status"] == "ok"
    # F8, the address, source, length, payload, checksum: Table 1
    assert go["raw"] == "f8010101" + "0009" + b"P0FA0FC18".hex() + f"{(3 + 9 + sum(b'P0FA0FC18')) & 0xFF:02x}"
    assert query["command"] == "P?" and query["azimuth_deg"] == ""
    assert (float(answer["azimuth_deg"]), float(answer["elevation_deg"])) == (20.0, 1.0)
    assert answer["request"] == "3" and answer["device"] == "1.1.1"
    assert all(r["problems"] == "" for r in got)


def test_the_columns_are_those_of_json_lines(tmp_path):
    # every event of a sample, both lines interleaved: each cell is its JSON Lines value
    done = run_cli("decode", SOCAT_LOG, "--format", "csv")
    lines = run_cli("decode", SOCAT_LOG, "--format", "jsonl")
    events = [json.loads(line) for line in lines.stdout.splitlines()]
    got = rows(done.stdout)
    assert len(got) == len(events) > 400
    for row, ev in zip(got, events, strict=True):
        assert row["number"] == str(ev["number"])
        assert row["kind"] == ev["kind"] and row["line"] == ev["line"]
        assert row["t"] == ("" if ev["t"] is None else repr(ev["t"]))
        assert row["raw"] == ev["raw"]
        assert row["problems"] == "; ".join(ev["problems"])
        for name, value in ev["fields"].items():
            column = "field_status" if name == "status" else name
            expected = "; ".join(map(str, value)) if isinstance(value, list) else value
            assert row[column] == ("" if expected is None else str(expected).lower() if isinstance(expected, bool)
                                   else str(expected)), (ev["number"], name)


def test_pandas_and_quoting(tmp_path):
    # a problem's text carries commas and quotes: quoted, read back whole
    bad = tmp_path / "bad.bin"
    bad.write_bytes(frame((1, 1, 1), 0, 'P"x,y') + frame((1, 1, 1), 0, "P?"))
    out = tmp_path / "x.csv"
    done = run_cli("convert", str(bad), "-o", out)
    assert done.returncode == 0, done.stderr
    assert "wrote 2 events" in done.stderr
    table = pd.read_csv(out, keep_default_na=False)
    assert list(table["number"]) == [1, 2]
    assert table["payload"][0] == 'P"x,y'
    assert '"P""x,y"' in out.read_text()   # RFC 4180: the field quoted, its quote doubled
    assert table["problems"][0] != "" and table["problems"][1] == ""


def test_fields_choose_the_columns(tmp_path):
    done = run_cli("decode", *two_dumps(tmp_path), "--format", "csv", "--fields", "t,device,azimuth_deg,kind")
    assert done.returncode == 0, done.stderr
    header, first = done.stdout.splitlines()[:2]
    assert header == "t,device,azimuth_deg,kind"
    assert first.split(",")[1:] == ["1.1.1", "40.0", "command"]


def test_bad_fields_are_one_line(tmp_path):
    unknown = run_cli("decode", SOCAT_LOG, "--format", "csv", "--fields", "t,azimuth")
    assert unknown.returncode == 2
    assert unknown.stderr.count("\n") == 1 and "unknown column 'azimuth'" in unknown.stderr
    other = run_cli("convert", SOCAT_LOG, "-o", tmp_path / "x.jsonl", "--fields", "t")
    assert other.returncode == 2 and "--fields chooses the columns of CSV" in other.stderr
    assert not (tmp_path / "x.jsonl").exists()
