"""USB captures of the controller PC's own USB-serial adapter, read as gimbal
traffic (docs/instruments.md, "USB captures"): synthesised usbmon and USBPcap captures
(tests/usb_captures.py) of an FTDI FT232R and FT2232H, a CP210x and a CH340
carrying real frames, decoded by the command line; what is expected is worked
out here from the protocol and the times the captures were written with.
tshark's ftdi-ft dissector must read the same bytes from the FTDI captures."""

import json
import shutil
import subprocess

import pytest

import analyzer
from analyzer.sources.base import ReadSettings
from analyzer.sources.files import Input
from analyzer.sources.registry import source_for
from tests.conftest import frame, run_cli
from tests.usb_captures import (
    BT,
    CH340,
    CP2102,
    FT232R,
    FT2232H,
    FTDI_HS_IDLE,
    FTDI_IDLE,
    MOUSE,
    STICK,
    UsbCapture,
    ftdi_packets,
)

CTL, DEV = 0, 1
ACK = b"\x06"
LINE_ERROR = "line error: framing error reported by the USB adapter"


def cmd(payload, device=2):
    return frame((DEV, 1, device), CTL, payload)


def result(payload, device=2):
    return frame((CTL, 1, device), DEV, payload)   # groups swapped (Table 3)


# P? answered: azimuth +12.34° (0x04D2 hundredths), elevation -5.00° (0xFE0C)
QUERY, ANSWER = cmd("P?"), result("04D2FE0C")


def decode(path, *flags):
    out = run_cli("decode", path, "--format", "jsonl", *flags)
    assert out.returncode == 0, out.stderr
    return [json.loads(line) for line in out.stdout.splitlines()], out.stderr


def ftdi_conversation(c, device=7, out_ep=2, in_ep=1, idle=FTDI_IDLE, answer_status=FTDI_IDLE, polls=True):
    """P? at 1.000 s; the ACK handed over at 1.015 s, the result at 1.040 s; idle
    polls (status bytes alone) every 16 ms around them."""
    if polls:
        for k in range(40):
            c.bulk_in(0.30 + k * 0.016, device, in_ep, idle)
            c.bulk_in(1.06 + k * 0.016, device, in_ep, idle)
    c.bulk_out(1.000, device, out_ep, QUERY)
    c.bulk_in(1.015, device, in_ep, ftdi_packets(ACK, idle))
    c.bulk_in(1.040, device, in_ep, ftdi_packets(ANSWER, answer_status))


def check_conversation(events, origin):
    """The command, its ACK and its result, paired, at the times the capture says."""
    assert [(e["line"], e["kind"], e["command"], e["device"]) for e in events] == [
        ("A", "command", "P?", "1.1.2"), ("B", "ack", None, "1.1.2"), ("B", "result", "P?", "1.1.2")]
    command, ack, answer = events
    assert command["status"] == "ok" and ack["request"] == answer["request"] == command["number"]
    assert command["t"] == pytest.approx(1.000 - origin, abs=1e-9)                    # on the wire at the submission
    assert ack["t"] == pytest.approx(1.015 - BT - origin, abs=1e-9)                   # back-dated by its one byte
    assert answer["t"] == pytest.approx(1.040 - len(ANSWER) * BT - origin, abs=1e-9)
    assert ack["latency"] == pytest.approx(0.015 - 10 * BT, abs=1e-9)     # after the command's 9 bytes
    assert answer["latency"] == pytest.approx(0.040 - 15 * BT - 9 * BT, abs=1e-9)
    assert answer["raw"] == ANSWER.hex() and answer["checksum_ok"]
    assert answer["fields"] == {"azimuth_deg": 12.34, "elevation_deg": -5.0}
    assert all(e["problems"] == [] for e in events)


WRITERS = {
    "usbmon mmapped pcap": lambda c, p: c.write_pcap(p, 220),
    "usbmon pcap, big endian, ns": lambda c, p: c.write_pcap(p, 189, ">", nanos=True),
    "usbmon pcapng": lambda c, p: c.write_pcapng(p, 220),
    "USBPcap": lambda c, p: c.write_pcap(p, 249),
}


