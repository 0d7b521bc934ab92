"""A bad --filter on the command line: one line on standard error with the fix,
exit status 2, nothing on standard output, no traceback; Wireshark's
``gimbal.`` prefix selects what the plain name does (docs/filters.md, "Mistakes")."""

import json

import pytest

from tests.conftest import BUS, run_cli


@pytest.mark.parametrize("command,expr,line", [
    ("decode", "status == nak",
     ("gimbalscope: error: --filter column 11: unknown name 'nak'; text goes in quotes: "
      "did you mean status == \"nak\"? in: status == >>>nak")),
    ("decode", 'status = "nak"',
     ("gimbalscope: error: --filter column 8: unexpected character '='; did you mean status == \"nak\"? "
      "in: status >>>= \"nak\"")),
    ("stats", "azimuth > 10",
     ("gimbalscope: error: --filter column 1: unknown name 'azimuth'; the unit is part of the name: "
      "did you mean azimuth_deg > 10? in: >>>azimuth > 10")),
])
def test_a_bad_filter_is_one_line_with_its_fix(command, expr, line):
    r = run_cli(command, BUS, "-Y", expr)
    assert r.returncode == 2
    assert r.stdout == ""
    assert r.stderr == line + "\n"


def test_the_wireshark_prefix_selects_the_same_events():
    plain = run_cli("decode", BUS, "--format", "jsonl", "-Y", 'status == "nak"')
    prefixed = run_cli("decode", BUS, "--format", "jsonl", "-Y", 'gimbal.status == "nak"')
    assert plain.returncode == prefixed.returncode == 0
    rows = [json.loads(line) for line in prefixed.stdout.splitlines()]
    assert rows and all(row["status"] == "nak" for row in rows)
    assert prefixed.stdout == plain.stdout
