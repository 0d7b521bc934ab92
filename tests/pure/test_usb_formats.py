"""USB capture formats (analyzer/formats/usb.py) and the adapters' framing of
their IN data (analyzer/formats/usbserial.py), on bytes built by hand or by
the test writer (tests/usb_captures.py), which follows the headers'
definitions and not the code under test."""

import io
import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from analyzer.errors import CaptureError
from analyzer.formats import usb
from analyzer.formats.usbserial import (
    BREAK,
    FRAMING,
    OVERRUN,
    PARITY,
    Cp210xIn,
    FtdiIn,
    ftdi_max_packet,
    looks_like_ftdi_status,
)
from tests.usb_captures import (
    BULK,
    CP2102,
    CTRL,
    FT232R,
    FT2232H,
    START,
    UsbCapture,
    config_descriptor,
    device_descriptor,
)


def _capture():
    c = UsbCapture(bus=3)
    c.enumerate(0.1, 7, **FT232R)
    c.bulk_out(1.0, 7, 2, b"\xf8\x01\x01\x02\x00\x02P?\x95")
    c.bulk_in(1.015, 7, 1, b"\x01\x60\x06")
    return c


def _urbs(path):
    warnings = []
    with open(path, "rb") as f:
        out = [usb.urb_of(lt, ns, endian, data) for lt, ns, endian, data in usb.packets(f, "cap", warnings.append)]
    return out, warnings


# ------------------------------------------------------------ containers

@pytest.mark.parametrize("link_type, endian, nanos", [(220, "<", False), (220, ">", True), (189, "<", True),
                                                      (189, ">", False), (249, "<", False)])
def test_pcap_forms_give_the_same_urbs(tmp_path, link_type, endian, nanos):
    c = _capture()
    path = tmp_path / "c.pcap"
    c.write_pcap(path, link_type, endian, nanos)
    head = path.read_bytes()[:64]
    assert usb.link_types(head) == {link_type}
    urbs, warnings = _urbs(path)
    assert warnings == []
    assert len(urbs) == 10   # three GET_DESCRIPTORs, one OUT and one IN URB: a submission and a completion each
    out_s, out_c, in_s, in_c = urbs[6:]
    assert out_s.ns == (START + 1) * 10**9 and not out_s.completion and not out_s.incoming
    assert (out_s.bus, out_s.device, out_s.endpoint, out_s.transfer) == (3, 7, 2, usb.BULK)
    assert out_s.data == b"\xf8\x01\x01\x02\x00\x02P?\x95"
    assert out_c.completion and out_c.urb_id == out_s.urb_id and out_c.status == 0
    assert in_s.incoming and not in_s.completion and in_s.data == b""
    assert in_c.incoming and in_c.completion and in_c.endpoint == 1 and in_c.data == b"\x01\x60\x06"
    assert in_c.ns == START * 10**9 + 1_015_000_000
    setup = usb.setup_of(urbs[0].setup)
    assert (setup.request_type, setup.request, setup.value, setup.length) == (0x80, 6, 0x0100, 18)
    assert usb.device_ids(urbs[1].data) == (0x0403, 0x6001)


def test_pcapng_with_nanosecond_interface(tmp_path):
    c = _capture()
    path = tmp_path / "c.pcapng"
    c.write_pcapng(path, 220)
    assert usb.link_types(path.read_bytes()[:200]) == {220}
    urbs, warnings = _urbs(path)
    assert warnings == [] and len(urbs) == 10
    assert urbs[6].ns == (START + 1) * 10**9 and urbs[6].data[:1] == b"\xf8"


def test_other_files_are_not_usb_captures():
    assert usb.link_types(b"\xf8\x01\x01\x02") is None
    ethernet = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1)
    assert usb.link_types(ethernet) == {1}


def test_a_cut_pcap_gives_what_came_before_and_says_where(tmp_path):
    c = _capture()
    path = tmp_path / "c.pcap"
    c.write_pcap(path)
    whole = path.read_bytes()
    path.write_bytes(whole[:-5])
    urbs, warnings = _urbs(path)
    assert len(urbs) == 9
    assert len(warnings) == 1 and "ends inside a packet at byte" in warnings[0] and "read up to there" in warnings[0]


def test_a_damaged_record_length_ends_the_walk_with_a_warning(tmp_path):
    c = _capture()
    path = tmp_path / "c.pcap"
    c.write_pcap(path)
    data = bytearray(path.read_bytes())
    data[24 + 8:24 + 12] = struct.pack("<I", 0x7FFFFFFF)   # the first record's captured length
    path.write_bytes(bytes(data))
    urbs, warnings = _urbs(path)
    assert urbs == [] and "damaged" in warnings[0]


def test_a_damaged_pcapng_block_is_a_warning_not_an_error(tmp_path):
    c = _capture()
    path = tmp_path / "c.pcapng"
    c.write_pcapng(path)
    data = bytearray(path.read_bytes())
    at = 0
    for _ in range(4):   # the section, the interface and two packets: the third packet's length is damaged
        at += struct.unpack_from("<I", data, at + 4)[0]
    data[at + 4:at + 8] = struct.pack("<I", 5)
    path.write_bytes(bytes(data))
    urbs, warnings = _urbs(path)
    assert len(urbs) == 2
    assert len(warnings) == 1 and "a pcapng block of length 5" in warnings[0] and "read up to there" in warnings[0]


