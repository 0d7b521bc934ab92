"""What a new user meets in the first hour with logic and USB captures
(docs/instruments.md): a saved stream of samples decodes with every command, a
sample rate typed a unit off is named, an option that does not apply to the
input says so, a rate measured from a few edges is said to be a guess, and the
help lists every input kind the readers' registry knows."""

from __future__ import annotations

import gzip
import json
import os

import pytest

from analyzer.physical.bitrate import power_of_ten_off
from analyzer.sources import registry
from tests.conftest import ROOT, SOCAT_LOG, frame, run_cli
from tests.waveforms import back_to_back, pack, uart_levels

RATE = 1_000_000
COMMAND = frame((1, 1, 1), 0, b"P?")
RESULT = frame((0, 1, 1), 1, b"0FA0FC18")   # azimuth 0x0FA0 = 4000, elevation 0xFC18 = -1000: hundredths of a degree
DUMPS = os.path.join(ROOT, "tests", "data", "sigrok-dumps")


def exchanges(unitsize: int = 1) -> bytes:
    """Four exchanges 60 ms apart at 9600 8N1, sampled at 1 MHz: line A (bit 0)
    the command at 10 ms, line B (bit 1) the ACK at 20 ms and the result at 24 ms."""
    a = uart_levels(back_to_back(COMMAND, 0.010, 9600), RATE, 9600, 0.060)
    b = uart_levels(back_to_back(b"\x06", 0.020, 9600) + back_to_back(RESULT, 0.024, 9600), RATE, 9600, 0.060)
    one = pack(a, b)
    if unitsize > 1:   # the same channels in wider samples: the high bytes stay 0
        one = b"".join(bytes([s]) + bytes(unitsize - 1) for s in one)
    return one * 4


def jsonl(r) -> list[dict]:
    assert r.returncode == 0, r.stderr
    return [json.loads(line) for line in r.stdout.splitlines()]


def check_exchanges(events: list[dict]) -> None:
    commands = [e for e in events if e["kind"] == "command"]
    assert [(c["command"], c["device"], c["status"]) for c in commands] == [("P?", "1.1.1", "ok")] * 4
    t0 = commands[0]["t"]
    assert [c["t"] - t0 for c in commands] == pytest.approx([0.0, 0.060, 0.120, 0.180], abs=2e-6)
    results = [e for e in events if e["kind"] == "result"]
    assert [r["fields"] for r in results] == [{"azimuth_deg": 40.0, "elevation_deg": -10.0}] * 4
    acks = [e for e in events if e["kind"] == "ack"]
    # the ACK's start bit at 20 ms, 10 ms after the command's (9 characters of 1.04 ms end at 19.4 ms)
    assert [a["latency"] for a in acks] == pytest.approx([0.020 - (0.010 + 9 * 10 / 9600)] * 4, abs=5e-6)


# ------------------------------------------------------------------ a saved stream of samples

@pytest.mark.parametrize("unitsize", [1, 2])
def test_a_saved_stream_of_samples_decodes_as_live_samples_reads_it(tmp_path, unitsize):
    path = tmp_path / "samples.bin"
    path.write_bytes(exchanges(unitsize))
    size = ("--unitsize", str(unitsize)) if unitsize > 1 else ()
    decoded = run_cli("decode", path, "--samplerate", "1MHz", *size, "--format", "jsonl")
    check_exchanges(jsonl(decoded))
    assert decoded.stderr == ""
    live = run_cli("live", "--samples", path, "--samplerate", "1MHz", *size, "--no-tui", "--format", "jsonl")
    assert [e["raw"] for e in jsonl(live)] == [e["raw"] for e in jsonl(decoded)]