@pytest.mark.parametrize("form", WRITERS)
def test_an_ft232r_conversation_in_every_container(tmp_path, form):
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    ftdi_conversation(c)
    path = tmp_path / "ftdi.cap"
    WRITERS[form](c, path)
    events, warnings = decode(path)
    check_conversation(events, origin=0.100)   # t = 0: the capture's first packet
    assert warnings == ""


def test_an_ftdi_adapter_without_its_enumeration_is_known_by_its_traffic(tmp_path):
    c = UsbCapture(bus=3)
    ftdi_conversation(c)
    path = tmp_path / "late.pcap"
    c.write_pcap(path)
    events, warnings = decode(path)
    check_conversation(events, origin=0.299)   # the first IN URB's submission
    lines = warnings.splitlines()
    assert len(lines) == 1
    assert "USB device 3.7: no enumeration in the capture; taken as an FTDI adapter from its traffic" in lines[0]
    assert "80 idle polls" in lines[0] and "--adapter" in lines[0]
    # said by the user: nothing to guess
    events, warnings = decode(path, "--adapter", "ftdi")
    check_conversation(events, origin=0.299)
    assert warnings == ""


def test_a_framing_error_in_the_line_status_is_on_the_event_of_its_byte(tmp_path):
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    ftdi_conversation(c, answer_status=b"\x01\x68")   # FE (0x08) with the result's packet
    path = tmp_path / "fe.pcap"
    c.write_pcap(path)
    events, _ = decode(path)
    command, ack, answer = events
    assert answer["kind"] == "result" and answer["problems"] == [LINE_ERROR]
    assert command["problems"] == ack["problems"] == []
    assert ack["request"] == answer["request"] == command["number"]


def test_answers_batched_in_packets_of_64_lose_their_status_bytes(tmp_path):
    """Five queries written at once (a controller that does not wait: pairing
    says so, which is not what is tested here); the chip hands the answers over
    together, 80 bytes in two packets of 64 (62 line bytes each, then 18)."""
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    queries = [cmd("P?", device=d) for d in (1, 2, 3, 4, 5)]
    answers = b"".join(ACK + result("04D2FE0C", device=d) for d in (1, 2, 3, 4, 5))
    assert len(answers) == 80
    c.bulk_out(1.000, 7, 2, b"".join(queries))
    transfer = ftdi_packets(answers)
    assert len(transfer) == 84 and transfer[64:66] == FTDI_IDLE
    c.bulk_in(1.200, 7, 1, transfer)
    path = tmp_path / "batch.pcap"
    c.write_pcap(path)
    events, _ = decode(path)
    assert [e["kind"] for e in events] == ["command"] * 5 + ["ack", "result"] * 5
    answered = events[5:]
    assert all(e["checksum_ok"] for e in answered if e["kind"] == "result")
    assert not any(p.startswith("line error") for e in answered for p in e["problems"])
    assert "".join(e["raw"] for e in answered) == answers.hex()


def _ft2232h(with_enumeration):
    """Forty queries on port A of an FT2232H, written without waiting (pairing
    says so, which is not what is tested here); the 640 answer bytes come in one
    transfer of two 512-byte packets (510 line bytes, then 130). Port B is open
    too: idle polls on its endpoint 0x83."""
    c = UsbCapture(bus=1)
    if with_enumeration:
        c.enumerate(0.100, 4, **FT2232H)
    for k in range(10):
        c.bulk_in(0.50 + k * 0.016, 4, 3, FTDI_HS_IDLE)
    queries = [cmd("P?", device=1 + k % 6) for k in range(40)]
    answers = b"".join(ACK + result("04D2FE0C", device=1 + k % 6) for k in range(40))
    for k, q in enumerate(queries):
        c.bulk_out(1.0 + k * 0.001, 4, 2, q)
    c.bulk_in(1.9, 4, 1, ftdi_packets(answers, FTDI_HS_IDLE, size=512))
    return c, answers