@given(st.binary(max_size=300))
def test_any_bytes_after_a_pcap_header_never_raise(tail):
    head = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 220)
    for link_type in usb.LINK_TYPES:
        usb.urb_of(link_type, 0, "<", tail)   # None or a URB, never an exception
    try:
        list(usb.packets(io.BytesIO(head + tail), "x", lambda m: None))
        list(usb.packets(io.BytesIO(b"\x0a\x0d\x0d\x0a" + tail), "x", lambda m: None))
    except CaptureError:
        pass


# ------------------------------------------------------------ headers and descriptors

def test_short_packets_are_no_urbs():
    assert usb.urb_of(220, 0, "<", bytes(63)) is None
    assert usb.urb_of(189, 0, "<", bytes(47)) is None
    assert usb.urb_of(249, 0, "<", bytes(26)) is None
    assert usb.urb_of(1, 0, "<", bytes(100)) is None


def test_usbpcap_setup_stage_carries_the_setup_packet():
    c = UsbCapture(bus=2)
    c.vendor(0.0, 5, 0x41, 0x15, 0xEC)
    sub, done = [c.usbpcap(e) for e in c.ordered()]
    u = usb.urb_of(249, 0, "<", sub)
    assert (u.transfer, u.completion, u.device, u.bus) == (CTRL, False, 5, 2)
    assert usb.setup_of(u.setup) == usb.Setup(0x41, 0x15, 0xEC, 0, 0)
    v = usb.urb_of(249, 0, "<", done)
    assert v.completion and v.setup is None and v.urb_id == u.urb_id and v.status == 0


def test_device_and_configuration_descriptors():
    assert usb.device_ids(device_descriptor(0x10C4, 0xEA60, 0x0100)) == (0x10C4, 0xEA60)
    assert usb.device_ids(device_descriptor(0x10C4, 0xEA60, 0x0100)[:8]) is None   # the first 8-byte read
    eps = usb.endpoints(config_descriptor(FT2232H["ports"]))
    assert [(e.interface, e.address, e.transfer, e.max_packet) for e in eps] == [
        (0, 0x81, BULK, 512), (0, 0x02, BULK, 512), (1, 0x83, BULK, 512), (1, 0x04, BULK, 512)]
    assert usb.endpoints(config_descriptor(CP2102["ports"])[:20]) == []   # cut inside the first endpoint


# ------------------------------------------------------------ FTDI

def test_ftdi_status_bytes_come_off_every_packet():
    ftdi = FtdiIn(64)
    line = bytes(range(100, 200))   # 100 bytes: 62 + 38
    transfer = b"\x01\x60" + line[:62] + b"\x01\x60" + line[62:]
    assert ftdi.decode(transfer) == (line, [])
    assert ftdi.decode(b"\x01\x60") == (b"", [])     # an idle poll
    assert ftdi.taken == 100


def test_ftdi_high_speed_packets_are_512():
    ftdi = FtdiIn(512)
    line = bytes(600)
    assert ftdi.decode(b"\x02\x60" + line[:510] + b"\x02\x60" + line[510:]) == (line, [])


def test_ftdi_line_status_errors_are_put_on_the_packets_bytes():
    ftdi = FtdiIn(64)
    assert ftdi.decode(b"\x01\x60AB") == (b"AB", [])
    # framing error: the packet's first byte (line offset 2)
    assert ftdi.decode(b"\x01\x68CD") == (b"CD", [(2, FRAMING)])
    # parity wins over framing, overrun besides
    assert ftdi.decode(b"\x01\x6eEF") == (b"EF", [(4, PARITY), (4, OVERRUN)])
    # a break with a NUL last: the NUL; a stale break flag on other bytes: nothing
    assert ftdi.decode(b"\x01\x70G\x00") == (b"G\x00", [(7, BREAK)])
    assert ftdi.decode(b"\x01\x70HI") == (b"HI", [])


def test_ftdi_errors_of_idle_polls_go_on_the_next_byte_once():
    ftdi = FtdiIn(64)
    assert ftdi.decode(b"\x01\x70") == (b"", [])
    assert ftdi.decode(b"\x01\x70") == (b"", [])
    assert ftdi.decode(b"\x01\x60J") == (b"J", [(0, BREAK)])


def test_ftdi_is_told_by_its_modem_status():
    assert looks_like_ftdi_status(b"\x01\x60") and looks_like_ftdi_status(b"\x32\x60")
    assert not looks_like_ftdi_status(b"\xf8\x00") and not looks_like_ftdi_status(b"\x06")
    assert ftdi_max_packet(b"\x01\x60") == 64 and ftdi_max_packet(b"\x32\x60") == 512


# ------------------------------------------------------------ CP210x

def test_cp210x_raw_until_event_insertion():
    cp = Cp210xIn()
    assert cp.decode(b"\xec\x00A") == (b"\xec\x00A", [])
    cp.events(0xEC)
    assert cp.decode(b"x\xec\x00y") == (b"x\xecy", [])                     # the escape character itself
    assert cp.decode(b"\xec\x01\x08\xf8z") == (b"\xf8z", [(6, FRAMING)])   # a line status and its byte
    assert cp.decode(b"\xec\x02\x12") == (b"", [])                         # a line status alone ...
    assert cp.decode(b"q") == (b"q", [(8, BREAK), (8, OVERRUN)])           # ... on the next byte
    assert cp.decode(b"\xec\x03\xb0r") == (b"r", [])                        # a modem status: dropped
    assert cp.decode(b"\xec") == (b"", [])                                  # an escape split over transfers
    assert cp.decode(b"\x00s") == (b"\xecs", [])
    cp.events(None)
    assert cp.decode(b"\xec\x01") == (b"\xec\x01", [])
