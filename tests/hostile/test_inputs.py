"""Inputs the way users really give them: standard input (``-``, ``/dev/stdin``),
FIFOs and ``<(…)`` pipes, gzip/zstd/xz/bz2 files, cut compressed files, socat
logs with a stray line or an impossible date, text files that are no capture.

Every input is decoded through the CLI (a separate process, real pipes and
FIFOs) and compared with what the plain file decodes to, or with frames built
here by hand (``tests.conftest.frame``).
"""

from __future__ import annotations

import bz2
import contextlib
import datetime
import gzip
import json
import lzma
import os
import shutil
import subprocess
import sys
import threading
import zlib

import pytest

from tests.conftest import BUS, CTL, DEV, ROOT, SOCAT_LOG, frame

BT = 10 / 9600


def cli(*args, stdin: bytes | None = None, tmpdir=None) -> subprocess.CompletedProcess:
    """The console command with ``stdin`` given through a pipe; bytes out."""
    exe = shutil.which("gimbalscope")
    cmd = [exe] if exe else [sys.executable, "-m", "analyzer"]
    env = dict(os.environ, TMPDIR=str(tmpdir)) if tmpdir else None
    return subprocess.run(cmd + [str(a) for a in args], input=stdin,
                          stdin=None if stdin is not None else subprocess.DEVNULL,
                          capture_output=True, timeout=120, cwd=ROOT, env=env, check=False)


def jsonl(*args, stdin: bytes | None = None, tmpdir=None) -> tuple[list[dict], list[str]]:
    """Decoded events and the stderr lines; the run must succeed."""
    out = cli("decode", *args, "--format", "jsonl", stdin=stdin, tmpdir=tmpdir)
    err = out.stderr.decode()
    assert out.returncode == 0, err
    assert "Traceback" not in err
    return [json.loads(x) for x in out.stdout.splitlines()], err.splitlines()


def plain(*paths) -> list[dict]:
    events, _ = jsonl(*paths)
    assert events
    return events


def compress(kind: str, data: bytes) -> bytes:
    if kind == "gzip":
        return gzip.compress(data)
    if kind == "xz":
        return lzma.compress(data)
    if kind == "bz2":
        return bz2.compress(data)
    zstandard = pytest.importorskip("zstandard")
    return zstandard.ZstdCompressor().compress(data)


SUFFIX = {"gzip": ".gz", "zstd": ".zst", "xz": ".xz", "bz2": ".bz2"}


def read(path) -> bytes:
    with open(path, "rb") as f:
        return f.read()


@contextlib.contextmanager
def fifo_writer(path, data: bytes):
    """A FIFO at ``path`` fed ``data`` by a thread, as a shell's ``<(…)`` does."""
    os.mkfifo(path)

    def write() -> None:
        try:
            with open(path, "wb") as f:
                f.write(data)
        except BrokenPipeError:
            pass   # the reader went away early

    t = threading.Thread(target=write, daemon=True)
    t.start()
    try:
        yield str(path)
    finally:
        if t.is_alive():
            # nobody opened it for reading: do, so the writer's open returns
            fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
            os.close(fd)
        t.join(10)


# ------------------------------------------------------------ standard input

@pytest.mark.parametrize("name", ["-", "/dev/stdin"])
def test_socat_log_from_standard_input_equals_the_file(name):
    events, _ = jsonl(name, stdin=read(SOCAT_LOG))
    assert events == plain(SOCAT_LOG)


def test_raw_dump_from_standard_input_equals_the_file():
    events, _ = jsonl("-", stdin=read(BUS))
    assert events == plain(BUS)


def test_compressed_mcap_through_a_pipe_equals_the_file(tmp_path):
    rec = make_mcap(tmp_path)
    spool = tmp_path / "tmp"
    spool.mkdir()
    events, _ = jsonl("-", stdin=gzip.compress(read(rec)), tmpdir=spool)
    assert events == plain(rec)
    assert os.listdir(spool) == []   # the temporary copy is gone


def test_standard_input_given_twice_is_refused():
    out = cli("decode", "-", "-", stdin=read(CTL))
    one_line_error(out, "standard input", "once")


# ------------------------------------------------------------ FIFOs and <(…)

def test_fifo_with_a_writer(tmp_path):
    with fifo_writer(tmp_path / "tap.fifo", read(SOCAT_LOG)) as fifo:
        events, _ = jsonl(fifo)
    assert events == plain(SOCAT_LOG)


def test_two_raw_dumps_from_two_pipes_are_lines_a_and_b(tmp_path):
    a = frame((1, 1, 1), 0, "P?") + frame((1, 1, 2), 0, "HO")
    b = b"\x06" + frame((0, 1, 1), 1, "0FA0FC18") + b"\x15"
    with fifo_writer(tmp_path / "a", a) as fa, fifo_writer(tmp_path / "b", b) as fb:
        events, _ = jsonl(fa, fb)
    assert [(e["line"], e["raw"]) for e in events] == [
        ("A", frame((1, 1, 1), 0, "P?").hex()), ("B", "06"), ("B", frame((0, 1, 1), 1, "0FA0FC18").hex()),
        ("A", frame((1, 1, 2), 0, "HO").hex()), ("B", "15")]
    assert events[0]["status"] == "ok" and events[3]["status"] == "nak"


