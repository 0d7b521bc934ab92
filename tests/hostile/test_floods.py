"""Floods and huge noise on real pseudo-terminals: a live tap pushed more bytes than
it can decode keeps its memory flat, still records every byte, says how many it
passed over (once, with updates, not per chunk), never stitches a frame across
what it skipped, and ends promptly on SIGTERM; a run of noise comes in pieces of
at most 4 KiB."""

from __future__ import annotations

import base64
import itertools
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time

from dissectors.deframer import NOISE_PIECE
from tests.child import LISTENING, wait_for
from tests.conftest import ROOT, run_cli
from tests.integration.test_live import pty_pair

FLOOD_BYTES = 40_000_000
# What the tap may hold beyond its start-up size while flooded: its read queue
# (1 MiB), a piece of noise, pairing's few seconds of events, the recorder's
# chunk. Holding the flood itself would take FLOOD_BYTES and more.
HELD_LIMIT_MB = 25
WARM_BYTES = 4_000_000   # flooded before the baseline is taken; the other 36 MB must not be held
# A correctness bound, not a speed target: a tap that drained its backlog through
# the decoder took minutes here; one that hands it to the recording takes well under 1 s.
STOP_BOUND_S = 10


def vm(pid: int, key: str) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) / 1024
    raise AssertionError(f"no {key} for {pid}")


def start_tap(tmp_path, *ports):
    """``gimbalscope live PORTS --format jsonl --record`` with stdout and stderr in
    files (a pipe nobody reads would stall it)."""
    rec = tmp_path / "flood.mcap"
    with open(tmp_path / "out.jsonl", "w") as out, open(tmp_path / "err.txt", "w") as err:
        proc = subprocess.Popen([sys.executable, "-m", "analyzer", "live", *ports, "--format", "jsonl",
                                 "--record", str(rec)], stdout=out, stderr=err, cwd=ROOT)
    said = tmp_path / "err.txt"
    wait_for(lambda: LISTENING in said.read_text() or proc.poll() is not None, "the tap to listen")
    assert proc.poll() is None, said.read_text()
    return proc, rec


class Flood(threading.Thread):
    """Random bytes into a pty master, as fast as the tap takes them, until
    ``limit`` bytes or ``stop()``."""

    def __init__(self, master: int, limit: int | None = None) -> None:
        super().__init__(daemon=True)
        self.master, self.limit, self.written = master, limit, 0
        self._enough = threading.Event()

    def run(self) -> None:
        block = os.urandom(1 << 20)
        k = 0
        os.set_blocking(self.master, False)   # so that stop() works once nobody reads
        while not self._enough.is_set() and (self.limit is None or self.written < self.limit):
            piece = block[k:k + 4096]
            if self.limit is not None:
                piece = piece[:self.limit - self.written]
            try:
                self.written += os.write(self.master, piece)
            except BlockingIOError:
                time.sleep(0.001)             # the pty is full: the tap has not read yet
                continue
            k = (k + 4096) % len(block)

    def stop(self) -> None:
        self._enough.set()
        self.join()


def recorded(rec) -> dict[str, tuple[int, bool]]:
    """Per line: bytes in the recording's raw topic, and whether its chunks cover
    the line without gap or overlap (each starts where the one before ended)."""
    from mcap.reader import make_reader

    spans: dict[str, list[tuple[int, int]]] = {}
    with open(rec, "rb") as f:
        for _s, channel, m in make_reader(f).iter_messages():
            if not channel.topic.endswith("/raw"):
                continue
            msg = json.loads(m.data)
            if msg["data"]:            # not the end marker
                size = len(base64.b64decode(msg["data"], validate=True))
                spans.setdefault(msg["line"], []).append((msg["offset"], size))
    out = {}
    for line, chunks in spans.items():
        chunks.sort()
        ends = [off + n for off, n in chunks]
        out[line] = (sum(n for _o, n in chunks),
                     chunks[0][0] == 0 and all(off == end for (off, _n), end in zip(chunks[1:], ends)))
    return out


def undecoded_total(err: str) -> dict[str, int]:
    """The tap's final word on what it passed over: bytes per line."""
    m = re.search(r"bytes? not decoded \((.*)\); a recording keeps every byte", err)
    if m is None:
        return {}
    return {k: int(v.replace(",", "")) for k, v in re.findall(r"line (\w+): ([\d,]+) byte", m.group(1))}


def events_of(tmp_path) -> list[dict]:
    return [json.loads(x) for x in (tmp_path / "out.jsonl").read_text().splitlines()]


