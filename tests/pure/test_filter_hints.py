"""Filter errors say the fix, not only the fault (analysis/filter_hints.py):
quotes for text, the nearest name, the field with its unit, '==' for '=', a
known value spelt nearest; and Wireshark's ``gimbal.`` prefix is accepted.
Every message stays one line (the TUI shows it in a bar)."""

import re

import pytest

from analyzer.analysis.filter import VOCABULARY, FilterError, compile_filter
from analyzer.wireshark.lua import FIXED, abbr
from dissectors.commands import field_types
from dissectors.event import Event


def ev(**kw) -> Event:
    e = Event(kw.pop("line", "A"), 0, kw.pop("kind", "command"), b"\xf8", None)
    for k, v in kw.items():
        setattr(e, k, v)
    return e


NAK_CMD = ev(command="HO", status="nak", dst=(1, 1, 2), txn=3, device="1.1.2", number=1)
OK_CMD = ev(command="P?", status="ok", dst=(1, 1, 3), txn=4, device="1.1.3", number=2, checksum_ok=True)
RESULT = ev(kind="result", line="B", command="P?", dst=(0, 1, 2), src=1, txn=4, number=3, latency=0.02,
            fields={"azimuth_deg": 40.0, "elevation_deg": -10.0}, problems=["bad checksum: x"])
EVENTS = [NAK_CMD, OK_CMD, RESULT]


def error_of(expr: str) -> FilterError:
    with pytest.raises(FilterError) as info:
        compile_filter(expr)
    return info.value


def fix_in(message: str) -> str:
    """The rewritten expression a hint offers."""
    m = re.search(r"did you mean (.*)\?$", message)
    assert m, message
    return m.group(1)


# --- the five mistakes of issue 27, and a misspelt known value: the whole message, by hand
@pytest.mark.parametrize("expr,message", [
    ("status == nak",
     "column 11: unknown name 'nak'; text goes in quotes: did you mean status == \"nak\"?"),
    ('staus == "nak"',
     "column 1: unknown name 'staus'; did you mean status == \"nak\"?"),
    ("azimuth > 10",
     "column 1: unknown name 'azimuth'; the unit is part of the name: did you mean azimuth_deg > 10?"),
    ('status = "nak"',
     "column 8: unexpected character '='; did you mean status == \"nak\"?"),
    ('status == "nack"',
     ("column 11: status is never 'nack' (it is one of: nak, nic, no_ack, no_result, ok, pending); "
      "did you mean status == \"nak\"?")),
])
def test_the_error_says_the_fix(expr, message):
    assert str(error_of(expr)) == message


@pytest.mark.parametrize("expr,fix", [
    # text goes in quotes, as the field's known value when it has some
    ("command == HO", 'command == "HO"'),
    ("command == P?", 'command == "P?"'),
    ("status == NAK", 'status == "nak"'),
    ("status != nack", 'status != "nak"'),
    ('command in ["P?", HO]', 'command in ["P?", "HO"]'),
    # the nearest name; a stem without its unit counts as the field
    ("Status", "status"),
    ("latncy > 0.1", "latency > 0.1"),
    ("azimut < 4", "azimuth_deg < 4"),
    ("rate_deg_s > pan_rate", "rate_deg_s > pan_rate_deg_s"),
    ("fields.elevation < 0", "fields.elevation_deg < 0"),
    ("fields.latency > 1", "latency > 1"),
    ('"bad checksum" in problemz', '"bad checksum" in problems'),   # after 'in', most often a name
    # operators as other languages write them
    ('status === "nak"', 'status == "nak"'),
    ('kind == "ack" && latency > 0.05', 'kind == "ack" and latency > 0.05'),
    ('kind == "ack"||problems', 'kind == "ack" or problems'),
    ("!checksum_ok", "not checksum_ok"),
    ('status eq "nak"', 'status == "nak"'),
    ("latency ge 0.1", "latency >= 0.1"),
    ('(status ne "ok")', '(status != "ok")'),
    ("latency > 1 AND problems", "latency > 1 and problems"),
    ("NOT problems", "not problems"),
    ("latency == None", "latency == null"),
    ('status "nak"', 'status == "nak"'),
    ('status == "nak', 'status == "nak"'),
    ("line == 'a'", "line == 'A'"),
    # Wireshark's names
    ("gimbal.problem", "gimbal.problems"),
    ("gimbal.field_status", "gimbal.fields.status"),
    ("gimbal.dst.device == 2", "gimbal.dst[2] == 2"),
    ('dst == "1.1.2"', "dst == [1, 1, 2]"),
    ("gimbal.status == nak", 'gimbal.status == "nak"'),
])
def test_the_fix_offered_compiles(expr, fix):
    assert fix_in(str(error_of(expr))) == fix
    compile_filter(fix)