@pytest.mark.parametrize("with_enumeration", [True, False])
def test_an_ft2232h_reads_at_512_byte_packets(tmp_path, with_enumeration):
    c, answers = _ft2232h(with_enumeration)
    path = tmp_path / "hs.pcapng"
    c.write_pcapng(path)
    events, warnings = decode(path)
    assert [e["kind"] for e in events] == ["command"] * 40 + ["ack", "result"] * 40
    answered = events[40:]
    assert "".join(e["raw"] for e in answered) == answers.hex()
    assert all(e["checksum_ok"] for e in answered if e["kind"] == "result")
    assert ("taken as an FTDI adapter" in warnings) is not with_enumeration
    assert "more endpoints" not in warnings   # port B's idle polls carry nothing


def test_a_cp210x_passes_raw_bytes(tmp_path):
    c = UsbCapture(bus=2)
    c.enumerate(0.100, 5, **CP2102)
    c.vendor(0.2, 5, 0x41, 0x00, 0x0001)   # IFC_ENABLE: the port opened
    c.bulk_out(1.000, 5, 1, QUERY)
    c.bulk_in(1.015, 5, 1, ACK)
    c.bulk_in(1.040, 5, 1, ANSWER)
    path = tmp_path / "cp.pcap"
    c.write_pcap(path)
    events, warnings = decode(path)
    check_conversation(events, origin=0.100)
    assert warnings == ""


def _escaped_checksum_answer():
    """A P? answer whose checksum byte is 0xEC, CP210x's escape character."""
    for az in range(2000):
        answer = result(f"{az:04X}FE0C")
        if answer[-1] == 0xEC:
            return az, answer
    raise AssertionError("no azimuth gives the checksum 0xEC")


def test_a_cp210x_in_event_mode(tmp_path):
    """After EMBED_EVENTS (escape 0xEC): an escaped 0xEC, a line status with its
    data byte (a framing error on a result's first byte), and a modem status
    event, which carries no line byte."""
    az, escaped = _escaped_checksum_answer()
    c = UsbCapture(bus=2)
    c.enumerate(0.100, 5, **CP2102)
    c.vendor(0.2, 5, 0x41, 0x15, 0xEC)   # CP210X_EMBED_EVENTS
    c.bulk_out(1.000, 5, 1, QUERY)
    c.bulk_in(1.015, 5, 1, ACK + b"\xec\x03\x30")                       # ACK, then a modem status event
    c.bulk_in(1.040, 5, 1, escaped[:-1] + b"\xec\x00")                  # the checksum, escaped
    c.bulk_out(1.100, 5, 1, QUERY)
    c.bulk_in(1.115, 5, 1, ACK)
    c.bulk_in(1.140, 5, 1, b"\xec\x01\x08" + ANSWER[:1] + ANSWER[1:])   # FE on the frame's first byte
    path = tmp_path / "events.pcap"
    c.write_pcap(path)
    events, _ = decode(path)
    assert [(e["kind"], e["problems"]) for e in events] == [
        ("command", []), ("ack", []), ("result", []), ("command", []), ("ack", []), ("result", [LINE_ERROR])]
    first = events[2]
    assert first["raw"] == escaped.hex() and first["checksum_ok"]
    assert first["fields"]["azimuth_deg"] == pytest.approx(az / 100)
    assert events[5]["raw"] == ANSWER.hex() and events[5]["request"] == events[3]["number"]


def test_a_ch340_passes_raw_bytes_and_its_interrupt_endpoint_is_left_alone(tmp_path):
    c = UsbCapture(bus=1)
    c.enumerate(0.100, 9, **CH340)
    c.vendor(0.2, 9, 0x40, 0xA1, 0xC29C)   # CH341_REQ_SERIAL_INIT
    c.interrupt_in(0.5, 9, 1, b"\x00\x00\x9f\xee")
    c.bulk_out(1.000, 9, 2, QUERY)
    c.bulk_in(1.015, 9, 2, ACK)
    c.bulk_in(1.040, 9, 2, ANSWER)
    path = tmp_path / "ch.pcap"
    c.write_pcap(path)
    events, warnings = decode(path)
    check_conversation(events, origin=0.100)
    assert warnings == ""


