"""The live tap over real pseudo-terminals opened with pyserial."""

import json
import os
import signal
import subprocess
import time
import tty

import pytest
import serial

from analyzer.analysis.findings import SLOW_ANSWERS
from tests.child import Child
from tests.conftest import frame, run_cli
from tests.integration.test_mcap import doctor, go_read, jsonl

BT = 10 / 9600


def pty_pair():
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def start_live(*args):
    """``gimbalscope live ARGS``, returned once it says it is listening."""
    tap = Child("live", *args)
    tap.wait_listening()
    return tap


def recording_tap(tmp_path, name="live.mcap"):
    """Two pty pairs, ``gimbalscope live`` on their slave ends recording to ``name``:
    (line A master, line B master, A path, B path, recording, process)."""
    ma, _sa, pa = pty_pair()
    mb, sb, pb = pty_pair()
    rec = tmp_path / name
    return ma, mb, sb, pa, pb, rec, start_live(pa, pb, "--format", "jsonl", "--record", rec)


def conversation(ma, mb, rounds=3):
    """The controller's bytes on line A, the gimbal's on line B, answers 20 ms late."""
    a, b = b"", b""
    for _ in range(rounds):
        cmd = frame((1, 1, 1), 0, "P?")
        os.write(ma, cmd)
        a += cmd
        time.sleep(0.020 + BT)
        os.write(mb, b"\x06")
        time.sleep(0.005 + 15 * BT)
        res = frame((0, 1, 1), 1, "0FA0FC18")
        os.write(mb, res)
        b += b"\x06" + res
        time.sleep(0.1)
        go = frame((1, 1, 2), 0, "P0FA0FC18")
        os.write(ma, go)
        a += go
        time.sleep(0.010 + BT)
        os.write(mb, b"\x06")
        b += b"\x06"
        time.sleep(0.1)
    return a, b


def stop(tap):
    return tap.stop(signal.SIGINT)


def test_live_equals_decode_of_recording_and_of_the_same_bytes(tmp_path):
    ma, mb, _sb, _pa, _pb, rec, proc = recording_tap(tmp_path, "live.mcap")
    a, b = conversation(ma, mb)
    time.sleep(0.7)
    code, out, err = stop(proc)
    assert code == 0, err
    live = [json.loads(x) for x in out.splitlines()]
    assert [e["kind"] for e in live] == ["command", "ack", "result", "command", "ack"] * 3
    assert all(e["status"] == "ok" for e in live if e["kind"] == "command")
    # the latency is the time from the command's end to the ACK's start, both as the
    # tap stamped them; how long that is depends on how promptly a busy machine
    # reads, so it is checked against the stamps, not against a clock
    for cmd, ack in zip(live[0::5], live[1::5]):
        assert ack["request"] == cmd["number"]
        assert ack["latency"] == pytest.approx(ack["t"] - cmd["t_end"], abs=1e-6)
        assert 0 < ack["latency"] and cmd["t"] < cmd["t_end"] < ack["t"]
    # event for event what decode makes of the recording
    assert jsonl(rec) == live
    assert doctor(rec) == [] and go_read(rec)["metadata"]["gimbalscope"]["mode"] == "live"
    # and the same as decoding the same bytes from raw dumps (which carry no time)
    (tmp_path / "a.bin").write_bytes(a)
    (tmp_path / "b.bin").write_bytes(b)
    untimed = jsonl(tmp_path / "a.bin", tmp_path / "b.bin")
    keys = ("line", "offset", "kind", "command", "fields", "checksum_ok", "txn", "status", "problems", "raw")
    assert [{k: e[k] for k in keys} for e in untimed] == [{k: e[k] for k in keys} for e in live]


