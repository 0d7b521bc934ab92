"""The demo and the simulator as a user runs them."""

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import time
import tty

from tests.conftest import ROOT, frame, run_cli

PATIENCE = 30.0   # seconds to wait for the simulator: generous, the machine may be busy
from tests.integration.test_mcap import doctor, go_read, jsonl


def test_demo_runs_records_and_the_recording_decodes_the_same(tmp_path):
    rec = tmp_path / "demo.mcap"
    out = run_cli("demo", "--seconds", "5", "--format", "jsonl", "--record", rec, timeout=60)
    assert out.returncode == 0, out.stderr
    live = [json.loads(x) for x in out.stdout.splitlines()]
    commands = [e for e in live if e["kind"] == "command"]
    assert len(commands) >= 20
    assert {e["command"] for e in commands} >= {"IX", "P?", "P"}
    assert sum(e["status"] == "ok" for e in commands) >= 0.7 * len(commands)
    results = [e for e in live if e["kind"] == "result" and e["command"] == "P?"]
    assert results and all("azimuth_deg" in e["fields"] for e in results)
    assert jsonl(rec) == live
    assert doctor(rec) == [] and go_read(rec)["messages"]["/events"] == len(live)


def test_clean_demo_has_no_problems():
    out = run_cli("demo", "--seconds", "4", "--clean", "--format", "jsonl", timeout=60)
    assert out.returncode == 0, out.stderr
    live = [json.loads(x) for x in out.stdout.splitlines()]
    assert live
    end = live[-1]["t"]
    # FA is NICed on purpose (not implemented); the stop cuts the last transactions
    bad = [e for e in live if e["problems"] and not (e["kind"] == "command" and e["command"] == "FA")
           and e["t"] < end - 0.5]
    assert bad == [], bad


@contextlib.contextmanager
def sim_on_pty(*args):
    """``gimbalscope sim`` on a pty's slave end; yields the master end."""
    master, slave = os.openpty()
    tty.setraw(slave)
    proc = subprocess.Popen([sys.executable, "-m", "analyzer", "sim", os.ttyname(slave), *args],
                            cwd=ROOT, stderr=subprocess.PIPE, text=True)
    try:
        # its start line comes once its port is open (pyserial's open drops what was
        # written before): wait for it rather than for a time a busy machine may exceed
        ready, _, _ = select.select([proc.stderr], [], [], PATIENCE)
        assert ready and "answering on" in proc.stderr.readline(), "sim did not start"
        yield master
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(10)
    assert proc.returncode == 0


def read_for(fd: int, want: int) -> bytes:
    """What ``fd`` gives until ``want`` bytes came or PATIENCE ran out."""
    got, end = b"", time.monotonic() + PATIENCE
    while len(got) < want and time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], 0.1)
        if ready:
            got += os.read(fd, 100)
    return got


def test_sim_answers_on_a_pty():
    with sim_on_pty("--address", "1.1.2") as master:
        os.write(master, frame((1, 1, 2), 0, "P?"))
        # ACK, then the result from device 1.1.2 back to group 0 (Table 3)
        expected = b"\x06" + frame((0, 1, 2), 1, "00000000")
        assert read_for(master, len(expected)) == expected
        os.write(master, frame((1, 1, 9), 0, "P?"))   # another device: silence
        time.sleep(0.3)
        os.set_blocking(master, False)
        try:
            assert os.read(master, 100) == b""
        except BlockingIOError:
            pass


def test_sim_bad_port_is_one_line():
    out = run_cli("sim", "/dev/ttyNOPE9")
    assert out.returncode == 2 and "no such serial port" in out.stderr and "Traceback" not in out.stderr


def test_replay_keeps_the_recorded_pace(tmp_path):
    rec = tmp_path / "r.mcap"
    r = run_cli("convert", os.path.join(ROOT, "captures", "demo-socat.log"), "-o", rec)
    assert r.returncode == 0
    # the sample spans 8.0 s: at speed 4 the last event is due after about 2 s
    t0 = time.monotonic()
    fast = run_cli("replay", rec, "--speed", "4", "--format", "jsonl", timeout=60)
    paced = time.monotonic() - t0
    quick = run_cli("replay", rec, "--speed", "max", "--format", "jsonl", timeout=60)
    assert fast.returncode == quick.returncode == 0
    assert fast.stdout == quick.stdout == run_cli("decode", rec, "--format", "jsonl").stdout
    assert paced >= 8.0 / 4 - 0.1   # it waited for the recorded times (a lower bound, not a speed)


