"""The --filter language: semantics over the JSON names, and errors that point
at the bad token. It never evaluates Python."""

import pytest

from analyzer.filter import FilterError, compile_filter
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
