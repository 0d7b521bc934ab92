"""A live logic analyser (docs/instruments.md): sigrok-cli writing samples to a
pipe (``-O binary``) and ``gimbalscope live --samples -`` reading them, with a
recording that opens afterwards."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pytest

from tests.conftest import ROOT, frame, run_cli
from tests.waveforms import back_to_back, pack, uart_levels

pytestmark = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")

RATE = 1_000_000
COMMAND = frame((1, 1, 1), 0, b"P?")
RESULT = frame((0, 1, 1), 1, b"0FA0FC18")


def test_samples_piped_from_sigrok_cli_are_tapped_live_and_recorded(tmp_path):
    a = uart_levels(back_to_back(COMMAND, 0.010, 9600), RATE, 9600, 0.060)
    b = uart_levels(back_to_back(b"\x06", 0.020, 9600) + back_to_back(RESULT, 0.024, 9600), RATE, 9600, 0.060)
    raw = tmp_path / "cap.bin"
    raw.write_bytes(pack(a, b) * 4)          # four exchanges, 60 ms apart
    sr = tmp_path / "cap.sr"
    subprocess.run(["sigrok-cli", "-I", f"binary:numchannels=2:samplerate={RATE}", "-i", str(raw), "-o", str(sr)],
                   check=True, capture_output=True, timeout=60)
    record = tmp_path / "live.mcap"
    sigrok = subprocess.Popen(["sigrok-cli", "-i", str(sr), "-O", "binary"], stdout=subprocess.PIPE)
    tap = subprocess.run([sys.executable, "-m", "analyzer", "live", "--samples", "-", "--samplerate", "1MHz",
                          "--no-tui", "--format", "jsonl", "--record", str(record)],
                         stdin=sigrok.stdout, capture_output=True, text=True, timeout=120, cwd=ROOT, check=False)
    sigrok.stdout.close()
    sigrok.wait(timeout=30)
    assert tap.returncode == 0, tap.stderr
    events = [json.loads(line) for line in tap.stdout.splitlines()]
    commands = [e for e in events if e["kind"] == "command"]
    assert [(c["command"], c["status"]) for c in commands] == [("P?", "ok")] * 4
    assert [c["t"] for c in commands] == pytest.approx([0.010, 0.070, 0.130, 0.190], abs=2e-6)
    assert "listening on standard input (logic samples at 1 MHz" in tap.stderr
    # the recording opens and decodes to the same conversation
    again = run_cli("decode", record, "--format", "jsonl")
    assert again.returncode == 0, again.stderr
    assert [json.loads(l)["status"] for l in again.stdout.splitlines() if '"kind":"command"' in l] == ["ok"] * 4


def test_samples_need_a_rate_and_no_ports():
    r = run_cli("live", "--samples", "-", "--no-tui", input="")
    assert r.returncode == 2 and "--samples needs --samplerate" in r.stderr and r.stderr.count("\n") == 1
    r = run_cli("live", "/dev/ttyS0", "--samples", "-", "--samplerate", "1MHz", "--no-tui", input="")
    assert r.returncode == 2 and "give ports or --samples, not both" in r.stderr
    r = run_cli("live", "--samples", "-", "--samplerate", "fast", "--no-tui", input="")
    assert r.returncode == 2 and "'fast': expected a rate such as 1MHz" in r.stderr
