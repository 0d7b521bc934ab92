"""``gimbalscope sigrok command CAPTURE`` (and ``sigrok install --for``): the
sigrok-cli command it prints is run as printed, through a shell, by the real
sigrok-cli (Debian's 0.7.2), with the decoder installed by ``sigrok install
--dir`` (docs/instruments.md, "The sigrok decoder").

Captures: sessions written by sigrok-cli itself from synthesised waveforms
(tests/waveforms.py), whose channels it names ``0`` and ``1``, with a line idling
low (inverted) and another format; VCDs of the same traffic, one as a
simulator writes them (1 ns time unit, scopes); and public captures from the
sigrok project's dumps whose channels are named neither TX nor RX. The expected
annotations are written by hand from the frames put on the wire (Table 1's
frame, §1.4.1.3's checksum, Table 15's positions).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys

import pytest

import analyzer
from tests.conftest import ROOT, run_cli
from tests.waveforms import back_to_back, sigrok_session, uart_levels

pytestmark = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")

DUMPS = os.path.join(ROOT, "tests", "data", "sigrok-dumps")
RATE = 1_000_000

# P? (current position query) to group 1 port 1 device 2 from group 0:
# 1+1+2+0+2+0x50+0x3F = 0x95
QUERY_112 = bytes.fromhex("f8 01 01 02 00 02 50 3f 95")
ACK, NIC = b"\x06", b"?"
# its result, to group 0 (port 1, device 2) from group 1: "0FA0FC18" is az 0x0FA0 = 4000
# (+40.00°), el 0xFC18 = -1000 (-10.00°); 0+1+2+1+8 = 0x0C, the payload's bytes
# 0x30+0x46+0x41+0x30+0x46+0x43+0x31+0x38 = 0x1D9: 0x0C + 0x1D9 = 0x1E5 -> 0xE5
RESULT_112 = bytes.fromhex("f8 00 01 02 01 08") + b"0FA0FC18" + b"\xe5"
# P? to 1.1.3 with a checksum one too high: the sum is 0x96
BAD_113 = bytes.fromhex("f8 01 01 03 00 02 50 3f 97")
# P? to group 1 port 2 device 3: 1+2+3+0+2+0x50+0x3F = 0x97
QUERY_123 = bytes.fromhex("f8 01 02 03 00 02 50 3f 97")
# its result: "1388EC78" is az 0x1388 = 5000 (+50.00°), el 0xEC78 = -5000 (-50.00°);
# 0+2+3+1+8 = 0x0E, 0x31+0x33+0x38+0x38+0x45+0x43+0x37+0x38 = 0x1CB: 0x1D9 -> 0xD9
RESULT_123 = bytes.fromhex("f8 00 02 03 01 08") + b"1388EC78" + b"\xd9"


def char_time(baud: int, bits: int = 10) -> float:
    return bits / baud


def levels(chars, baud: int, duration: float, **kw):
    return uart_levels(chars, RATE, baud, duration, **kw)


def session(tmp_path, channels, name: str = "cap") -> str:
    """A .sr written by sigrok-cli from raw samples: its channels are named "0", "1"."""
    return sigrok_session(tmp_path, *channels, samplerate=RATE, name=name)


@pytest.fixture(scope="module")
def decoders(tmp_path_factory) -> str:
    folder = tmp_path_factory.mktemp("decoders")
    run = subprocess.run([sys.executable, "-m", "analyzer", "sigrok", "install", "--dir", str(folder)],
                         check=False, capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    return str(folder)


def printed(capture: str, decoders: str, *options: str) -> tuple[str, list[str]]:
    """The command ``sigrok command`` prints for ``capture`` (its first line), and
    the comments after it."""
    run = run_cli("sigrok", "command", capture, "--dir", decoders, *options)
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    lines = run.stdout.splitlines()
    assert lines and lines[0].startswith(f"SIGROKDECODE_DIR={shlex.quote(decoders)} sigrok-cli "), lines
    assert all(line.startswith("# ") for line in lines[1:]), lines
    return lines[0], [line[2:] for line in lines[1:]]


def run_printed(command: str, *extra: str) -> list[str]:
    """The annotations of the command as printed, run by a shell (``extra``: more
    of sigrok-cli's output options)."""
    line = command + "".join(" " + shlex.quote(e) for e in extra)
    run = subprocess.run(line, shell=True, check=False, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert run.returncode == 0 and not run.stderr.strip(), run.stderr
    return run.stdout.splitlines()


def measured(notes: list[str], near: int) -> list[str]:
    """The notes with each measured rate checked (within 0.5 % of ``near``) and
    shown as "measured ~": the last digits of a measure are the waveform's."""
    out = []
    for note in notes:
        m = re.search(r"\(measured ([0-9,]+)\)", note)
        if m:
            assert abs(int(m.group(1).replace(",", "")) - near) <= near * 0.005, note
            note = note[:m.start()] + "(measured ~)" + note[m.end():]
        out.append(note)
    return out


def texts(lines: list[str]) -> list[str]:
    return [line.split(": ", 1)[1] for line in lines]


# ------------------------------------------------------------------ synthesised captures

def two_lines(baud: int = 9600, **b_kw):
    """Line A: P? to 1.1.2, then P? to 1.1.3 with a bad checksum; line B: the
    ACK and the result of the first, silent for the second. 0.3 s: the capture
    ends in a silence longer than the frame gap (50 ms), which decides the last
    frame."""
    c = char_time(baud)
    a = back_to_back(QUERY_112, 0.010, baud) + back_to_back(BAD_113, 0.080, baud)
    b = back_to_back(ACK, 0.010 + 9 * c + 0.004, baud) + back_to_back(RESULT_112, 0.010 + 10 * c + 0.006, baud)
    return levels(a, baud, 0.3), levels(b, baud, 0.3, **b_kw)


TWO_LINES_SAID = [
    "command P? 1.1.2 current position query",
    "ack P? 1.1.2",
    "result P? 1.1.2 at az +40.00° el -10.00°",
    "command P? 1.1.3 current position query",
    "bad checksum: expected 0x96, got 0x97",
]


def test_a_session_whose_channels_are_numbers_with_line_b_inverted(tmp_path, decoders):
    """The case the generic command (tx=TX:rx=RX) failed on twice: sigrok-cli names
    the channels 0 and 1, and line B idles low."""
    sr = session(tmp_path, two_lines(inverted=True))
    command, notes = printed(sr, decoders)
    assert f"-i {sr} -P uart:baudrate=9600:tx=0:rx=1:invert_rx=yes,gimbal -A gimbal=frames:problems" in command
    assert measured(notes, 9600) == [
        "tx: line A (the controller's commands), channel 0: 9,600 bit/s (measured ~), 8N1",
        "rx: line B (the devices' answers), channel 1: 9,600 bit/s (measured ~), 8N1, idles low (inverted)"]
    assert texts(run_printed(command)) == TWO_LINES_SAID
    # without the inversion sigrok's uart decoder reads line B as garbage: the option matters
    garbled = texts(run_printed(command.replace(":invert_rx=yes", "")))
    assert "ack P? 1.1.2" not in garbled and any(t.startswith("line error") for t in garbled)


def test_a_single_inverted_line_of_another_format(tmp_path, decoders):
    """One wire carrying both directions at 19200 8E1, idling low: a one-channel
    command with the format and the inversion."""
    baud, bits = 19200, 11
    c = char_time(baud, bits)
    chars = (back_to_back(QUERY_123, 0.010, baud, parity="E")
             + back_to_back(ACK, 0.010 + 9 * c + 0.002, baud, parity="E")
             + back_to_back(RESULT_123, 0.010 + 10 * c + 0.004, baud, parity="E")
             + back_to_back(QUERY_112, 0.040, baud, parity="E")
             + back_to_back(ACK, 0.040 + 9 * c + 0.002, baud, parity="E")
             + back_to_back(RESULT_112, 0.040 + 10 * c + 0.004, baud, parity="E"))
    sr = session(tmp_path, [levels(chars, baud, 0.2, parity="E", inverted=True)])
    command, notes = printed(sr, decoders)
    assert "-P uart:baudrate=19200:parity=even:rx=0:invert_rx=yes,gimbal:lines=single-line " in command
    assert measured(notes, 19200) == [
        "rx: one line carrying both directions, channel 0: 19,200 bit/s (measured ~), 8E1, idles low (inverted)"]
    assert texts(run_printed(command)) == [
        "command P? 1.2.3 current position query",
        "ack P? 1.2.3",
        "result P? 1.2.3 at az +50.00° el -50.00°",
        "command P? 1.1.2 current position query",
        "ack P? 1.1.2",
        "result P? 1.1.2 at az +40.00° el -10.00°",
    ]


def test_install_for_a_capture_installs_and_prints_its_command(tmp_path):
    sr = session(tmp_path, two_lines(inverted=True))
    folder = tmp_path / "decoders"
    run = run_cli("sigrok", "install", "--dir", folder, "--for", sr)
    assert run.returncode == 0, run.stderr
    assert sorted(os.listdir(folder / "gimbal")) == ["__init__.py", "pd.py"]
    assert run.stderr.strip().splitlines() == [
        f"gimbalscope: wrote the sigrok decoder gimbal into {folder / 'gimbal'}; the command for {sr}:"]
    command = run.stdout.splitlines()[0]
    assert command.startswith(f"SIGROKDECODE_DIR={folder} sigrok-cli -i {sr} ")
    assert texts(run_printed(command)) == TWO_LINES_SAID


def test_a_capture_that_cannot_be_read_installs_nothing(tmp_path):
    folder = tmp_path / "decoders"
    run = run_cli("sigrok", "install", "--dir", folder, "--for", tmp_path / "none.sr")
    assert run.returncode == 2
    assert run.stderr.strip().splitlines() == [f"gimbalscope: error: {tmp_path / 'none.sr'}: no such file"]
    assert not folder.exists()


def test_channels_and_rate_given(tmp_path, decoders):
    """--channels chooses the lines (here the other way round: the decoder is then
    told line A is on channel 1) and --baud the rate."""
    a, b = two_lines()
    sr = session(tmp_path, [b, a])
    command, notes = printed(sr, decoders, "--channels", "A=1,B=0", "--baud", "9600")
    assert "-P uart:baudrate=9600:tx=1:rx=0,gimbal " in command
    assert notes[0] == "tx: line A (the controller's commands), channel 1: 9,600 bit/s (given), 8N1"
    assert texts(run_printed(command)) == TWO_LINES_SAID


# ------------------------------------------------------------------ VCD

def vcd_text(a, b, unit_ns: int) -> str:
    """The two lines as a simulator writes them: a time unit of ``unit_ns`` ns,
    the wires in nested scopes, a wider variable among them."""
    out = ["$timescale 1 ns $end" if unit_ns == 1 else f"$timescale {unit_ns} ns $end",
           "$scope module top $end", "$scope module uart $end",
           "$var wire 1 ! txd $end", "$var wire 8 # data [7:0] $end", "$var wire 1 \" rxd $end",
           "$upscope $end", "$upscope $end", "$enddefinitions $end"]
    changes: dict[int, list[str]] = {}
    for ident, lv in (("!", a), ('"', b)):
        changes.setdefault(0, []).append(f"{int(lv[0])}{ident}")
        for i in (lv[1:] != lv[:-1]).nonzero()[0] + 1:
            changes.setdefault(int(i), []).append(f"{int(lv[i])}{ident}")
    scale = 1000 // unit_ns     # a sample is 1 us
    for i in sorted(changes):
        out.append(f"#{i * scale}")
        out += changes[i]
    out.append(f"#{len(a) * scale}")
    return "\n".join(out) + "\n"


def test_a_simulators_vcd(tmp_path, decoders):
    """A nanosecond time unit: sigrok's VCD input would make a billion samples a
    second of it; the command asks it to downsample to a rate the lines need."""
    a, b = two_lines()
    vcd = tmp_path / "sim.vcd"
    vcd.write_text(vcd_text(a, b, 1))
    command, notes = printed(str(vcd), decoders)
    assert f"sigrok-cli -I vcd:downsample=1000 -i {vcd} -P uart:baudrate=9600:tx=txd:rx=rxd,gimbal " in command
    assert notes[0] == "the VCD's time unit is 1 ns: downsample=1000 has sigrok-cli read it as 1 MHz samples"
    assert texts(run_printed(command)) == TWO_LINES_SAID


def test_a_vcd_sigrok_wrote(tmp_path, decoders):
    sr = session(tmp_path, two_lines(inverted=True))
    vcd = tmp_path / "cap.vcd"
    subprocess.run(["sigrok-cli", "-i", sr, "-O", "vcd", "-o", str(vcd)], check=True, capture_output=True,
                   timeout=120)
    command, _ = printed(str(vcd), decoders)
    assert f"sigrok-cli -I vcd -i {vcd} -P uart:baudrate=9600:tx=0:rx=1:invert_rx=yes,gimbal " in command
    assert texts(run_printed(command)) == TWO_LINES_SAID


def test_a_vcd_channel_sigrok_cannot_name(tmp_path):
    """sigrok's VCD input names a channel without its scope: two wires named alike
    in two scopes cannot be told apart, and that is said rather than guessed."""
    a, b = two_lines()
    text = vcd_text(a, b, 1).replace("$var wire 1 \" rxd $end", "$upscope $end $scope module other $end "
                                     "$var wire 1 \" txd $end")
    vcd = tmp_path / "two.vcd"
    vcd.write_text(text)
    run = run_cli("sigrok", "command", vcd)
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.splitlines() == [
        (f"gimbalscope: error: {vcd}: sigrok-cli names a VCD's channels without their scope, and two of them "
         "are txd: it cannot be told which is txd")]


# ------------------------------------------------------------------ what sigrok-cli cannot read

def test_what_sigrok_cli_cannot_read_is_said_in_one_line(tmp_path):
    csv = tmp_path / "digital.csv"
    csv.write_text("Time [s],Channel 0,Channel 1\n0.000000,1,1\n0.010000,0,1\n0.010104,1,1\n")
    raw = tmp_path / "ctl.bin"
    raw.write_bytes(QUERY_112)
    a, b = two_lines()
    sr = session(tmp_path, [a, b])
    packed = tmp_path / "cap.sr.gz"
    subprocess.run(["gzip", "-k", sr], check=True)
    os.replace(sr + ".gz", packed)
    for path, said in [(csv, ("sigrok-cli reads sessions (.sr) and VCD, not this capture (its CSV input takes a "
                              "row as a sample, where a Saleae export's rows are transitions); export it from "
                              "Saleae Logic 2 as VCD")),
                       (raw, "is no logic analyser's capture"),
                       (packed, "sigrok-cli cannot read a gzip-compressed capture; decompress it first")]:
        run = run_cli("sigrok", "command", path)
        assert run.returncode == 2 and run.stdout == "", run.stderr
        lines = run.stderr.splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"gimbalscope: error: {path}: ") and said in lines[0], lines


# ------------------------------------------------------------------ the generic command

def test_install_says_how_to_fit_the_command(tmp_path):
    run = run_cli("sigrok", "install", "--dir", tmp_path / "d")
    assert run.returncode == 0, run.stderr
    said = run.stderr.splitlines()
    assert len(said) == 1
    assert (f"use it with: SIGROKDECODE_DIR={tmp_path / 'd'} sigrok-cli -i CAPTURE.sr "
            "-P uart:baudrate=9600:tx=D0:rx=D1,gimbal -A gimbal=frames:problems") in said[0]
    hints = run.stdout
    assert "sigrok-cli -i CAPTURE.sr --show lists them" in hints
    assert ":invert_tx=yes (line A) or :invert_rx=yes (line B)" in hints and "idles low" in hints
    assert "gimbalscope sigrok command CAPTURE" in hints
    assert all(line.startswith("# ") for line in run.stdout.splitlines())


def test_the_generic_command_fits_a_typical_capture(tmp_path, decoders):
    """fx2lafw names its channels D0…D7 (a capture made as docs/instruments.md
    shows, without renaming them): the generic command reads it as it is."""
    sr = session(tmp_path, two_lines())
    renamed = tmp_path / "fx2.sr"
    subprocess.run(["sigrok-cli", "-i", sr, "-C", "0=D0,1=D1", "-o", str(renamed)], check=True,
                   capture_output=True, timeout=120)
    install = run_cli("sigrok", "install", "--dir", tmp_path / "d")
    command = install.stderr.split("use it with: ", 1)[1].split(" (or in PulseView", 1)[0]
    assert texts(run_printed(command.replace("CAPTURE.sr", str(renamed)))) == TWO_LINES_SAID
    mine, _ = printed(str(renamed), decoders)
    assert "-P uart:baudrate=9600:tx=D0:rx=D1,gimbal " in mine


# ------------------------------------------------------------------ public captures

def noise_text(data: bytes) -> str:
    """The frames row's text for bytes outside any frame (12 shown)."""
    shown = " ".join(f"{b:02x}" for b in data[:12]) + (" ..." if len(data) > 12 else "")
    return f"noise {len(data)} byte{'s' if len(data) != 1 else ''}: {shown}"


def test_a_public_capture_whose_channels_are_pins(decoders):
    """bootup.sr: an Amulet LCD's serial lines at a video mixer's boot, channels
    named "Pin 1" and "Pin 3" (a space in each). gimbalscope reads Pin 3, the one
    toggling, as one line at 115200; the printed command has sigrok read the same
    bytes: past the boot's first glitches (which each UART reads its own way),
    every run of bytes sigrok's decoder shows is one gimbalscope shows, byte for
    byte. None is a gimbal frame: it is another protocol."""
    path = os.path.join(DUMPS, "bootup.sr")
    command, notes = printed(path, decoders)
    assert "-P 'uart:baudrate=115200:rx=Pin 3,gimbal:lines=single-line' " in command
    assert measured(notes, 115_636) == [
        "rx: one line carrying both directions, channel Pin 3: 115,200 bit/s (measured ~), 8N2"]
    lines = run_printed(command, "--protocol-decoder-samplenum")
    ours = [(round(ev.t * 10e6), noise_text(ev.raw)) for ev in analyzer.open(path) if ev.raw]
    assert len(ours) == 12
    settled = ours[1][0] - 1000       # the samples (10 MHz) before the second run of bytes
    theirs = [(int(line.split("-", 1)[0]), text) for line, text in zip(lines, texts(lines))]
    assert all(ss < settled for ss, text in theirs[:-len(ours[1:]) * 2])
    frames = [text for _, text in theirs if not text.startswith(("noise:", "line error"))]
    assert frames[-11:] == [text for _, text in ours[1:]]
    assert frames[-11:][:2] == ["noise 8 bytes: d6 46 46 35 41 35 41 00",
                                "noise 80 bytes: d6 46 46 35 41 35 41 00 d6 46 46 35 ..."]


def test_a_public_capture_with_an_rs232_line(decoders):
    """max3232e_hello_world_57600_8n1.sr: "Hello world\\r\\n" on both sides of an
    RS-232 transceiver, DOUT1 at RS-232 polarity (idle low), DIN1 at logic
    polarity; channels named "MAX3232E DOUT1" and "MAX3232E DIN1". The capture
    ends as the text does, with no silence to close the run of bytes, so the
    decoder shows nothing of it; read at the wrong polarity, it shows the
    receiver's framing errors."""
    path = os.path.join(DUMPS, "max3232e_hello_world_57600_8n1.sr")
    command, notes = printed(path, decoders)
    assert "-P 'uart:baudrate=57600:tx=MAX3232E DOUT1:invert_tx=yes:rx=MAX3232E DIN1,gimbal' " in command
    assert notes[0].endswith("8N1, idles low (inverted)")
    assert run_printed(command) == []
    assert "line error: framing error" in texts(run_printed(command.replace(":invert_tx=yes", "")))
    # the uart decoder under it, told as the command tells it, reads the text on both lines
    for side in ("tx", "rx"):
        run = subprocess.run(command.replace("-A gimbal=frames:problems", f"-B uart={side}"), shell=True,
                             check=False, capture_output=True, timeout=120, cwd=ROOT)
        assert run.stdout == b"Hello world\r\n" * 5, (side, run.stdout)
