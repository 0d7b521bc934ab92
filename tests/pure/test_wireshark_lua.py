"""The Lua dissector's generator (analyzer/wireshark/lua.py) and the packet
header (analyzer/formats/pdu.py), without Wireshark (tests/integration/
test_wireshark.py runs the result in tshark)."""

import re
import struct

import pytest

from analyzer.formats import pdu
from analyzer.wireshark import lua
from dissectors import problems as P
from dissectors.commands import field_types
from dissectors.event import Event
from dissectors.fields import Layout, hexnum
from tests.conftest import frame


@pytest.mark.parametrize("regex, pattern", [
    (rb"[0-9A-Fa-f]{4}", "%x%x%x%x"),
    (rb"[0-9A-Fa-f]{1,2}", "%x%x?"),
    (rb"[0-9]{1,3}", "%d%d?%d?"),
    (rb"[\s\S]{2}", ".."),
    (rb"[\s\S]{0,}", ".*"),
    (rb".", "."),
    (rb"[A-Fa-f]", "[A-Fa-f]"),
])
def test_field_shapes_become_lua_patterns(regex, pattern):
    assert lua.lua_pattern(regex) == pattern


def test_a_shape_lua_cannot_say_stops_the_generator():
    with pytest.raises(ValueError):
        lua.lua_pattern(rb"(ab|cd)")


def test_layout_literals_are_escaped_and_fields_captured():
    layout = Layout((b"*x", hexnum("n", 2), b"c,?"))
    assert lua.layout_pattern(layout) == "^%*x()(%x%x)c,%?$"


def test_a_derive_function_without_a_lua_version_stops_the_generator():
    def _new(values):
        values["x"] = 1
    with pytest.raises(ValueError, match="_new"):
        lua.layout_spec(Layout((b"Q", hexnum("n", 2)), _new))


def test_every_field_and_problem_of_the_tables_is_in_the_dissector():
    text = lua.generate()
    for name in field_types():
        assert 'ProtoField.' in text and f'"{lua.abbr(name)}"' in text
    assert '"gimbal.field_status"' in text   # AW's status: the event's status keeps its name
    for info in P.TABLE:
        assert f'"gimbal.expert.{info.name.lower()}"' in text
    assert not re.search(r"@@\w+@@", text)


def test_the_header_carries_what_pairing_decided():
    raw = frame((1, 1, 2), 0, "P?")
    ev = Event("A", 40, "command", raw, t=1.0, dst=(1, 1, 2), src=0, payload=b"P?", checksum_ok=True)
    ev.number, ev.txn, ev.status, ev.command = 7, 3, "nak", "P?"
    ev.add_problem(P.CHECKSUM, "expected 0x12")
    data = pdu.encode(ev, capture=2)
    # tags: the dissector's name, padded to 4 bytes, then the end tag
    assert data[:16] == struct.pack(">HH", 12, 8) + b"gimbal\0\0" + struct.pack(">HH", 0, 0)
    h = data[16:]
    assert h[0] == 1 and pdu.KIND_CODES[h[1]] == "command" and pdu.STATUS_CODES[h[2]] == "nak"
    assert struct.unpack(">III", h[4:16]) == (7, 3, 0)
    assert struct.unpack(">H", h[16:18]) == (2,) and pdu.LINE_CODES[h[18]] == "A"
    assert h[34:37] == bytes((1, 1, 2)) and h[37] == 2 and h[38:40] == b"P?"
    assert h[40] == 1 and struct.unpack(">H", h[41:43])[0] == P.TABLE.index(P.CHECKSUM)
    k = struct.unpack(">H", h[43:45])[0]
    assert h[45:45 + k] == b"bad checksum: expected 0x12"
    assert h[45 + k:] == raw   # the wire bytes, last and whole
