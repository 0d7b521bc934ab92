"""The --filter language: semantics over the JSON names, and errors that point
at the bad token. It never evaluates Python."""

import pytest

from analyzer.analysis.filter import FilterError, compile_filter
from dissectors.event import Event


def ev(**kw) -> Event:
    e = Event(kw.pop("line", "A"), 0, kw.pop("kind", "command"), kw.pop("raw", b"\xf8"), kw.pop("t", None))
    for k, v in kw.items():
        setattr(e, k, v)
    return e


NAK_CMD = ev(command="HO", status="nak", dst=(1, 1, 2), txn=3)
SLOW = ev(kind="ack", line="B", latency=0.08, txn=4)
POS = ev(kind="result", line="B", command="P?", fields={"azimuth_deg": 40.0, "elevation_deg": -10.0}, txn=5)
BAD = ev(checksum_ok=False, problems=["bad checksum: expected 0x94, got 0x92"], command="P?")


@pytest.mark.parametrize("expr,matches", [
    ('status == "nak" or problems', [NAK_CMD, BAD]),
    ('kind == "ack" and latency > 0.05', [SLOW]),
    ("azimuth_deg > 30", [POS]),
    ("fields.elevation_deg < 0", [POS]),
    ("dst[2] == 2", [NAK_CMD]),
    ("dst == [1, 1, 2]", [NAK_CMD]),
    ('"bad checksum" in problems', [BAD]),
    ('command in ["P?", "HO"] and not checksum_ok == false', [NAK_CMD, POS]),
    ('command not in ["P?"]', [NAK_CMD, SLOW]),
    ("not (txn >= 4)", [NAK_CMD, BAD]),
    ("checksum_ok == false", [BAD]),
    ("latency", [SLOW]),
    ('line == "B" and kind != "ack"', [POS]),
    ("azimuth_deg < \"x\"", []),   # mismatched types compare false, never raise
])
def test_semantics(expr, matches):
    keep = compile_filter(expr)
    assert [e for e in (NAK_CMD, SLOW, POS, BAD) if keep(e)] == matches


@pytest.mark.parametrize("expr,column,fragment", [
    ('status == ', 11, "expected a value"),
    ('status === "nak"', 10, "unexpected character '='"),
    ('status == "nak" and', 20, "expected a value"),
    ('statuss == "nak"', 1, "unknown name 'statuss'"),
    ('status == "nack"', 11, "status is never 'nack'"),
    ('(kind == "ack"', 15, "expected ')'"),
    ("latency > 0.1 latency", 15, "expected 'and', 'or'"),
    ("__import__('os')", 1, "unknown name '__import__'"),
    ("", 1, "empty filter"),
    ("kind == 'ack' ; rm", 15, "unexpected character ';'"),
])
def test_errors_point_at_the_token(expr, column, fragment):
    with pytest.raises(FilterError) as info:
        compile_filter(expr)
    assert info.value.column == column
    assert fragment in str(info.value)


# --- != and absent values (docs/filters.md: comparisons between different types are false)

ACKED = ev(command="P?", status="ok", dst=(1, 1, 2), txn=6)
ITS_ACK = ev(kind="ack", line="B", txn=6, request=1)
ITS_RESULT = ev(kind="result", line="B", command="P?", dst=(0, 1, 2), src=1, txn=6)
PEOPLE = [NAK_CMD, ACKED, ITS_ACK, ITS_RESULT]


def test_not_equal_needs_both_values_present_and_comparable():
    rules = {
        # an ACK or result has no status: neither equal to "ok" nor different from it
        'status != "ok"': [NAK_CMD],
        'not status == "ok"': [NAK_CMD, ITS_ACK, ITS_RESULT],
        # against the literal null: presence
        "status != null": [NAK_CMD, ACKED],
        "status == null": [ITS_ACK, ITS_RESULT],
        "null != null": [],
        "null == null": PEOPLE,
        # two absent values are not equal fields
        "latency == request": [],
        # a header's list differs only where there is a header
        "dst != [1, 1, 2]": [ITS_RESULT],
        "dst[0] != 1": [ITS_RESULT],
        # different types are never "different" either: the string "6" is not a txn
        'txn != "6"': [],
    }
    got = {expr: [e for e in PEOPLE if compile_filter(expr)(e)] for expr in rules}
    assert got == rules


