"""Commands encoded from the table (dissectors/encode.py): payloads computed by hand
from the spec's tables, and, for every command of the table, encoding the values
its dissection gives back the payload (the encoder is the dissector's inverse)."""

import re

import pytest

from dissectors.commands import COMMANDS, CONFIG, EFFECTS, MOTION, QUERY, STOP
from dissectors.dissect import dissect_command
from dissectors.encode import EncodeError, encode, find_command
from tests.conftest import frame


@pytest.mark.parametrize(("code", "values", "payload"), [
    # Table 15: hundredths of a degree, signed 16-bit: 10.00 = 1000 = 03E8, -5.00 = -500 = FE0C
    ("P", {"azimuth_deg": 10, "elevation_deg": -5}, b"P03E8FE0C"),
    # the document's own example: +40.00°, -10.00° is P0FA0FC18
    ("P", {"azimuth_deg": "40", "elevation_deg": "-10.00"}, b"P0FA0FC18"),
    # Tables 12-13: 10.25 deg/s is sent as 1025 = 0401
    ("RP", {"rate_deg_s": 10.25}, b"RP0401"),
    # Table 7 in tenths (its "1.5 as 0E" is a typo: 15 is 0F)
    ("GRP", {"gain": 1.5}, b"GRP0F"),
    ("Pnn", {"preset": 37}, b"P25"),                 # Table 11: preset in hex
    ("C", {"rate_code": 4}, b"C4"),                  # Table 4: C4 is 19,200 bps
    ("#NN", {"new_address": 254}, b"#FE"),           # §1.5.3: 01 to FE
    ("D?", {}, b"D?"),
    ("LS", {"pan_ccw": 0x123, "pan_cw": 0xABC, "tilt_ccw": 0, "tilt_cw": 4095}, b"LS123ABC000FFF"),   # Table 10
    ("V", {"zoom": 0xFFF, "focus": 10}, b"VFFF00A"),   # Table 17: 12-bit values
    ("*x1c", {"baud": 9600, "data_bits": 8, "stop_bits": 1, "parity": "even"}, b"*x1c,9600,8,1,2"),   # Table 18
    ("*x0t", {"data": "hello"}, b"*x0thello"),
])
def test_payloads_as_the_tables_give_them(code, values, payload):
    assert encode(code, values).payload == payload


def test_a_frame_is_table_1s():
    assert encode("P", {"azimuth_deg": 10, "elevation_deg": -5}).frame((1, 1, 3)) == frame((1, 1, 3), 0, "P03E8FE0C")


def _sample(f) -> bytes:
    """Characters a field's pattern takes: the smallest count of its kind (a
    decimal within its valid range)."""
    if f.choices:
        return f.choices[0][0]
    if f.codec == "decimal" and f.valid:
        return str(int(f.valid[0])).encode()
    regex = f.regex
    m = re.fullmatch(rb"(.+?)\{(\d+)(?:,(\d*))?\}", regex)
    count = int(m.group(2)) if m else 1
    count = count or 2
    kind = m.group(1) if m else regex
    char = b"1" if b"0-9" in kind else b"A" if kind == rb"[A-Fa-f]" else b"7"
    return char * count


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c.id)
def test_encoding_what_dissection_gives_is_the_payload_again(command):
    payload = b"".join(p if isinstance(p, bytes) else _sample(p) for p in command.layout.parts)
    if "{aux_port}" in command.id:
        payload = payload.replace(b"*x7", b"*x1", 1)
    decoded = dissect_command(payload)
    assert decoded.entry is command, payload
    code = decoded.command
    values = {k: v for k, v in decoded.fields.items() if k in {f.name for f in command.layout.fields}}
    if "{aux_port}" in command.id:
        values.pop("aux_port", None)
    assert encode(code, values).payload == payload


def test_every_command_has_one_effect_read_from_the_tables():
    assert {c.effect for c in COMMANDS} <= set(EFFECTS)
    effect = {c.id: c.effect for c in COMMANDS}
    assert [effect[c] for c in ("D?", "AW", "P?", "B?")] == [QUERY] * 4        # "Request ..."
    assert [effect[c] for c in ("HS", "PS", "TS", "HA")] == [STOP] * 4          # stops
    assert [effect[c] for c in ("P", "Pnn", "HO", "IX", "PL")] == [MOTION] * 5  # go to, pan, initialise
    assert [effect[c] for c in ("#NN", "C", "LS", "Snn", "LA")] == [CONFIG] * 5  # address, rate, limits, preset, relay


@pytest.mark.parametrize(("code", "values", "message"), [
    ("Q", {}, "unknown command 'Q'"),
    ("P", {"azimuth_deg": 1}, "P (Go to pan-tilt position) needs elevation_deg [deg]"),
    ("P", {"azimuth_deg": 1, "elevation_deg": 1, "speed": 2}, "has no field 'speed'"),
    ("P", {"azimuth_deg": 327.68, "elevation_deg": 0}, "a signed 16-bit value, -327.68 to 327.67"),
    ("P", {"azimuth_deg": "north", "elevation_deg": 0}, "a number in deg"),
    ("#NN", {"new_address": 255}, "outside 1..254"),         # 255 is the wildcard, not an address
    ("Pnn", {"preset": 256}, "at most 255 (2 hex digits)"),
    ("C", {"rate_code": 16}, "at most 15 (1 hex digits)"),
    ("*x1c", {"baud": 9600, "data_bits": 8, "stop_bits": 1, "parity": "mark"}, "one of none, odd, even"),
    ("RP", {"rate_deg_s": float("nan")}, "a finite number"),
])
def test_mistakes_say_what_was_wrong(code, values, message):
    with pytest.raises(EncodeError) as e:
        encode(code, values)
    assert message in str(e.value)


def test_codes_are_found_by_id_or_as_sent():
    assert find_command("*x0c")[1] == {"aux_port": 0}
    assert find_command("P?nn")[0].name == "Get preset"
    with pytest.raises(EncodeError) as e:
        find_command("*x2c")   # ports 0 and 1 only (Table 16)
    assert e.value.kind == "command" and "D?" in e.value.valid
