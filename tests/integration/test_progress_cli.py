"""The progress bar on a terminal, never on a pipe, and -q, through the real
command: standard error on a pseudo-terminal (os.openpty) makes the command
believe it is on a terminal. GIMBALSCOPE_PROGRESS_DELAY=0 shows the bar from the
start, so no test depends on how long anything takes."""

import gzip
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import ROOT, drain, run_cli

SOCAT = os.path.join(ROOT, "captures", "demo-socat.log")
NOW = {"GIMBALSCOPE_PROGRESS_DELAY": "0"}


def command() -> list[str]:
    exe = shutil.which("gimbalscope")
    return [exe] if exe else [sys.executable, "-m", "analyzer"]


def run_on_terminal(*args, stdout_too: bool = False, stdin=subprocess.DEVNULL, env=NOW) -> tuple[int, str, str]:
    """Run with standard error (and with ``stdout_too`` standard output) on a
    pseudo-terminal: (exit code, what the terminal got, standard output)."""
    master, slave = os.openpty()
    proc = subprocess.Popen(command() + [str(a) for a in args], cwd=ROOT, stdin=stdin,
                            stdout=slave if stdout_too else subprocess.PIPE, stderr=slave,
                            env={**os.environ, **env, "COLUMNS": "120"})
    os.close(slave)
    seen = drain(master)
    out = proc.stdout.read().decode() if proc.stdout else ""
    code = proc.wait(timeout=60)
    os.close(master)
    return code, seen.decode(errors="replace"), out


def kb(n: int) -> str:
    """A size as the bar writes it: decimal kilobytes, one decimal."""
    return f"{n / 1000:.1f}"


@pytest.mark.parametrize("cmd", ["stats", "decode"])
def test_a_bar_of_the_bytes_read_shows_on_a_terminal_and_is_gone_at_the_end(cmd):
    code, terminal, _ = run_on_terminal(cmd, SOCAT)
    assert code == 0
    size = os.path.getsize(SOCAT)
    assert "reading" in terminal and "━" in terminal
    assert f"{kb(size)}/{kb(size)} kB" in terminal          # all of it read, of its size on disk
    assert terminal.endswith("\x1b[2K")                     # transient: the bar's line erased at the end


def test_a_compressed_input_counts_its_compressed_bytes(tmp_path):
    packed = tmp_path / "tap.log.gz"
    packed.write_bytes(gzip.compress(Path(SOCAT).read_bytes()))
    code, terminal, _ = run_on_terminal("stats", packed)
    size = packed.stat().st_size
    assert code == 0 and f"{kb(size)}/{kb(size)} kB" in terminal


def test_no_bar_on_a_pipe():
    r = subprocess.run(command() + ["stats", SOCAT], cwd=ROOT, capture_output=True, text=True,
                       env={**os.environ, **NOW}, timeout=60, check=False)
    assert r.returncode == 0 and r.stderr == ""


def test_no_bar_when_decode_prints_to_the_same_terminal():
    code, terminal, _ = run_on_terminal("decode", SOCAT, stdout_too=True)
    assert code == 0
    assert "A → 1.1.2" in terminal                           # the lines are there ...
    assert "reading" not in terminal and "━" not in terminal  # ... and no bar among them


def test_no_bar_without_a_total_from_a_pipe():
    with open(SOCAT, "rb") as f:
        data = f.read()
    proc_in = subprocess.Popen(["cat"], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    proc_in.stdin.write(data)
    proc_in.stdin.close()
    code, terminal, out = run_on_terminal("stats", "-", stdin=proc_in.stdout)
    proc_in.wait()
    assert code == 0 and "events" in out
    assert "reading" not in terminal and "━" not in terminal


def test_no_bar_for_a_short_run_at_the_usual_delay():
    # the demo capture takes far less than the delay (3 s) to read
    code, terminal, _ = run_on_terminal("stats", SOCAT, env={})
    assert code == 0 and "reading" not in terminal


def test_quiet_silences_warnings_only(tmp_path):
    damaged = tmp_path / "tap.log"
    damaged.write_bytes(Path(SOCAT).read_bytes() + b"this is no socat line\n")
    loud = run_cli("decode", damaged)
    assert loud.returncode == 0 and "gimbalscope: warning:" in loud.stderr
    for cmd in ("decode", "stats", "doctor"):
        quiet = run_cli(cmd, damaged, "-q")
        # the doctor's status is its findings': the sample's line B is noisy, a warning
        assert quiet.returncode == (1 if cmd == "doctor" else 0) and "warning:" not in quiet.stderr, cmd
    converted = run_cli("convert", damaged, "-o", tmp_path / "out.mcap", "--quiet")
    # what it wrote is no warning: still said, alone
    said = converted.stderr.splitlines()
    assert converted.returncode == 0 and len(said) == 1 and said[0].startswith("gimbalscope: recorded "), said
    missing = run_cli("decode", tmp_path / "missing.log", "-q")     # errors are still one line
    assert missing.returncode == 2
    assert missing.stderr.splitlines() == [f"gimbalscope: error: {tmp_path / 'missing.log'}: no such file"]