def test_stats_doctor_convert_and_a_compressed_stream_read_samples_too(tmp_path):
    path = tmp_path / "samples.bin"
    path.write_bytes(exchanges())
    packed = tmp_path / "samples.bin.gz"
    packed.write_bytes(gzip.compress(exchanges()))
    check_exchanges(jsonl(run_cli("decode", packed, "--samplerate", "1MHz", "--format", "jsonl")))
    stats = run_cli("stats", path, "--samplerate", "1MHz")
    assert stats.returncode == 0 and "4 commands" in stats.stdout and "ok 4" in stats.stdout
    doctor = run_cli("doctor", path, "--samplerate", "1MHz", "--format", "json")
    assert doctor.returncode == 0, doctor.stderr
    assert json.loads(doctor.stdout)["findings"] == [] or all(
        f["severity"] == "info" for f in json.loads(doctor.stdout)["findings"])
    out = tmp_path / "samples.mcap"
    conv = run_cli("convert", path, "--samplerate", "1MHz", "-o", out)
    assert conv.returncode == 0, conv.stderr
    check_exchanges(jsonl(run_cli("decode", out, "--format", "jsonl")))


def test_without_a_sample_rate_the_stream_is_a_raw_dump_as_before(tmp_path):
    path = tmp_path / "samples.bin"
    path.write_bytes(exchanges())
    events = jsonl(run_cli("decode", path, "--format", "jsonl"))
    assert not [e for e in events if e["kind"] == "command"]


# ------------------------------------------------------------------ a sample rate typed wrong

def test_a_rate_a_power_of_ten_off_a_standard_one_is_found():
    # by hand: 96 bit/s is 13 % from 110 and 50 % from 150 (no standard rate); 96 × 100 = 9,600
    assert power_of_ten_off(96.0) == 100
    assert power_of_ten_off(960.0) == 10           # 20 % from 1,200, 60 % from 600; × 10 = 9,600
    assert power_of_ten_off(11_520.0) == 10        # 115,200 read at a tenth (20 % from 9,600 and 14,400)
    assert power_of_ten_off(1_152_000.0) == pytest.approx(0.1)   # 15 % from 1 M, 42 % from 2 M
    assert power_of_ten_off(9_600.0) is None       # standard
    assert power_of_ten_off(106_000.0) is None     # MIFARE's own rate: × 10 is 6 % from 1 M, too far
    assert power_of_ten_off(77_777.0) is None      # 35 % from 57,600: and no power of ten lands near one


def test_a_sample_rate_a_hundred_times_low_is_named_once(tmp_path):
    path = tmp_path / "samples.bin"
    path.write_bytes(exchanges())
    r = run_cli("decode", path, "--samplerate", "10kHz", "--format", "jsonl")
    assert r.returncode == 0, r.stderr
    said = [line for line in r.stderr.splitlines() if "did you mean" in line]
    # 9,600 bit/s read at a hundredth of the sample rate: 96 bit/s
    assert len(said) == 1, r.stderr
    assert "line A (D0) measures 96 bit/s, near no standard rate" in said[0]
    assert said[0].endswith("at --samplerate 1MHz it would be 9,600 bit/s: did you mean --samplerate 1MHz?")
    right = run_cli("decode", path, "--samplerate", "1MHz", "--format", "jsonl")
    assert "did you mean" not in right.stderr


def test_a_sample_rate_a_million_times_low_is_named_not_refused(tmp_path):
    # 1 Hz for 1 MHz: a bit is still 104 samples (not "under 4 samples a bit", which
    # the rate's name, 1 bit/s, once made it), and 9,600 bit/s reads as 0.0096
    path = tmp_path / "samples.bin"
    path.write_bytes(exchanges())
    r = run_cli("decode", path, "--samplerate", "1Hz", "--format", "jsonl")
    assert r.returncode == 0, r.stderr
    assert "samples a bit" not in r.stderr
    said = [line for line in r.stderr.splitlines() if "did you mean" in line]
    assert len(said) == 1 and "measures 0.0096 bit/s" in said[0], r.stderr
    assert said[0].endswith("at --samplerate 1MHz it would be 9,600 bit/s: did you mean --samplerate 1MHz?")


# ------------------------------------------------------------------ options that do not apply