def test_sample_raw_dumps_from_two_pipes_equal_the_files(tmp_path):
    with fifo_writer(tmp_path / "a", read(CTL)) as fa, fifo_writer(tmp_path / "b", read(DEV)) as fb:
        events, _ = jsonl(fa, fb)
    assert events == plain(CTL, DEV)


# ------------------------------------------------------------ compressed files

def make_mcap(tmp_path) -> str:
    rec = tmp_path / "rec.mcap"
    out = cli("convert", SOCAT_LOG, "-o", rec)
    assert out.returncode == 0, out.stderr.decode()
    return str(rec)


@pytest.mark.parametrize("kind", ["gzip", "zstd", "xz", "bz2"])
@pytest.mark.parametrize("what", ["socat", "raw", "two raw", "mcap"])
def test_compressed_input_equals_the_plain_file(tmp_path, kind, what):
    originals = {"socat": [SOCAT_LOG], "raw": [BUS], "two raw": [CTL, DEV]}.get(what) or [make_mcap(tmp_path)]
    packed = []
    for i, path in enumerate(originals):
        p = tmp_path / f"in{i}{os.path.splitext(path)[1]}{SUFFIX[kind]}"
        p.write_bytes(compress(kind, read(path)))
        packed.append(p)
    events, err = jsonl(*packed)
    assert events == plain(*originals)
    assert err == []


def test_concatenated_gzip_members_are_one_input(tmp_path):
    data = read(SOCAT_LOG)
    half = len(data) // 2
    p = tmp_path / "tap.log.gz"
    p.write_bytes(gzip.compress(data[:half]) + gzip.compress(data[half:]))
    events, err = jsonl(p)
    assert events == plain(SOCAT_LOG) and err == []


def many_frames() -> list[bytes]:
    out = []
    for i in range(3000):
        dev = (1, 1, 1 + i % 3)
        out.append(frame(dev, 0, f"P{i % 256:02X}{(i * 7) % 256:02X}{i % 100:02d}01"))
        out.append(b"\x06")
    return out


