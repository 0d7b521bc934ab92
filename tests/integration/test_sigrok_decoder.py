"""The sigrok decoder gimbal in the real sigrok-cli (Debian's 0.7.2): a waveform of
known traffic is synthesised (tests/waveforms.py), sigrok-cli's binary input
turns it into a .sr session, and ``gimbalscope sigrok install --dir`` puts the
decoder where SIGROKDECODE_DIR points. The expected annotations are written by
hand from the protocol (Table 1's frame, §1.4.1.3's checksum, Table 15's
positions)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from tests.waveforms import back_to_back, sigrok_session, uart_levels

pytestmark = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")

RATE, BAUD = 1_000_000, 9600
CHAR = 10 / BAUD   # seconds a character takes, 8N1

# F8, group 1 port 1 device 2, source group 0, length 2, "P?", checksum 1+1+2+0+2+0x50+0x3F = 0x95
POSITION_QUERY = bytes.fromhex("f801010200025" "03f95")
# the answer: to group 0 from group 1, "0FA0FC18" = az 0x0FA0 = 4000 → +40.00°, el 0xFC18 = -1000 → -10.00°
POSITION = bytes.fromhex("f800010201 08") + b"0FA0FC18" + bytes([(0 + 1 + 2 + 1 + 8 + sum(b"0FA0FC18")) & 0xFF])
# P? to device 1.1.3: the sum is 0x96, the wire carries 0x97
BAD_CHECKSUM = bytes.fromhex("f801010300025" "03f97")
# "QQ" is no command of rev 1.9: 1+1+2+0+2+0x51+0x51 = 0xa8
UNKNOWN = bytes.fromhex("f80101020002" "5151a8")
ACK, NIC = b"\x06", b"?"

# (seconds, line, bytes): the controller on line A, the gimbals' answers on line B
TRAFFIC = [
    (0.010, "A", POSITION_QUERY),
    (0.010 + 9 * CHAR + 0.004, "B", ACK),
    (0.010 + 10 * CHAR + 0.006, "B", POSITION),
    (0.080, "A", BAD_CHECKSUM),
    (0.150, "A", UNKNOWN),
    (0.150 + 9 * CHAR + 0.004, "B", ACK + NIC),
]
DURATION = 0.3   # ends in a silence longer than the frame gap (50 ms)

FRAMES = [
    "command P? 1.1.2 current position query",
    "ack P? 1.1.2",
    "result P? 1.1.2 at az +40.00° el -10.00°",
    "command P? 1.1.3 current position query",
    "command QQ 1.1.2 'QQ'",
    "ack QQ 1.1.2",
    "nic QQ 1.1.2",
]
PROBLEMS = [
    "bad checksum: expected 0x96, got 0x97",
    "unknown command: 'QQ' is not in protocol rev 1.9",
]


def _levels(line: str) -> object:
    chars = [c for t, ln, data in TRAFFIC if ln == line for c in back_to_back(data, t, BAUD)]
    return uart_levels(chars, RATE, BAUD, DURATION)


def _session(tmp_path, channels) -> str:
    return sigrok_session(tmp_path, *channels, samplerate=RATE)


@pytest.fixture
def decoders(tmp_path) -> str:
    folder = tmp_path / "decoders"
    run = subprocess.run([sys.executable, "-m", "analyzer", "sigrok", "install", "--dir", str(folder)],
                         capture_output=True, text=True, timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    assert sorted(os.listdir(folder / "gimbal")) == ["__init__.py", "pd.py"]
    said = run.stderr.strip().splitlines()
    assert len(said) == 1 and f"SIGROKDECODE_DIR={folder} sigrok-cli" in said[0], said
    return str(folder)


def _annotations(decoders: str, sr: str, stack: str, rows: str) -> list[str]:
    run = subprocess.run(["sigrok-cli", "-i", sr, "-P", stack, "-A", f"gimbal={rows}", "--protocol-decoder-samplenum"],
                         capture_output=True, text=True, timeout=300,
                         env={**os.environ, "SIGROKDECODE_DIR": decoders}, check=False)
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr
    return run.stdout.splitlines()


def _texts(lines: list[str]) -> list[str]:
    return [line.split(": ", 1)[1] for line in lines]


def test_two_lines(tmp_path, decoders):
    sr = _session(tmp_path, [_levels("A"), _levels("B")])   # line A on channel 0, B on channel 1
    stack = f"uart:baudrate={BAUD}:tx=0:rx=1,gimbal"
    frames = _annotations(decoders, sr, stack, "frames")
    assert _texts(frames) == FRAMES
    # the command's annotation spans its 9 characters: the first start bit's edge to the last stop bit
    span = frames[0].split(" ", 1)[0]
    ss, es = map(int, span.split("-"))
    assert ss == round(0.010 * RATE)
    assert abs(es - (0.010 + 9 * CHAR) * RATE) < RATE / BAUD   # within a bit
    assert _texts(_annotations(decoders, sr, stack, "problems")) == PROBLEMS
    fields = _texts(_annotations(decoders, sr, stack, "fields"))
    assert fields[:4] == ["dst=1.1.2", "src=0", "length=2", "checksum=0x95"]
    assert "azimuth_deg=40.0 deg" in fields and "elevation_deg=-10.0 deg" in fields


def test_lines_the_other_way_round(tmp_path, decoders):
    """Line A on the UART's RX side: the option says so."""
    sr = _session(tmp_path, [_levels("A"), _levels("B")])
    stack = f"uart:baudrate={BAUD}:rx=0:tx=1,gimbal:lines=rx-a-tx-b"
    assert _texts(_annotations(decoders, sr, stack, "frames")) == FRAMES


def test_single_line(tmp_path, decoders):
    """Both directions on one wire (a half-duplex pair): commands are told from results."""
    chars = [c for t, _, data in TRAFFIC for c in back_to_back(data, t, BAUD)]
    sr = _session(tmp_path, [uart_levels(chars, RATE, BAUD, DURATION)])
    stack = f"uart:baudrate={BAUD}:rx=0,gimbal:lines=single-line"
    assert _texts(_annotations(decoders, sr, stack, "frames")) == FRAMES
    assert _texts(_annotations(decoders, sr, stack, "problems")) == PROBLEMS


def test_install_into_an_unwritable_folder(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    for target in (blocker, blocker / "sub"):
        run = subprocess.run([sys.executable, "-m", "analyzer", "sigrok", "install", "--dir", str(target)],
                             capture_output=True, text=True, timeout=120, check=False)
        assert run.returncode == 2
        assert len(run.stderr.strip().splitlines()) == 1 and run.stderr.startswith("gimbalscope: error: ")


def test_the_silence_after_the_last_frame_decides_it(tmp_path, decoders):
    """A bad checksum is only reported once the byte after the frame, or a silence,
    shows the length byte held: the uart decoder's idle reports are that silence."""
    chars = back_to_back(BAD_CHECKSUM, 0.010, BAUD)
    sr = _session(tmp_path, [uart_levels(chars, RATE, BAUD, 0.010 + 9 * CHAR + 0.060)])   # 60 ms > the 50 ms gap
    stack = f"uart:baudrate={BAUD}:tx=0,gimbal"
    assert _texts(_annotations(decoders, sr, stack, "frames")) == ["command P? 1.1.3 current position query"]
    assert _texts(_annotations(decoders, sr, stack, "problems")) == [PROBLEMS[0]]