def _two_adapters(path):
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    c.enumerate(0.110, 9, **CP2102)
    c.enumerate(0.120, 4, **MOUSE)
    ftdi_conversation(c, polls=False)
    c.bulk_out(2.000, 9, 1, QUERY)
    c.bulk_in(2.015, 9, 1, ACK)
    c.interrupt_in(2.5, 4, 1, b"\x00\x01\x00\x00")
    c.write_pcap(path)


def test_several_adapters_are_listed_and_one_is_chosen(tmp_path):
    path = tmp_path / "two.pcap"
    _two_adapters(path)
    out = run_cli("decode", path)
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.strip() == (
        f"gimbalscope: error: {path}: 2 serial adapters move data: "
        "3.7 0403:6001 FTDI, 9 bytes out, 16 bytes in; 3.9 10c4:ea60 CP210x, 9 bytes out, 1 byte in: "
        "choose one with --usb-device BUS.DEV")
    events, _ = decode(path, "--usb-device", "3.9")
    assert [(e["kind"], e["t"]) for e in events] == [("command", pytest.approx(1.9)),
                                                     ("ack", pytest.approx(1.915 - BT))]
    events, _ = decode(path, "--usb-device", "3.7")
    check_conversation(events, origin=0.100)
    out = run_cli("decode", path, "--usb-device", "3.5")
    assert out.returncode == 2
    assert out.stderr.strip() == (
        f"gimbalscope: error: {path}: no USB device 3.5 in the capture; serial adapters in it: "
        "3.7 0403:6001 FTDI, 9 bytes out, 16 bytes in; 3.9 10c4:ea60 CP210x, 9 bytes out, 1 byte in")


def test_a_usb_stick_and_a_mouse_on_the_bus_are_no_serial_adapters(tmp_path):
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    c.enumerate(0.110, 8, **STICK)
    c.enumerate(0.120, 4, **MOUSE)
    ftdi_conversation(c, polls=False)
    c.bulk_out(1.3, 8, 2, b"USBC" + bytes(27))   # a mass-storage command block
    c.interrupt_in(1.5, 4, 1, b"\x00\x01\x00\x00")
    path = tmp_path / "bus.pcap"
    c.write_pcap(path)
    events, warnings = decode(path)
    check_conversation(events, origin=0.100)
    assert warnings == ""


def test_a_capture_without_a_serial_adapter_lists_what_it_saw(tmp_path):
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 4, **MOUSE)
    c.interrupt_in(0.5, 4, 1, b"\x00\x01\x00\x00")
    c.interrupt_in(0.6, 1, 1, b"\x10")   # the root hub's port change
    path = tmp_path / "mouse.pcap"
    c.write_pcap(path)
    out = run_cli("decode", path)
    assert out.returncode == 2
    assert out.stderr.strip() == (
        f"gimbalscope: error: {path}: a USB capture with no serial adapter in it (no bulk data to or from any "
        "device); devices seen: 3.1 (not enumerated in the capture) (interrupt), 3.4 046d:c077 (interrupt, control)")


def test_a_cut_capture_decodes_what_came_before_and_says_so(tmp_path):
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    ftdi_conversation(c, polls=False)
    path = tmp_path / "cut.pcap"
    c.write_pcap(path)
    data = path.read_bytes()
    path.write_bytes(data[:-10])   # inside the result's packet, the last one
    events, warnings = decode(path)
    assert [e["kind"] for e in events] == ["command", "ack"]
    assert events[1]["request"] == events[0]["number"]
    lines = warnings.splitlines()
    assert len(lines) == 1 and "ends inside a packet at byte" in lines[0] and "cut short" in lines[0]


def test_failed_and_empty_urbs_carry_nothing(tmp_path):
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    c.bulk_out(0.500, 7, 2, cmd("P?", device=5), status=-32)   # stalled (EPIPE): never sent
    c.bulk_in(0.600, 7, 1, b"")                               # completed empty
    c.bulk_in(0.700, 7, 1, ftdi_packets(ACK), status=-71)     # a protocol error (EPROTO)
    ftdi_conversation(c, polls=False)
    path = tmp_path / "failed.pcap"
    c.write_pcap(path)
    events, _ = decode(path)
    check_conversation(events, origin=0.100)