@pytest.mark.parametrize("through", ["file", "stdin"])
def test_cut_gzip_gives_a_warning_and_everything_before_the_cut(tmp_path, through):
    data = b"".join(many_frames())
    packed = gzip.compress(data)
    cut = packed[:len(packed) // 2]
    # what the cut file still holds, decompressed here independently
    before = zlib.decompressobj(16 + zlib.MAX_WBITS).decompress(cut)
    assert 0 < len(before) < len(data)
    p = tmp_path / "bus.bin.gz"
    p.write_bytes(cut)
    events, err = jsonl(p) if through == "file" else jsonl("-", stdin=cut)
    assert b"".join(bytes.fromhex(e["raw"]) for e in events) == before   # nothing lost, nothing made up
    name = "bus.bin.gz" if through == "file" else "standard input"
    assert len(err) == 1, err
    assert err[0].startswith("gimbalscope: warning: ") and name in err[0]
    assert f"compressed data ends early at byte {len(cut)}" in err[0]


# ------------------------------------------------------------ socat logs with damage

START = datetime.datetime(2026, 11, 21, 8, 35, 52)


def stamp(us: int, nanoseconds: bool = False) -> str:
    """socat's time: local date and time, a 9-digit fraction (µs as Debian's
    socat 1.7.4 writes it, or real ns)."""
    t = START + datetime.timedelta(microseconds=us)
    frac = t.microsecond * 1000 if nanoseconds else t.microsecond
    return t.strftime("%Y/%m/%d %H:%M:%S") + f".{frac:09d}"


def hex_lines(data: bytes) -> list[str]:
    lines = []
    for i in range(0, len(data), 16):
        row = data[i:i + 16]
        text = "".join(chr(b) if 32 <= b < 127 else "." for b in row)
        lines.append("".join(f" {b:02x}" for b in row).ljust(49) + text)
    return lines


class SocatLog:
    """A socat -x -v log built chunk by chunk; remembers the line number of each header."""

    def __init__(self, nanoseconds: bool = False) -> None:
        self.lines: list[str] = []
        self.sent = {">": 0, "<": 0}
        self.chunks: list[bytes] = []
        self.header_line: list[int] = []
        self.nanoseconds = nanoseconds

    def chunk(self, direction: str, data: bytes, us: int, when: str | None = None) -> None:
        start = self.sent[direction]
        self.sent[direction] += len(data)
        self.lines.append(f"{direction} {when or stamp(us, self.nanoseconds)}  length={len(data)} "
                          f"from={start} to={start + len(data) - 1}")
        self.header_line.append(len(self.lines))
        self.lines += hex_lines(data)
        self.lines.append("--")
        self.chunks.append(data)

    def insert(self, after_line: int, text: str) -> int:
        """Put a line after line ``after_line``; its number."""
        self.lines.insert(after_line, text)
        self.header_line = [n + 1 if n > after_line else n for n in self.header_line]
        return after_line + 1

    def write(self, path) -> str:
        path.write_text("\n".join(self.lines) + "\n")
        return str(path)


def exchanges(n: int) -> SocatLog:
    """``n`` position queries, each ACKed and answered (stamps are when the last byte came)."""
    log = SocatLog()
    for i in range(n):
        dev = (1, 1, 1 + i % 3)
        t = i * 100_000
        log.chunk(">", frame(dev, 0, "P?"), t)
        log.chunk("<", b"\x06", t + 20_000)
        log.chunk("<", frame((0, 1, dev[2]), 1, f"{i:04X}FC18"), t + 50_000)
    return log


def test_socat_log_with_a_stray_line_and_an_impossible_date_keeps_every_other_event(tmp_path):
    log = exchanges(150)
    # a stray line between a header and its hex (the chunk's bytes follow it)
    junk_at = log.insert(log.header_line[200], "junk")
    # a header whose date cannot be: its chunk (a result) is lost, nothing else
    bad = 302
    assert bad % 3 == 2
    bad_line = log.header_line[bad]
    log.lines[bad_line - 1] = log.lines[bad_line - 1].replace("2026/11/21", "2026/13/45")
    events, err = jsonl(log.write(tmp_path / "tap.log"))
    expected = [c.hex() for i, c in enumerate(log.chunks) if i != bad]
    assert [e["raw"] for e in events] == expected
    assert len(events) == 3 * 150 - 1
    junk = [w for w in err if f"tap.log:{junk_at}:" in w]
    date = [w for w in err if f"tap.log:{bad_line}:" in w]
    assert len(junk) == 1 and len(date) == 1, err
    assert "2026/13/45" in date[0]
    assert len(err) == 2, err


def test_many_stray_lines_are_one_counted_warning(tmp_path):
    log = exchanges(60)
    first = log.insert(log.header_line[30] + 2, "junk")      # after the chunk's "--"
    log.insert(log.header_line[90], "more junk")               # between a header and its hex
    log.insert(log.header_line[150] + 2, "ERROR: something else wrote here")
    events, err = jsonl(log.write(tmp_path / "tap.log"))
    assert [e["raw"] for e in events] == [c.hex() for c in log.chunks]
    assert len(err) == 1, err
    assert "tap.log" in err[0] and "3 " in err[0] and f"line {first}" in err[0]


def test_nanosecond_log_from_a_pipe_is_read_in_nanoseconds(tmp_path):
    # real nanoseconds (newer socat), but every fraction below 1 000 000 for more
    # than the first 64 KiB: only a look at the first 2000 headers tells the unit
    log = SocatLog(nanoseconds=True)
    n = 1200
    for i in range(n):
        us = i * 1_000_000 + (500 if i < 900 else 600_000)
        log.chunk(">", frame((1, 1, 1), 0, "P?"), us)
    text = "\n".join(log.lines) + "\n"
    assert len(text.split("600000000")[0]) > 1 << 16
    events, _ = jsonl("-", stdin=text.encode())
    assert len(events) == n
    # t is the first byte's start: the stamp less the frame's 9 byte times
    t0 = 0.0005 - 9 * BT
    for i in (1, 899, 900, n - 1):
        frac = 0.0005 if i < 900 else 0.6
        assert events[i]["t"] == pytest.approx(i + frac - 9 * BT - t0, abs=1e-6)


# ------------------------------------------------------------ not a capture

def one_line_error(out, *fragments):
    err = out.stderr.decode()
    assert out.returncode == 2, err
    assert out.stdout == b""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("gimbalscope: error: ") and "Traceback" not in err
    for f in fragments:
        assert f in lines[0]


def test_one_line_text_without_newline_is_refused(tmp_path):
    p = tmp_path / "note.txt"
    p.write_bytes(b"remember to check the cable")
    one_line_error(cli("decode", p), "note.txt", "not a socat -x -v log")


def test_a_terminal_is_refused_not_waited_on():
    # reading a terminal (or a serial port given to decode instead of live) would
    # wait for typing forever
    master, slave = os.openpty()
    try:
        name = os.ttyname(slave)
        one_line_error(cli("decode", name), name, "terminal")
        exe = shutil.which("gimbalscope")
        cmd = [exe] if exe else [sys.executable, "-m", "analyzer"]
        out = subprocess.run(cmd + ["decode", "-"], stdin=slave, capture_output=True, timeout=120, cwd=ROOT,
                             check=False)
        one_line_error(out, "standard input", "terminal")
    finally:
        os.close(master)
        os.close(slave)
