"""``gimbalscope doctor`` on captures of a link read at the wrong rate and of input
that is no frame of this protocol, end to end (docs/doctor.md, "Wrong rate or not
this protocol", "Exit status"). The captures are made by the encoder and the UART
of tests/pure/test_doctor_rate.py, from the docs' wire format, not by the product."""

from __future__ import annotations

import json
import random

import pytest

from analyzer.analysis.findings import NO_FRAMES, NOT_THIS_PROTOCOL, WRONG_BAUD
from tests.conftest import run_cli
from tests.pure.test_doctor_rate import polling, socat_log, tapped

ERROR_STATUS, WARNING_STATUS = 3, 1    # docs/doctor.md, "Exit status"


def report(*args) -> tuple[dict, int]:
    r = run_cli("doctor", *args, "--format", "json")
    assert r.returncode in (0, 1, 3), r.stderr
    return json.loads(r.stdout), r.returncode


@pytest.mark.parametrize("read", [19200, 4800])
def test_a_socat_log_read_at_the_wrong_rate_names_the_lines_rate(tmp_path, read):
    log = tmp_path / "tap.log"
    log.write_text(socat_log(tapped(polling(), 9600, read)))
    # --baud: the rate socat read at (a socat log does not record it)
    found, status = report(log, "--baud", read)
    assert status == ERROR_STATUS
    codes = sorted((f["code"], f["subject"]) for f in found["findings"])
    assert codes == [(WRONG_BAUD, "A"), (WRONG_BAUD, "B")], found["findings"]
    for f in found["findings"]:
        assert (f["measured"]["baud"], f["measured"]["read"]) == (9600, read)
        # the fix says to capture again at the line's rate: these bytes cannot be decoded
        assert "--baud 9600" in f["fix"] and "--baud RATE" not in f["fix"]
    text = run_cli("doctor", log, "--baud", read)
    assert "no problems found" not in text.stdout and "not traffic of this protocol" not in text.stdout


def test_a_capture_of_56_bytes_of_text_says_what_it_holds(tmp_path):
    log = tmp_path / "console.log"
    line = b"Hello from the bench PC, this is not gimbal traffic.\r\n"
    log.write_text(socat_log([("A", 0.0, line), ("A", 0.5, b"OK")]))
    found, status = report(log)
    assert status == WARNING_STATUS
    assert [(f["code"], f["subject"], f["measured"]) for f in found["findings"]] == \
        [(NO_FRAMES, "A", {"looks": "text", "bytes": 56})]
    text = run_cli("doctor", log)
    assert text.returncode == WARNING_STATUS and "no problems found" not in text.stdout
    assert "56 bytes on line A" in text.stdout


def test_an_empty_capture_is_not_no_problems(tmp_path):
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    text = run_cli("doctor", empty)
    assert text.returncode == WARNING_STATUS and "no problems found" not in text.stdout, text.stdout


def test_random_bytes_on_one_line_stay_not_this_protocol(tmp_path):
    rng = random.Random(4)
    dump = tmp_path / "junk.bin"
    dump.write_bytes(bytes(rng.randrange(256) for _ in range(3000)))
    found, status = report(dump)
    assert status == ERROR_STATUS
    assert [f["code"] for f in found["findings"]] == [NOT_THIS_PROTOCOL]
    assert found["findings"][0]["measured"]["looks"] == "binary"
