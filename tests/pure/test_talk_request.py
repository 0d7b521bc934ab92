"""What a person asks to send, read once for ``send`` and the TUI's prompt
(analyzer/talk/request.py): raw bytes read as the deframer reads frames (Table 1,
READING: a length byte of 0 is 256), addresses as ``format_address`` writes them."""

import pytest

from analyzer.talk.request import TalkError, address, frame_payload, parse_line
from analyzer.talk.safety import Allowed
from tests.conftest import frame


def test_a_raw_frames_payload_bad_checksum_or_not():
    good = frame((1, 1, 3), 0, "D?")
    assert frame_payload(good) == b"D?"
    assert frame_payload(good[:-1] + bytes([good[-1] ^ 0xFF])) == b"D?"   # still a frame: its checksum is shown
    long = frame((1, 1, 3), 0, "*x0t" + "A" * 252)                        # 256 characters: length byte 0
    assert long[5] == 0 and frame_payload(long) == long[6:-1]
    assert frame_payload(good + good) is None        # two frames: not one request
    assert frame_payload(b"\x06") is None            # an ACK
    assert frame_payload(b"\xf8\x01") is None        # cut short


def test_addresses_and_lines():
    assert address("255.1.3") == (255, 1, 3)
    for bad in ("1.1", "1.1.256", "a.b.c", "1.1.1.1", "-1.1.1"):
        with pytest.raises(TalkError):
            address(bad)
    asked = parse_line("P --to 1.1.3 azimuth_deg=10 elevation_deg=-5 --allow-motion")
    assert (asked.command, asked.to, asked.values) == ("P", (1, 1, 3), {"azimuth_deg": "10", "elevation_deg": "-5"})
    assert asked.allowed == Allowed(motion=True)