def test_replay_errors():
    out = run_cli("replay", os.path.join(ROOT, "captures", "demo-bus.bin"))
    assert out.returncode == 2 and "replay takes an MCAP recording" in out.stderr
    out = run_cli("replay", "x.mcap", "--speed", "0")
    assert out.returncode == 2 and "'0': a factor above 0" in out.stderr


def test_demo_recording_rotates_by_size(tmp_path):
    rec = tmp_path / "long.mcap"
    out = run_cli("demo", "--seconds", "4", "--format", "jsonl", "--record", rec, "--rotate-mb", "0.004",
                  timeout=60)
    assert out.returncode == 0, out.stderr
    parts = sorted(tmp_path.glob("long-*.mcap"))
    assert len(parts) >= 2
    total = 0
    for k, part in enumerate(parts, 1):
        assert doctor(part) == []
        report = go_read(part)
        assert report["metadata"]["gimbalscope"]["part"] == str(k)
        # a part may hold one line's bytes only: a line's raw bytes are written in timed batches
        raw = report["messages"].get("/serial/A/raw", 0) + report["messages"].get("/serial/B/raw", 0)
        assert raw > 0, part
        total += raw
    assert total > 0


def test_sim_at_a_wrong_baud_rate_answers_garbage():
    with sim_on_pty("--wrong-baud", "19200") as master:
        os.write(master, frame((1, 1, 1), 0, "HO"))
        # the ACK (0x06) sent at 19200 reads as 0xF9 at 9600 (tests/pure/test_uart.py)
        assert read_for(master, 1) == b"\xf9"


def test_demo_and_live_bad_options_are_one_line(tmp_path):
    for args, fragment in ((["demo", "--seconds", "-1"], "argument --seconds: '-1': must be a finite number, 0 or more"),
                           (["live", "loop://", "--record", "/nonexistent-dir/x.mcap"], "cannot write"),
                           (["convert", os.path.join(ROOT, "captures", "demo-bus.bin"), "-o", str(tmp_path),
                             "--force"], "is a directory")):
        out = run_cli(*args, timeout=30)
        assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
        assert len(out.stderr.strip().splitlines()) == 1 and fragment in out.stderr, out.stderr


def test_record_never_replaces_a_recording_silently(tmp_path):
    kept = tmp_path / "kept.mcap"
    kept.write_bytes(b"an earlier recording")
    first_part = tmp_path / "tap-0001.mcap"
    first_part.write_bytes(b"an earlier first part")
    bare_part = tmp_path / "bare-0001.mcap"   # a name without a suffix: its parts are .mcap
    bare_part.write_bytes(b"an earlier first part")
    for args in (["demo", "--seconds", "1", "--format", "jsonl", "--record", kept],
                 ["live", "loop://", "--format", "jsonl", "--record", kept],
                 ["demo", "--seconds", "1", "--format", "jsonl", "--record", tmp_path / "tap.mcap", "--rotate-mb", "1"],
                 ["demo", "--seconds", "1", "--format", "jsonl", "--record", tmp_path / "bare", "--rotate-minutes", "1"]):
        out = run_cli(*args, timeout=60)
        assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
        lines = out.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].endswith("exists (use --force to overwrite)"), out.stderr
    assert kept.read_bytes() == b"an earlier recording"
    assert first_part.read_bytes() == b"an earlier first part" and bare_part.read_bytes() == b"an earlier first part"
    assert not (tmp_path / "tap.mcap").exists()
    # --force replaces it with the new recording
    out = run_cli("demo", "--seconds", "1", "--format", "jsonl", "--record", kept, "--force", timeout=60)
    assert out.returncode == 0, out.stderr
    assert kept.read_bytes().startswith(b"\x89MCAP0\r\n")
