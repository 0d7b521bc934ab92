"""Outputs that cannot be written, or must not be: a full filesystem (a small
tmpfs), /dev/full and a closed standard output, an output that is an input,
folders that are not there, names that are not UTF-8. Each is one line on
stderr and loses nothing; a live tap whose recording fails keeps tapping."""

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import tty

import pytest

import analyzer
from tests.child import LISTENING, wait_for
from tests.child import PATIENCE as WAIT
from tests.conftest import ROOT, frame, run_cli

SAMPLES = os.path.join(ROOT, "captures")
SOCAT_LOG = os.path.join(SAMPLES, "demo-socat.log")
BUS = os.path.join(SAMPLES, "demo-bus.bin")
EXE = shutil.which("gimbalscope")
CMD = [EXE] if EXE else [sys.executable, "-m", "analyzer"]
BT = 10 / 9600


def one_line(out, code, *fragments):
    """``out`` failed with exit ``code``: one line on stderr holding ``fragments``."""
    err = out.stderr if isinstance(out.stderr, str) else os.fsdecode(out.stderr)
    assert out.returncode == code, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("gimbalscope: error: ")
    for f in fragments:
        assert f in lines[0], lines[0]
    return lines[0]


def run_bytes(*args, timeout=60):
    """Run the command with ``bytes`` arguments (file names as the OS gives them)."""
    argv = [os.fsencode(a) for a in CMD] + [a if isinstance(a, bytes) else os.fsencode(str(a)) for a in args]
    return subprocess.run(argv, capture_output=True, timeout=timeout, cwd=ROOT, check=False)


# ------------------------------------------------------------ a full filesystem
@pytest.fixture
def small_fs(tmp_path):
    """A 256 KiB tmpfs, unmounted afterwards (skipped where mounting is not allowed)."""
    where = tmp_path / "small"
    where.mkdir()
    try:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(where)],
                           capture_output=True, text=True, timeout=30, check=False)
    except (OSError, subprocess.TimeoutExpired) as e:
        pytest.skip(f"cannot mount a tmpfs: {e}")
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {r.stderr.strip()}")
    try:
        yield where
    finally:
        if subprocess.run(["umount", str(where)], capture_output=True, timeout=30, check=False).returncode != 0:
            subprocess.run(["umount", "-l", str(where)], capture_output=True, timeout=30, check=False)