def test_options_that_do_not_apply_to_the_input_are_named(tmp_path):
    sr = os.path.join(DUMPS, "hello_world_8n1_9600.sr")
    r = run_cli("decode", sr, "--usb-device", "1.2", "--adapter", "ftdi")
    assert r.returncode == 0, r.stderr
    warned = [line for line in r.stderr.splitlines() if "ignored" in line]
    assert len(warned) == 2
    assert any(w.endswith("--usb-device ignored: read as sigrok session, which takes no --usb-device (it is for "
                          "USB capture (usbmon, USBPcap))") for w in warned)
    assert any(w.endswith("--adapter ignored: read as sigrok session, which takes no --adapter (it is for USB "
                          "capture (usbmon, USBPcap))") for w in warned)
    socat = run_cli("decode", SOCAT_LOG, "--channels", "A=TX,B=RX")
    assert socat.returncode == 0
    assert [line for line in socat.stderr.splitlines() if "ignored" in line] == [
        (f"gimbalscope: warning: {SOCAT_LOG}: --channels ignored: read "
         "as socat -x -v log, which takes no --channels (it is for sigrok session, VCD, Saleae CSV export, Saleae "
         "binary export or logic sample stream)")]
    # given where they apply: no word
    quiet = run_cli("decode", sr, "--channels", "A=0")
    assert "ignored" not in quiet.stderr


def test_channels_on_a_usb_capture_are_named(tmp_path):
    from tests.usb_captures import FT232R, FTDI_IDLE, UsbCapture, ftdi_packets
    c = UsbCapture(bus=1)
    c.enumerate(0.1, 7, **FT232R)
    c.bulk_out(1.000, 7, 2, COMMAND)
    c.bulk_in(1.015, 7, 1, ftdi_packets(b"\x06", FTDI_IDLE))
    path = tmp_path / "usb.pcap"
    c.write_pcap(path)
    r = run_cli("decode", path, "--channels", "A=1")
    assert r.returncode == 0, r.stderr
    assert "--channels ignored: read as USB capture (usbmon, USBPcap), which takes no --channels" in r.stderr


# ------------------------------------------------------------------ how sure a rate is

def test_one_character_decodes_at_the_rate_found_and_says_it_is_a_guess():
    # sigrok-dumps uart/errors: one 0x0a at 115200 8N1, sampled at 2 MHz, with a
    # glitch. 0x0a is start 0, data 0 1 0 1 0 0 0 0 (LSB first), stop 1: six edges,
    # five intervals, the glitch's two edges dropped
    r = run_cli("decode", os.path.join(DUMPS, "glitch_0x0a.sr"), "--format", "jsonl")
    assert r.returncode == 0, r.stderr
    assert [e["raw"] for e in jsonl(r)] == ["0a"]
    assert "samples a bit" not in r.stderr                # no advice to buy a faster analyser
    lines = r.stderr.splitlines()
    assert len(lines) == 1
    assert "line AB (RX) read as 115,200 bit/s 8N1; the rate is a guess from only 5 intervals between edges" in \
        lines[0]
    assert "--baud" in lines[0]


def test_a_line_measured_from_many_characters_says_nothing_of_its_rate():
    r = run_cli("decode", os.path.join(DUMPS, "hello_world_8n1_9600.sr"))
    assert r.returncode == 0 and "guess" not in r.stderr


# ------------------------------------------------------------------ help

@pytest.mark.parametrize("command", ["decode", "stats", "view", "convert", "doctor", "export", "replay"])
def test_every_command_that_reads_captures_lists_every_input_kind(command):
    r = run_cli(command, "--help")
    assert r.returncode == 0
    text = " ".join(r.stdout.split())   # argparse wraps lines
    if command == "replay":   # replays recordings only
        assert "MCAP" in text
        return
    for name in registry.formats():
        assert name in text, name


def test_the_main_help_points_at_the_instruments_page():
    r = run_cli("--help")
    text = " ".join(r.stdout.split())
    assert os.path.join(ROOT, "docs", "instruments.md") in text
    assert "sigrok session" in text and "USB capture" in text