def test_booleans_are_not_numbers():
    bad = ev(checksum_ok=False, retransmission=True)
    assert not compile_filter("checksum_ok == 0")(bad)
    assert not compile_filter("retransmission == 1")(bad)
    assert not compile_filter("retransmission in [1, 2]")(bad)
    assert compile_filter("retransmission in [true]")(bad)
    assert compile_filter("checksum_ok == false")(bad)


def test_values_that_cannot_be_keys_never_raise():
    e = ev(command="P?", dst=(1, 1, 2), fields={"azimuth_deg": 1.0, "flags": ["a", "b"]})
    # a list looked up in a dict, a dict looked up in a list: false, not TypeError
    assert not compile_filter("dst in fields")(e)
    assert not compile_filter("fields in [1, 2]")(e)
    assert not compile_filter("fields in problems")(e)
    assert compile_filter('"azimuth_deg" in fields')(e)


def test_device_is_a_name():
    ack = ev(kind="ack", line="B", txn=3, request=1)
    ack.device = "1.1.2"
    assert compile_filter('device == "1.1.2"')(ack)
    assert compile_filter('device == "1.1.2"')(NAK_CMD)     # a command's destination
    assert not compile_filter('device == "1.1.2"')(SLOW)    # an unpaired ACK: no device


@pytest.mark.parametrize("expr,column,fragment", [
    ("latency < " + "9" * 5000, 11, "more than 30 digits"),
    ("latency < 1e999", 11, "out of range"),
    ("latency < 1234567890123456789012345678901", 11, "more than 30 digits"),
    ("(" * 200 + "latency" + ")" * 200, 65, "nested more than 64 levels"),
    ("not " * 5000 + "latency", 64 * 4 + 1, "nested more than 64 levels"),
    ("[" * 100 + "]" * 100, 65, "nested more than 64 levels"),
    ("not (" * 40 + "latency" + ")" * 40, 32 * 5 + 1, "nested more than 64 levels"),
    ("txn == \u0663", 8, "unexpected character"),     # only ASCII digits are numbers
], ids=["5000 digits", "inf", "31 digits", "200 parens", "5000 nots", "100 lists", "not (", "arabic 3"])
def test_limits_are_errors_with_a_column(expr, column, fragment):
    with pytest.raises(FilterError) as info:
        compile_filter(expr)
    assert info.value.column == column
    assert fragment in str(info.value)
    assert len(f"{info.value} in: {info.value.pointer()}") < 400   # the spot, not the whole expression


def test_nesting_up_to_the_limit_evaluates_and_one_more_is_an_error():
    assert compile_filter("not " * 63 + "(latency)")(SLOW) is False     # 63 nots: an odd count negates
    assert compile_filter("(" * 64 + "latency > 0.05" + ")" * 64)(SLOW) is True
    with pytest.raises(FilterError) as info:
        compile_filter("not " * 64 + "(latency)")
    assert info.value.column == 64 * 4 + 1   # the parenthesis is the 65th level


@pytest.mark.parametrize("expr", ['kind ==\n"ack" and', 'kind\t== "nack"', "latency >\r\n\x0b"],
                         ids=["newline", "tab", "cr lf vt"])
def test_an_error_message_is_one_line(expr):
    with pytest.raises(FilterError) as info:
        compile_filter(expr)
    line = f"--filter {info.value} in: {info.value.pointer()}"   # as the CLI prints it
    assert line.splitlines() == [line]
    assert "\\n" in line or "\\t" in line