def test_port_vanishing_mid_capture_keeps_everything(tmp_path):
    ma, mb, sb, _pa, pb, rec, proc = recording_tap(tmp_path, "live.mcap")
    conversation(ma, mb, rounds=1)
    time.sleep(0.3)
    os.close(mb)          # the device-side adapter is unplugged
    os.close(sb)
    time.sleep(0.5)
    cmd = frame((1, 1, 1), 0, "HO")
    os.write(ma, cmd)     # line A still works
    time.sleep(0.8)
    code, out, err = stop(proc)
    assert code == 0 and "Traceback" not in err
    assert f"{pb}: lost" in err
    live = [json.loads(x) for x in out.splitlines()]
    assert [e["kind"] for e in live] == ["command", "ack", "result", "command", "ack", "command"]
    assert live[-1]["command"] == "HO" and live[-1]["status"] == "no_ack"
    assert jsonl(rec) == live and doctor(rec) == []
    # the gap is marked in the recording: a foxglove.Log message on /log
    from mcap.reader import make_reader
    with open(rec, "rb") as f:
        messages = [json.loads(m.data)["message"] for _s, _c, m in make_reader(f).iter_messages(topics=["/log"])]
    assert any(f"{pb}: lost" in m for m in messages), messages


def test_sigkill_during_record_leaves_a_file_that_reads_and_recovers(tmp_path):
    ma, mb, _sb, pa, pb, rec, proc = recording_tap(tmp_path, "killed.mcap")
    conversation(ma, mb, rounds=3)
    time.sleep(1.5)       # the recorder flushes about once a second
    conversation(ma, mb, rounds=1)
    proc.stop(signal.SIGKILL)
    events = jsonl(rec)
    assert len(events) >= 15                      # at least what was flushed
    assert [e["kind"] for e in events[:5]] == ["command", "ack", "result", "command", "ack"]
    r = run_cli("recover", rec, "-o", tmp_path / "fixed.mcap")
    assert r.returncode == 0, r.stderr
    assert doctor(tmp_path / "fixed.mcap") == []
    fixed = go_read(tmp_path / "fixed.mcap")
    assert fixed["metadata"]["gimbalscope"]["ports"] == f"{pa} {pb}"
    assert jsonl(tmp_path / "fixed.mcap") == events


def one_line(out, fragment):
    assert out.returncode == 2 and out.stdout == "" and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and fragment in out.stderr, out.stderr


def test_missing_port():
    one_line(run_cli("live", "/dev/ttyNOPE0"), "/dev/ttyNOPE0: no such serial port")


def test_not_a_serial_port(tmp_path):
    p = tmp_path / "plain.txt"
    p.write_text("x")
    one_line(run_cli("live", p), "not a serial port")


def test_busy_port():
    _ma, _sa, pa = pty_pair()
    holder = serial.Serial(pa, 9600, exclusive=True)
    try:
        one_line(run_cli("live", pa), f"{pa}: busy")
    finally:
        holder.close()


def test_loop_url_is_accepted_and_sigterm_ends_cleanly():
    code, out, err = start_live("loop://", "--format", "jsonl").stop(signal.SIGTERM)
    assert code == 0 and out == "" and "Traceback" not in err
    assert "gimbalscope live: listening on loop:// (until Ctrl-C)\n" in err


def drifted_round(ma, mb, cmd):
    """The gimbal answers 8 ms after the command, but line A's adapter delivers the
    command 20 ms late: the ACK is read 12 ms before the command."""
    time.sleep(0.008 + BT)
    os.write(mb, b"\x06")
    time.sleep(0.020 - 0.008 - BT)
    os.write(ma, cmd)


def test_skewed_adapters_are_detected_and_corrected(tmp_path):
    ma, mb, _sb, _pa, _pb, rec, proc = recording_tap(tmp_path, "skew.mcap")
    for _ in range(6):
        drifted_round(ma, mb, frame((1, 1, 1), 0, "HO"))
        time.sleep(0.15)
    time.sleep(0.6)
    code, out, err = stop(proc)
    assert code == 0, err
    assert "line B reads about" in err and "ms ahead of line A" in err
    live = [json.loads(x) for x in out.splitlines()]
    commands = [e for e in live if e["kind"] == "command"]
    acks = [e for e in live if e["kind"] == "ack"]
    assert len(commands) == len(acks) == 6
    # after the first pair taught the estimate, every ACK pairs with its command
    assert all(c["status"] == "ok" for c in commands[1:]), [(c["number"], c["status"]) for c in commands]
    # uncorrected they would be -12 ms (more where the machine overslept the
    # harness's 12 ms: the skew then grows, and is corrected as it grows); corrected
    # every one is causal
    assert all(a["latency"] is not None and a["latency"] >= 0 for a in acks[1:]), \
        [(a["number"], a["latency"], a["t"]) for a in acks]
    assert jsonl(rec) == live