def test_several_near_names_are_listed():
    assert str(error_of("azimuth_stat")).endswith("; did you mean azimuth_status or azimuth_status_bits?")


@pytest.mark.parametrize("expr", ["frobnicate", "txn = = 3", "dst == \"north\"", "gimbal"])
def test_no_guess_without_a_likely_fix(expr):
    message = str(error_of(expr))
    assert "did you mean" not in message


def test_without_a_hint_the_names_are_listed():
    message = str(error_of("frobnicate > 1"))
    assert message.startswith("column 1: unknown name 'frobnicate': use an event key (number, t, ")


def test_gimbal_alone_says_where_the_prefix_goes():
    assert str(error_of("gimbal")).endswith("; Wireshark's gimbal. goes before a name, as in gimbal.status")


def test_a_text_dst_and_a_dst_key_are_errors_not_silent_misses():
    assert "dst is a list of numbers (group, port, device), never text" in str(error_of('dst != "north"'))
    assert str(error_of("dst.group")) == ("column 5: dst is a list (group, port, device): it has no 'group'; "
                                          "did you mean dst[0]?")
    assert str(error_of("dst.side")).endswith("; write dst[0], dst[1] or dst[2]")


def test_a_misspelt_field_after_fields_is_an_error():
    assert str(error_of("fields.azimuth_degs")).startswith("column 8: no decoded field is named 'azimuth_degs'; ")


# --- Wireshark's prefix, accepted
@pytest.mark.parametrize("plain", [
    'status == "nak"', 'kind == "result"', "dst[2] == 3", "fields.azimuth_deg > 30", "azimuth_deg > 30",
    'device == "1.1.2"', "checksum_ok", "latency < 0.05", '"bad checksum" in problems',
    'command in ["P?"] and not status == "ok"',
])
def test_the_gimbal_prefix_selects_what_the_plain_name_does(plain):
    prefixed = re.sub(r"(?<![.\w])(status|kind|dst|fields|azimuth_deg|device|checksum_ok|latency|problems|command)\b",
                      r"gimbal.\1", plain)
    assert "gimbal." in prefixed
    want = [e.number for e in EVENTS if compile_filter(plain)(e)]
    assert [e.number for e in EVENTS if compile_filter(prefixed)(e)] == want


def test_the_prefix_checks_known_values_too():
    assert "status is never 'nack'" in str(error_of('gimbal.status == "nack"'))


def test_every_wireshark_name_of_ours_is_accepted_or_corrected():
    """The dissector's own fields with a name of the same meaning here compile with the
    prefix; the ones spelt differently are corrected; the rest have no counterpart."""
    corrected = {"problem": "gimbal.problems", "request_in": "gimbal.request", "checksum": "gimbal.checksum_ok"}
    no_counterpart = {"command_name", "length", "response_in", "capture", "spec"}
    for name in FIXED:
        if name in corrected:
            assert fix_in(str(error_of(f"gimbal.{name}"))) == corrected[name]
        elif name in no_counterpart:
            assert "unknown name" in str(error_of(f"gimbal.{name}"))
        else:
            compile_filter(f"gimbal.{name}")
    for name in field_types():      # every decoded value, by its Wireshark name
        wireshark = abbr(name)
        try:
            compile_filter(wireshark)
        except FilterError as e:
            assert wireshark == "gimbal.field_" + name
            compile_filter(fix_in(str(e)))


def test_the_unit_stems_are_every_field_with_a_unit_in_its_name():
    # from the command table's units (fields.md): deg, deg/s, deg/s^2; the bps fields
    # (baud, max_baud, previous_baud) carry no unit in their names
    assert VOCABULARY.stems == {
        "azimuth": "azimuth_deg", "elevation": "elevation_deg",
        "rate": "rate_deg_s", "pan_rate": "pan_rate_deg_s", "tilt_rate": "tilt_rate_deg_s",
        "accel": "accel_deg_s2", "pan_accel": "pan_accel_deg_s2", "tilt_accel": "tilt_accel_deg_s2",
    }


# --- one line, and short
@pytest.mark.parametrize("expr", ["status ==\nnak", "kind ==\t\"ak\"", "latency > 1\r\n&& problems",
                                  "staus\n== 1"])
def test_a_hint_keeps_the_message_one_line(expr):
    e = error_of(expr)
    line = f"--filter {e} in: {e.pointer()}"     # as the CLI prints it
    assert "did you mean" in line
    assert line.splitlines() == [line]


def test_a_long_expression_is_cut_around_the_fix():
    head = " or ".join(f"number == {i}" for i in range(50))
    tail = " or ".join(f"txn == {i}" for i in range(50))
    fix = fix_in(str(error_of(f"{head} or status == nak or {tail}")))
    # 30 characters either side of the change: 16 of the head before ' or status == '
    assert fix == f'…{head[-16:]} or status == "nak" or {tail[:26]}…'