def test_the_api_opens_a_usb_capture(tmp_path):
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    ftdi_conversation(c, answer_status=b"\x01\x68")
    path = tmp_path / "api.pcapng"
    c.write_pcapng(path)
    events = list(analyzer.open(str(path)))
    assert [e.kind for e in events] == ["command", "ack", "result"]
    assert [str(p) for p in events[2].problems] == [LINE_ERROR]
    assert events[1].transaction is events[0].transaction


# ------------------------------------------------------------ tshark

def _ours(path):
    """What our reader gives on each line, joined."""
    source = source_for([Input(str(path))], ReadSettings(BT))
    try:
        lines = {"A": b"", "B": b""}
        for chunk in source.chunks():
            lines[chunk.line] += chunk.data
        return lines
    finally:
        source.close()


def _tsharks(path):
    """What tshark's ftdi-ft dissector reads as interface A's TX (host to
    adapter: line A) and RX (line B) payloads, joined in packet order."""
    out = subprocess.run(["tshark", "-r", str(path), "-Y", "ftdi-ft", "-T", "fields",
                          "-e", "ftdi-ft.if_a_tx_payload", "-e", "ftdi-ft.if_a_rx_payload"],
                         capture_output=True, text=True, timeout=120, check=False)
    assert out.returncode == 0, out.stderr
    lines = {"A": b"", "B": b""}
    for row in out.stdout.splitlines():
        tx, _, rx = row.partition("\t")
        lines["A"] += b"".join(bytes.fromhex(x) for x in tx.split(",") if x)
        lines["B"] += b"".join(bytes.fromhex(x) for x in rx.split(",") if x)
    return lines


def _ft232r_with_errors(c):
    c.enumerate(0.100, 7, **FT232R)
    ftdi_conversation(c, answer_status=b"\x01\x68")
    queries = [cmd("P?", device=d) for d in (1, 2, 3, 4, 5)]
    c.bulk_out(3.000, 7, 2, b"".join(queries))
    c.bulk_in(3.200, 7, 1, ftdi_packets(b"".join(ACK + result("04D2FE0C", device=d) for d in (1, 2, 3, 4, 5))))


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark is not installed (.ci/run installs it)")
@pytest.mark.parametrize("capture", ["FT232R usbmon pcap", "FT232R USBPcap", "FT2232H usbmon pcapng"])
def test_tshark_reads_the_same_payloads(tmp_path, capture):
    c = UsbCapture(bus=3)
    if capture.startswith("FT232R"):
        _ft232r_with_errors(c)
    else:
        c = _ft2232h(with_enumeration=True)[0]   # tshark knows an FTDI only from its enumeration
    path = tmp_path / "ftdi.cap"
    if "USBPcap" in capture:
        c.write_pcap(path, 249)
    elif "pcapng" in capture:
        c.write_pcapng(path, 220)
    else:
        c.write_pcap(path, 220)
    theirs, ours = _tsharks(path), _ours(path)
    assert theirs["A"] and theirs["B"]
    assert ours == theirs


def test_damaged_captures_raise_nothing_but_capture_errors(tmp_path):
    """Bytes of a capture changed at random (a fixed seed): decoded as far as
    they go, or refused in one line; never another exception."""
    import random

    from analyzer.errors import CaptureError

    rng = random.Random(28)
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    ftdi_conversation(c, answer_status=b"\x01\x68")
    forms = {}
    for form, write in WRITERS.items():
        write(c, tmp_path / "whole")
        forms[form] = (tmp_path / "whole").read_bytes()
    path = tmp_path / "damaged"
    for k in range(240):
        data = bytearray(forms[list(forms)[k % len(forms)]])
        for _ in range(rng.randint(1, 8)):
            at = rng.randrange(len(data))
            data[at] = rng.randrange(256)
        if k % 3 == 0:
            del data[rng.randrange(len(data)):]
        path.write_bytes(bytes(data))
        try:
            source = source_for([Input(str(path))], ReadSettings(BT))
        except CaptureError:
            continue
        try:
            for _ in source.chunks():
                pass
        except CaptureError:
            pass
        finally:
            source.close()