def test_skew_correction_switching_on_partway_decodes_as_it_was_shown_live(tmp_path):
    """The adapters drift apart mid-capture: for six rounds the gimbal's ACK comes
    8 ms after its command as read, then line A's adapter starts delivering 20 ms
    late, so ACKs read 12 ms before their commands. The estimate switches on at
    that point; every event (times and latencies included) must decode from the
    recording exactly as the live tap printed it, and the ACKs of before and after
    are not read as one device slowing down."""
    ma, mb, _sb, _pa, _pb, rec, proc = recording_tap(tmp_path, "drift.mcap")
    cmd = frame((1, 1, 1), 0, "HO")
    for k in range(14):
        if k < 6:                       # in step: ACK 8 ms after the command
            os.write(ma, cmd)
            time.sleep(len(cmd) * BT + 0.008)
            os.write(mb, b"\x06")
        else:                           # drifted: the ACK is read first
            drifted_round(ma, mb, cmd)
        time.sleep(0.12)
    time.sleep(0.6)
    code, out, err = stop(proc)
    assert code == 0, err
    assert "line B reads about" in err
    live = [json.loads(x) for x in out.splitlines()]
    assert sum(e["kind"] == "command" for e in live) == 14 and sum(e["kind"] == "ack" for e in live) == 14
    assert jsonl(rec) == live
    found = run_cli("doctor", rec, "--format", "json")
    assert found.returncode == 0, found.stderr
    assert SLOW_ANSWERS not in found.stdout and SLOW_ANSWERS not in err


def test_vanished_port_is_reopened_when_it_returns(tmp_path, socat_bin):
    """A USB adapter unplugged and plugged back keeps its device name: here line B
    is a socat pty link; killing socat removes it, starting it again brings the
    same name back. The tap says both, keeps reading, and decodes what follows."""
    from tests.integration.test_socat_real import wait_for

    tap_b, feed_b = tmp_path / "tapB", tmp_path / "feedB"

    def plug_in():
        proc = subprocess.Popen([socat_bin, f"PTY,link={tap_b},raw,echo=0", f"PTY,link={feed_b},raw,echo=0"])
        wait_for(tap_b)
        wait_for(feed_b)
        return proc, serial.Serial(str(feed_b), 9600)

    ma, _sa, pa = pty_pair()
    adapter, dev = plug_in()
    rec = tmp_path / "live.mcap"
    proc = start_live(pa, tap_b, "--format", "jsonl", "--record", rec)
    try:
        cmd = frame((1, 1, 1), 0, "HO")
        os.write(ma, cmd)
        time.sleep(0.01 + BT)
        dev.write(b"\x06")
        time.sleep(0.3)
        dev.close()
        adapter.terminate()        # unplugged
        adapter.wait(5)
        time.sleep(0.8)
        adapter, dev = plug_in()   # plugged back in, same name
        time.sleep(1.5)            # the tap retries every 0.5 s
        os.write(ma, cmd)
        time.sleep(0.01 + BT)
        dev.write(b"\x06")
        time.sleep(0.5)
        code, out, err = stop(proc)
    finally:
        proc.kill()
        dev.close()
        adapter.terminate()
        adapter.wait(5)
    assert code == 0 and "Traceback" not in err
    assert f"{tap_b}: lost" in err and f"{tap_b}: back" in err
    assert err.index(f"{tap_b}: lost") < err.index(f"{tap_b}: back")
    live = [json.loads(x) for x in out.splitlines()]
    assert [(e["kind"], e["status"]) for e in live] == [("command", "ok"), ("ack", None)] * 2
    assert jsonl(rec) == live and doctor(rec) == []
    from mcap.reader import make_reader
    with open(rec, "rb") as f:
        messages = [json.loads(m.data)["message"] for _s, _c, m in make_reader(f).iter_messages(topics=["/log"])]
    assert any(f"{tap_b}: lost" in m for m in messages) and any(f"{tap_b}: back" in m for m in messages)
