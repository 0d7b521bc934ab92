"""The gimbalscope command as a user runs it: decode, stats, filters, and one
clear line for every bad input."""

import json
import os
import sys

import pytest

from tests.conftest import frame, run_cli


@pytest.fixture
def two_line(tmp_path):
    a = (frame((1, 1, 1), 0, "P0FA0FC18") + frame((1, 1, 1), 0, "P?") + frame((1, 1, 2), 0, "HO")
         + frame((1, 1, 2), 0, "HO"))
    b = b"\x06" + b"\x06" + frame((0, 1, 1), 1, "0FA0FC18") + b"\x15" + b"\x06"
    pa, pb = tmp_path / "ctl.bin", tmp_path / "dev.bin"
    pa.write_bytes(a)
    pb.write_bytes(b)
    return pa, pb


def test_decode_text(two_line):
    out = run_cli("decode", *two_line)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert len(lines) == 9
    assert "go to az +40.00° el -10.00°" in lines[0] and "[ok]" in lines[0]
    assert "at az +40.00° el -10.00°" in lines[4] and "[#3]" in lines[4]
    assert "\x1b[" not in out.stdout   # no colour when piped


def test_decode_jsonl_contract(two_line):
    out = run_cli("decode", *two_line, "--format", "jsonl")
    rows = [json.loads(line) for line in out.stdout.splitlines()]
    assert [r["kind"] for r in rows] == ["command", "ack", "command", "ack", "result", "command", "nak",
                                          "command", "ack"]
    first = rows[0]
    for key in ("line", "offset", "t", "kind", "raw", "dst", "src", "payload", "checksum_ok", "command",
                "fields", "problems", "txn", "status", "latency", "retransmission"):
        assert key in first
    assert first["dst"] == [1, 1, 1] and first["src"] == 0 and first["payload"] == "P0FA0FC18"
    assert first["fields"] == {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    assert first["t"] is None and first["raw"].startswith("f8010101")
    assert rows[4]["command"] == "P?" and rows[4]["txn"] == rows[2]["txn"]
    assert rows[5]["status"] == "nak" and rows[7]["retransmission"] is True
    assert rows[8]["offset"] == 1 + 1 + 15 + 1   # ACK, ACK, result (15 bytes), NAK


def test_decode_filter(two_line):
    out = run_cli("decode", *two_line, "--format", "jsonl", "--filter", 'status == "nak" or problems')
    rows = [json.loads(line) for line in out.stdout.splitlines()]
    assert [(r["kind"], r["status"]) for r in rows] == [("command", "nak"), ("command", "ok")]
    assert rows[1]["retransmission"]


def test_stats_json(two_line):
    out = run_cli("stats", *two_line, "--format", "json")
    d = json.loads(out.stdout)
    assert d["commands"] == 4 and d["status"]["nak"] == 1 and d["retransmissions"] == 1
    assert d["by_command"]["HO"]["commands"] == 2
    assert set(d["by_device"]) == {"1.1.1", "1.1.2"}


def test_stats_text(two_line):
    out = run_cli("stats", *two_line)
    assert out.returncode == 0 and "4 commands" in out.stdout and "per device" in out.stdout


def test_single_line_tap(tmp_path):
    p = tmp_path / "bus.bin"
    p.write_bytes(frame((1, 1, 1), 0, "P?") + b"\x06" + frame((0, 1, 1), 1, "0FA0FC18"))
    rows = [json.loads(x) for x in run_cli("decode", p, "--format", "jsonl").stdout.splitlines()]
    assert [(r["line"], r["kind"], r["command"]) for r in rows] == [
        ("AB", "command", "P?"), ("AB", "ack", None), ("AB", "result", "P?")]


def one_line_error(out, *fragments):
    assert out.returncode == 2
    assert out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert "Traceback" not in out.stderr
    assert lines[0].startswith("gimbalscope: error: ")
    for f in fragments:
        assert f in lines[0]


def test_missing_file(tmp_path):
    one_line_error(run_cli("decode", tmp_path / "nope.bin"), "nope.bin", "no such file")


def test_directory(tmp_path):
    one_line_error(run_cli("stats", tmp_path), str(tmp_path), "is a directory")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_unreadable(tmp_path):
    p = tmp_path / "locked.bin"
    p.write_bytes(b"\x06")
    p.chmod(0)
    one_line_error(run_cli("decode", p), "locked.bin", "permission denied")


def test_text_that_is_not_a_capture(tmp_path):
    p = tmp_path / "notes.txt"
    p.write_text("remember to check the cable\nsecond line\n")
    one_line_error(run_cli("decode", p), "notes.txt", "not a socat -x -v log")


def test_too_many_inputs(tmp_path, two_line):
    one_line_error(run_cli("decode", *two_line, two_line[0]), "3 inputs")


def test_mcap_without_our_topics(tmp_path):
    p = tmp_path / "x.mcap"
    p.write_bytes(b"\x89MCAP0\r\n" + b"\0" * 32)
    one_line_error(run_cli("decode", p), "x.mcap", "MCAP file without gimbalscope raw topics")


@pytest.mark.parametrize("expr,fragment", [('status == "nack"', "column 11"), ("kind ==", "column 8"),
                                          ("import os", "unknown name 'import'")])
def test_bad_filter_points_at_token(two_line, expr, fragment):
    one_line_error(run_cli("decode", *two_line, "--filter", expr), fragment, ">>>")


def test_bad_timeout_option(two_line):
    one_line_error(run_cli("decode", *two_line, "--timeout", "IX"), "--timeout", "CMD=SECONDS")


def test_garbage_bytes_decode_as_noise_not_errors(tmp_path):
    p = tmp_path / "garbage.bin"
    p.write_bytes(bytes(range(256)) * 20)
    out = run_cli("decode", p, "--format", "jsonl")
    assert out.returncode == 0 and "Traceback" not in out.stderr
    rows = [json.loads(x) for x in out.stdout.splitlines()]
    assert sum(len(bytes.fromhex(r["raw"])) for r in rows) == 256 * 20   # nothing lost


def test_broken_pipe_is_quiet(tmp_path):
    p = tmp_path / "many.bin"
    p.write_bytes((frame((1, 1, 1), 0, "HO") + b"\x06") * 20000)
    import shutil
    import subprocess
    exe = shutil.which("gimbalscope")
    cmd = f"{exe or sys.executable + ' -m analyzer'} decode {p} | head -1"
    out = subprocess.run(cmd, shell=True, capture_output=True, text=True, timeout=60, check=False)
    assert out.stdout.count("\n") == 1 and "Traceback" not in out.stderr and "Error" not in out.stderr


def test_console_script_is_installed():
    import shutil
    # beside the interpreter running the tests: the venv's, activated or not
    assert shutil.which("gimbalscope", path=os.path.dirname(sys.executable)), \
        "pip install -e . provides the gimbalscope command"
    assert run_cli("--version").stdout.startswith("gimbalscope ")


def test_file_that_fails_to_read():
    # opens, then fails with EIO on read even for root
    one_line_error(run_cli("decode", "/proc/self/mem"), "/proc/self/mem", "cannot read")


@pytest.mark.parametrize("args,fragment", [(["decode", "x.bin", "--baud", "abc"], "invalid int value: 'abc'"),
                                           (["decode"], "the following arguments are required"),
                                           (["frobnicate"], "invalid choice: 'frobnicate'"),
                                           (["decode", "x.bin", "--format", "xml"], "invalid choice: 'xml'")])
def test_usage_mistakes_are_one_line(args, fragment):
    one_line_error(run_cli(*args), fragment)


def test_empty_capture_warns(tmp_path):
    p = tmp_path / "empty.bin"
    p.write_bytes(b"")
    out = run_cli("decode", p)
    assert out.returncode == 0 and out.stdout == ""
    assert out.stderr.strip() == f"gimbalscope: warning: {p}: no bytes in this capture"


def test_commands_start_without_loading_the_dataset_libraries():
    """pyarrow and DuckDB load only for the commands that use them (export, query,
    report): they took a tenth of a second of every other command's start."""
    import subprocess

    from tests.conftest import ROOT

    code = ("import sys, analyzer.cli.main as m; m.build_parser(); "
            "print(sorted(n for n in ('pyarrow', 'duckdb') if n in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120,
                         check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