def fill(folder) -> None:
    """Fill the filesystem holding ``folder`` to the last byte."""
    fd = os.open(os.path.join(folder, "filler"), os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    try:
        block = b"\0" * 4096
        while True:
            try:
                os.write(fd, block)
            except OSError:
                break
        while True:   # what is left is smaller than a block
            try:
                os.write(fd, b"\0")
            except OSError:
                break
    finally:
        os.close(fd)


@pytest.mark.parametrize("name", ["out.mcap", "out.jsonl"])
def test_convert_onto_a_full_disk_is_one_line_and_leaves_no_file(small_fs, name):
    fill(small_fs)
    out = run_cli("convert", SOCAT_LOG, "-o", small_fs / name)
    one_line(out, 1, f"{small_fs / name}: cannot write: no space left on device")
    assert sorted(os.listdir(small_fs)) == ["filler"]   # no partial file, no 0-byte one


def test_convert_onto_a_full_disk_keeps_the_file_it_would_replace(small_fs):
    old = small_fs / "old.mcap"
    assert run_cli("convert", BUS, "-o", old).returncode == 0
    before = old.read_bytes()
    fill(small_fs)
    one_line(run_cli("convert", SOCAT_LOG, "-o", old, "--force"), 1, "no space left on device")
    assert old.read_bytes() == before
    assert sorted(os.listdir(small_fs)) == ["filler", "old.mcap"]


def pty_pair():
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def one_round(ma, mb) -> None:
    """A command on line A, its ACK and result on line B: three events, paced as
    on a 9600 baud wire (a read is stamped when its last byte came)."""
    os.write(ma, frame((1, 1, 1), 0, "P?"))
    time.sleep(0.020 + BT)
    os.write(mb, b"\x06")
    time.sleep(0.005 + 15 * BT)
    os.write(mb, frame((0, 1, 1), 1, "0FA0FC18"))
    time.sleep(0.1)


class Reader(threading.Thread):
    """Collects a pipe's lines as they come."""

    def __init__(self, pipe) -> None:
        super().__init__(daemon=True)
        self.pipe, self.lines = pipe, []

    def run(self) -> None:
        for line in self.pipe:
            self.lines.append(line)

    def text(self) -> str:
        return "".join(self.lines)


def events_on_disk(path) -> int:
    """The events a live recording holds as it stands, read as a killed tap's file
    is (up to its last whole chunk); 0 while it holds no chunk yet."""
    try:
        return sum(1 for _ in analyzer.open(str(path)))
    except analyzer.CaptureError:
        return 0


def test_live_recording_onto_a_full_disk_stops_it_and_the_tap_goes_on(small_fs):
    ma, _sa, pa = pty_pair()
    mb, _sb, pb = pty_pair()
    rec = small_fs / "live.mcap"
    proc = subprocess.Popen(CMD + ["live", pa, pb, "--format", "jsonl", "--record", str(rec)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    out, err = Reader(proc.stdout), Reader(proc.stderr)
    out.start()
    err.start()
    try:
        wait_for(lambda: LISTENING in err.text() or proc.poll() is not None, "the tap to listen")
        assert proc.poll() is None, err.text()
        # The disk fills only once the recording holds a whole round: the recorder
        # keeps whole chunks (flushed about every second), and removes a recording
        # stopped before one reached the disk. The tap prints nothing about what it
        # kept until it stops, so the file is read as it stands. Its size says less:
        # its header and metadata are written one after the other, and a chunk may
        # hold part of a round. What was read may be a chunk still being written:
        # once a later round has been printed, that write has returned (the tap
        # records each read before it prints its events, in one thread).
        rounds, held = 0, False
        while True:
            one_round(ma, mb)
            rounds += 1
            wait_for(lambda rounds=rounds: len(out.lines) == 3 * rounds, "the round's events")
            if held:
                break
            held = events_on_disk(rec) >= 3
            assert rounds < 400, "the recording never flushed"
        fill(small_fs)
        deadline = time.monotonic() + WAIT
        while "recording stopped" not in err.text():   # the chunks still fit in the file's last page
            assert time.monotonic() < deadline, err.text()
            one_round(ma, mb)
            rounds += 1
            time.sleep(0.3)
        for _ in range(3):   # the tap goes on printing
            one_round(ma, mb)
            rounds += 1
        wait_for(lambda: len(out.lines) == 3 * rounds, "the events after the disk filled")
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=WAIT)
        out.join(WAIT)
        err.join(WAIT)
    stderr = err.text()
    assert proc.returncode == 0 and "Traceback" not in stderr, stderr
    assert stderr.count("recording stopped") == 1, stderr
    assert f"{rec}: recording stopped: no space left on device (" in stderr
    live = [json.loads(x) for x in out.lines]
    assert [e["kind"] for e in live] == ["command", "ack", "result"] * rounds
    # what was written reads back: the events up to the disk filling
    os.unlink(small_fs / "filler")
    r = run_cli("decode", rec, "--format", "jsonl")
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    recorded = [json.loads(x) for x in r.stdout.splitlines()]
    assert 3 <= len(recorded) < len(live)
    keys = ("line", "offset", "kind", "raw")
    assert [{k: e[k] for k in keys} for e in recorded] == [{k: e[k] for k in keys} for e in live[:len(recorded)]]


def test_tui_feed_recording_onto_a_full_disk_is_said_once_and_the_capture_goes_on(small_fs):
    """The TUI's capture thread (no screen needed): the same as the printing tap."""
    from analyzer.capture import open_live
    from analyzer.info import CaptureInfo
    from analyzer.listeners import DoctorListener
    from analyzer.runner import TapRunner
    from analyzer.tui.feed import Feed
    from analyzer.writers.mcap import McapWriter

    ma, _sa, pa = pty_pair()
    mb, _sb, pb = pty_pair()
    rec = small_fs / "tui.mcap"
    capture = open_live([pa, pb])
    info = CaptureInfo.of(capture, command="live")
    recorder = McapWriter(str(rec), info, live=True, flush_interval=0.2)   # reach the full disk sooner
    batches = []
    doctor = DoctorListener(tui=True)
    runner = TapRunner(capture, [recorder, doctor], info=info)
    feed = Feed(runner, batches.append, doctor, recorder=recorder)
    runner.add_listener(feed)

    def events() -> int:
        return sum(len(b.events) for b in list(batches))

    def warnings() -> list[str]:
        return [w for b in list(batches) for w in b.warnings]

    feed.start()
    try:
        # The disk fills only once the recorder says it kept a whole round (as the
        # test above, here by its own count): it keeps whole chunks, and removes a
        # recording stopped before one reached the disk. The file growing says
        # less: a chunk closed on time may hold part of a round.
        one_round(ma, mb)
        rounds = 1
        wait_for(lambda: events() >= 3, "the first round's events")
        first = recorder.count   # the recorder heard the round before the feed passed it on
        while recorder.recorder.kept < first:
            one_round(ma, mb)   # a chunk is closed by a message that comes after the interval
            rounds += 1
            wait_for(lambda rounds=rounds: events() >= 3 * rounds, "the round's events")
            assert rounds < 400, "the recording never flushed"
        fill(small_fs)
        deadline = time.monotonic() + WAIT
        while not any("recording stopped" in w for w in warnings()):
            assert time.monotonic() < deadline, warnings()
            one_round(ma, mb)
            rounds += 1
            time.sleep(0.3)
        for _ in range(3):
            one_round(ma, mb)
            rounds += 1
        wait_for(lambda: events() >= 3 * rounds - 1, "the events after the disk filled")
    finally:
        feed.stop()
        feed.join(WAIT)
    assert not feed.is_alive()
    said = [w for w in warnings() if "recording stopped" in w]
    assert len(said) == 1 and said[0].startswith(f"{rec}: recording stopped: no space left on device")
    assert feed.notes == said and feed.recorder is None
    assert batches[-1].done and batches[-1].error is None and batches[-1].recording is None
    os.unlink(small_fs / "filler")
    recorded = [e.to_dict() for e in analyzer.open(str(rec))]
    assert len(recorded) >= 3


def test_live_recording_on_a_full_disk_from_the_start_is_one_line(small_fs):
    _ma, _sa, pa = pty_pair()
    fill(small_fs)
    out = run_cli("live", pa, "--record", small_fs / "x.mcap", timeout=WAIT)
    one_line(out, 1, f"{small_fs / 'x.mcap'}: cannot write: no space left on device")
    assert sorted(os.listdir(small_fs)) == ["filler"]


# ------------------------------------------------------------ standard output
@pytest.mark.parametrize("args", [["decode", SOCAT_LOG], ["decode", SOCAT_LOG, "--format", "jsonl"],
                                  ["decode", SOCAT_LOG, "--color", "always"], ["stats", SOCAT_LOG]])
def test_stdout_on_a_full_disk_is_one_line(args):
    with open("/dev/full", "w") as full:
        out = subprocess.run(CMD + args, stdout=full, stderr=subprocess.PIPE, text=True, timeout=60, cwd=ROOT,
                             check=False)
    one_line(out, 1, "standard output: cannot write: no space left on device")


def test_closed_stdout_is_one_line():
    cmd = " ".join(CMD) + f" decode {SOCAT_LOG} >&-"
    out = subprocess.run(["bash", "-c", cmd], capture_output=True, text=True, timeout=60, cwd=ROOT, check=False)
    one_line(out, 1, "standard output is closed")


# ------------------------------------------------------------ output over an input
def test_convert_onto_its_input_is_refused_and_the_input_kept(tmp_path):
    log = tmp_path / "s.log"
    shutil.copy(SOCAT_LOG, log)
    before = log.read_bytes()
    one_line(run_cli("convert", log, "-o", log, "--force"), 2, f"{log}: is the input {log}")
    assert log.read_bytes() == before


@pytest.mark.parametrize("link", ["symlink", "hardlink"])
def test_convert_onto_its_input_through_a_link_is_refused(tmp_path, link):
    rec = tmp_path / "rec.mcap"
    assert run_cli("convert", BUS, "-o", rec).returncode == 0
    before = rec.read_bytes()
    other = tmp_path / "other.mcap"
    (os.symlink if link == "symlink" else os.link)(rec, other)
    one_line(run_cli("convert", rec, "-o", other, "--force"), 2, "is the same file as the input")
    assert rec.read_bytes() == before and other.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other.mcap", "rec.mcap"]


def test_convert_onto_the_second_raw_dump_is_refused(tmp_path):
    a, b = tmp_path / "a.bin", tmp_path / "b.jsonl"
    shutil.copy(os.path.join(SAMPLES, "demo-ctl.bin"), a)
    shutil.copy(os.path.join(SAMPLES, "demo-dev.bin"), b)
    before = b.read_bytes()
    one_line(run_cli("convert", a, b, "-o", b, "--force"), 2, "is the input")
    assert b.read_bytes() == before


@pytest.mark.parametrize("where,fragment", [("missing/x.mcap", "no such folder"), ("adir", "is a directory")])
def test_convert_output_folder_problems_are_one_line(tmp_path, where, fragment):
    (tmp_path / "adir").mkdir()
    one_line(run_cli("convert", BUS, "-o", tmp_path / where), 2, str(tmp_path / where), fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir"]


@pytest.mark.parametrize("where,fragment", [("missing/x.mcap", "no such folder"), ("adir", "is a directory")])
def test_live_record_folder_problems_are_refused_before_the_tap(tmp_path, where, fragment):
    (tmp_path / "adir").mkdir()
    _ma, _sa, pa = pty_pair()
    one_line(run_cli("live", pa, "--record", tmp_path / where, timeout=WAIT), 2, fragment)


def test_live_record_onto_a_port_is_refused(tmp_path):
    _ma, _sa, pa = pty_pair()
    _mb, _sb, pb = pty_pair()
    one_line(run_cli("live", pa, pb, "--record", pb, timeout=WAIT), 2, f"{pb}: is the port {pb}")


# ------------------------------------------------------------ formats by suffix
@pytest.mark.parametrize("suffix", [".jsonl", ".ndjson"])
def test_convert_to_json_lines_equals_decode(tmp_path, suffix):
    out = tmp_path / f"x{suffix}"
    r = run_cli("convert", SOCAT_LOG, "-o", out)
    decoded = run_cli("decode", SOCAT_LOG, "--format", "jsonl")
    assert out.read_text() == decoded.stdout and decoded.stdout
    # it says what it wrote, as export and report do: one event a line
    lines = decoded.stdout.count("\n")
    assert r.returncode == 0 and r.stderr == f"gimbalscope: wrote {lines:,} events to {out}\n", r.stderr


@pytest.mark.parametrize("name", ["x.json", "x.txt", "x"])
def test_convert_to_an_unknown_suffix_is_refused(tmp_path, name):
    line = one_line(run_cli("convert", BUS, "-o", tmp_path / name), 2, str(tmp_path / name))
    assert ".mcap" in line and ".jsonl" in line and ".ndjson" in line
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------ names that are not UTF-8
def test_non_utf8_input_and_output_names(tmp_path):
    folder = os.fsencode(tmp_path)
    src = os.path.join(folder, b"caf\xe9-bus.bin")
    with open(BUS, "rb") as f, open(src, "wb") as g:
        g.write(f.read())
    expected = run_bytes("decode", src, "--format", "jsonl")
    assert expected.returncode == 0 and expected.stdout, expected.stderr
    for name in (b"out-\xff.mcap", b"out-\xff.jsonl"):
        out = os.path.join(folder, name)
        r = run_bytes("convert", src, "-o", out)
        # one line saying what it wrote, the name's undecodable byte shown as \xff
        shown = os.path.join(folder, name.replace(b"\xff", b"\\xff"))
        assert r.returncode == 0 and r.stderr.count(b"\n") == 1 and r.stderr.endswith(b" to " + shown + b"\n"), r.stderr
        assert os.listdir(folder).count(name) == 1
    decoded = run_bytes("decode", os.path.join(folder, b"out-\xff.mcap"), "--format", "jsonl")
    assert decoded.returncode == 0 and decoded.stdout == expected.stdout, decoded.stderr
    with open(os.path.join(folder, b"out-\xff.jsonl"), "rb") as f:
        assert f.read() == expected.stdout
    from mcap.reader import make_reader
    with open(os.path.join(folder, b"out-\xff.mcap"), "rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert "caf\\xe9-bus.bin" in meta["gimbalscope"]["inputs"]
    # and an error naming one prints it, escaped, in one line
    one_line(run_bytes("convert", src, "-o", src, "--force"), 2, "caf\\xe9-bus.bin: is the input")


# ------------------------------------------------------------ success is no warning
def test_a_finished_recording_is_a_status_line_not_a_warning(tmp_path):
    ma, _sa, pa = pty_pair()
    rec = tmp_path / "ok.mcap"
    proc = subprocess.Popen(CMD + ["live", pa, "--format", "jsonl", "--record", str(rec)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    out = Reader(proc.stdout)
    out.start()
    try:
        wait_for(lambda: rec.exists(), "the recording to start")
        os.write(ma, frame((1, 1, 1), 0, "P?") + b"\x06" + frame((0, 1, 1), 1, "0FA0FC18"))
        wait_for(lambda: out.lines, "the tap to print")   # it is running: SIGTERM ends it cleanly
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=WAIT)
        out.join(WAIT)
    err = proc.stderr.read()
    assert proc.returncode == 0, err
    assert "gimbalscope: recorded " in err and f" messages to {rec}" in err
    assert "warning: recorded" not in err