def assert_tiles(events: list[dict], line: str, skipped: int, total: int) -> None:
    """Decoded events and skipped bytes account for every byte of the line, once."""
    mine = sorted((e for e in events if e["line"] == line), key=lambda e: e["offset"])
    decoded = sum(len(e["raw"]) // 2 for e in mine)
    assert decoded + skipped == total, (decoded, skipped, total)
    for a, b in itertools.pairwise(mine):
        assert a["offset"] + len(a["raw"]) // 2 <= b["offset"]   # no byte in two events
    assert all(len(e["raw"]) // 2 <= NOISE_PIECE for e in mine if e["kind"] == "noise")


def test_a_flood_keeps_memory_flat_records_every_byte_and_says_what_it_skipped(tmp_path):
    master, slave, port = pty_pair()
    proc, rec = start_tap(tmp_path, port)
    try:
        flood = Flood(master, FLOOD_BYTES)
        flood.start()
        # the baseline once the tap is at work: what it loads on its first bytes
        # (decoding, pairing, the recorder's first chunk) is no part of the flood,
        # and on a loaded machine it comes later than the listening line
        while flood.written < WARM_BYTES and flood.is_alive():
            time.sleep(0.01)
        start = vm(proc.pid, "VmHWM")
        flood.join()
        time.sleep(1.0)                       # the tap takes what the pty still holds
        held = vm(proc.pid, "VmHWM") - start
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=STOP_BOUND_S) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(master)
        os.close(slave)
    err = (tmp_path / "err.txt").read_text()
    assert "Traceback" not in err
    # the read queue is bounded: the tap never held the flood
    assert held < HELD_LIMIT_MB, f"peak RSS grew by {held:.0f} MB while {FLOOD_BYTES / 1e6:.0f} MB were pushed"
    # every byte reached the recording, in order
    assert recorded(rec) == {"AB": (FLOOD_BYTES, True)}
    # what decoding passed over is said: one warning, a few updates, a total; not one per chunk
    skipped = undecoded_total(err)
    assert skipped.get("AB", 0) > 0, err
    said = [x for x in err.splitlines() if "decod" in x and "doctor" not in x]
    assert len(said) <= 2 + 60 // 10, said
    assert sum("fell behind the line" in x for x in said) == 1
    # decoded events and skipped bytes tile the line, with absolute offsets
    assert_tiles(events_of(tmp_path), "AB", skipped["AB"], FLOOD_BYTES)


def test_sigterm_during_a_flood_on_two_lines_ends_promptly_with_the_recording_whole(tmp_path):
    ma, sa, pa = pty_pair()
    mb, sb, pb = pty_pair()
    proc, rec = start_tap(tmp_path, pa, pb)
    floods = [Flood(ma), Flood(mb)]
    try:
        for f in floods:
            f.start()
        # until the tap is well behind (what the old tap queued without bound)
        while sum(f.written for f in floods) < FLOOD_BYTES:
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)      # still flooding
        assert proc.wait(timeout=STOP_BOUND_S) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        for f in floods:
            f.stop()
        for fd in (ma, sa, mb, sb):
            os.close(fd)
    err = (tmp_path / "err.txt").read_text()
    assert "Traceback" not in err
    lines = recorded(rec)
    assert set(lines) == {"A", "B"} and all(ok for _n, ok in lines.values())
    # what was still queued at the stop went to the recording undecoded, and is counted
    skipped = undecoded_total(err)
    assert "still waiting when the capture stopped" in err or "while decoding was behind" in err, err
    events = events_of(tmp_path)
    for line, (total, _ok) in lines.items():
        assert_tiles(events, line, skipped.get(line, 0), total)


def test_a_hundred_megabytes_of_zeros_would_come_in_4_kib_pieces(tmp_path):
    """A few megabytes stand for the hundred: every piece is 4 KiB, at absolute
    offsets, and the whole run is there."""
    p = tmp_path / "zeros.bin"
    size = 3 * 1024 * 1024 + 1000
    p.write_bytes(bytes(size))
    r = run_cli("decode", p, "--format", "jsonl", timeout=120)
    assert r.returncode == 0, r.stderr
    events = [json.loads(x) for x in r.stdout.splitlines()]
    assert [e["offset"] for e in events] == list(range(0, size, NOISE_PIECE))
    assert {e["kind"] for e in events} == {"noise"}
    assert [len(e["raw"]) // 2 for e in events] == [NOISE_PIECE] * (size // NOISE_PIECE) + [size % NOISE_PIECE]
    assert events[0]["problems"] == [f"noise: {NOISE_PIECE} bytes outside any frame"]
