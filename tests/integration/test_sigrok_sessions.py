"""sigrok session files as older and other writers make them (docs/instruments.md,
"sigrok and PulseView"): version 1 (one ``logic-1`` member), ``key = value`` lines
indented, probes numbered with gaps, 2 bytes a sample, rates in Hz, kHz and MHz,
and damaged files. Sessions are written here with zipfile, as libsigrok lays them
out; the traffic is rendered by tests/waveforms.py."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

import analyzer
from analyzer.errors import CaptureError
from analyzer.sources.sigrok import parse_samplerate
from tests.conftest import frame, run_cli
from tests.waveforms import back_to_back, uart_levels

COMMAND = frame((1, 1, 1), 0, b"P?")
RESULT = frame((0, 1, 1), 1, b"0FA0FC18")


def levels(rate, baud=9600, seconds=0.06):
    a = uart_levels(back_to_back(COMMAND, 0.010, baud), rate, baud, seconds)
    b = uart_levels(back_to_back(b"\x06", 0.020, baud) + back_to_back(RESULT, 0.024, baud), rate, baud, seconds)
    return a, b


def write(path, metadata: str, members: dict[str, bytes], version: str = "2"):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("version", version)
        z.writestr("metadata", metadata)
        for name, data in members.items():
            z.writestr(name, data)


def statuses(path, **kw):
    return [(e.command, e.status) for e in analyzer.open(str(path), **kw) if e.kind == "command"]


@pytest.mark.parametrize("text,rate", [("625 kHz", 625e3), ("1.5 MHz", 1.5e6), ("250 Hz", 250.0),
                                       ("1 MHz", 1e6), ("200000", 2e5), ("1GHz", 1e9)])
def test_sample_rates_as_sigrok_writes_them(text, rate):
    assert parse_samplerate(text) == rate


def test_version_1_indented_key_value_probes_with_gaps_two_bytes_a_sample(tmp_path):
    a, b = levels(1.5e6)
    # line A on probe 3 (bit 2), line B on probe 10 (bit 9): a 16-bit sample
    word = (a.astype(np.uint16) << 2) | (b.astype(np.uint16) << 9) | (1 << 4)   # probe 5 held high
    meta = ("[global]\nsigrok version = 0.2.0\n\n[device 1]\n    driver = fx2lafw\n    capturefile = logic-1\n"
            "    unitsize = 2\n    total probes = 16\n    samplerate = 1.5 MHz\n    probe3 = CTL\n"
            "    probe5 = VCC\n    probe10 = DEV\n")
    path = tmp_path / "old.sr"
    write(path, meta, {"logic-1": word.astype("<u2").tobytes()}, version="1")
    cap = analyzer.open(str(path))
    assert cap.source.channel_of == {"A": 0, "B": 2}     # CTL and DEV; VCC never toggles
    assert [(e.command, e.status) for e in cap if e.kind == "command"] == [("P?", "ok")]
    # by probe number as sigrok-cli counts (from 0), and by name
    assert statuses(path, channels={"A": "2", "B": "DEV"}) == [("P?", "ok")]


def test_version_2_chunks_are_read_in_order(tmp_path):
    a, b = levels(1e6)
    data = (a | (b << 1)).tobytes()
    cut = [0, 7_001, 20_000, 33_333, len(data)]
    chunks = {f"logic-1-{i + 1}": data[cut[i]:cut[i + 1]] for i in range(len(cut) - 1)}
    # written out of order in the zip: the numbers decide
    shuffled = dict(sorted(chunks.items(), key=lambda kv: -int(kv[0].rsplit("-", 1)[1])))
    path = tmp_path / "v2.sr"
    write(path, "[device 1]\ncapturefile=logic-1\nsamplerate=1 MHz\nunitsize=1\nprobe1=A\nprobe2=B\n", shuffled)
    assert statuses(path) == [("P?", "ok")]


def test_a_damaged_chunk_keeps_what_came_before(tmp_path):
    a, b = levels(1e6, seconds=0.12)
    second = levels(1e6)
    data = (np.concatenate((a[:60_000], second[0])) | (np.concatenate((a[:60_000] * 0 + b[:60_000], second[1])) << 1))
    path = tmp_path / "bad.sr"
    write(path, "[device 1]\ncapturefile=logic-1\nsamplerate=1 MHz\nunitsize=1\nprobe1=A\nprobe2=B\n",
          {"logic-1-1": data[:60_000].tobytes(), "logic-1-2": data[60_000:].tobytes()})
    raw = bytearray(path.read_bytes())
    at = raw.index(b"logic-1-2") + len("logic-1-2") + 10     # inside the second chunk's deflate data
    raw[at:at + 8] = b"\xff" * 8
    path.write_bytes(bytes(raw))
    r = run_cli("decode", path, "--format", "jsonl")
    assert r.returncode == 0
    assert r.stdout.count('"kind":"command"') >= 1
    assert "logic-1-2 is damaged" in r.stderr and "read up to there" in r.stderr


def test_not_a_session(tmp_path):
    z = tmp_path / "other.sr"
    with zipfile.ZipFile(z, "w") as f:
        f.writestr("readme.txt", "hello")
    r = run_cli("decode", z)
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert "not a sigrok session" in r.stderr
    path = tmp_path / "nometa.sr"
    write(path, "[global]\nsigrok version=0.5\n", {})
    with pytest.raises(CaptureError, match="names no capture file"):
        analyzer.open(str(path))
