"""The wiring signs a recording keeps with its stored columns (docs/mcap.md):
their state, written as JSON and read back, is the state the events left, and
says the same findings."""

from __future__ import annotations

import orjson
import pytest

import analyzer
from analyzer.analysis.signs import WiringSigns
from analyzer.simulation.traffic import generate
from tests.conftest import BUS, CTL, DEV, SOCAT_LOG


def signs_of(events, lines) -> WiringSigns:
    signs = WiringSigns(lines)
    for ev in events:
        signs.add(ev)
    return signs


def findings(signs: WiringSigns) -> list:
    return [(f.code, f.title, f.detail) for f in signs.findings("swap them", "try --baud", False)]


@pytest.mark.parametrize("paths", [(CTL, DEV), (DEV, CTL), (SOCAT_LOG,), (BUS,)], ids=lambda p: "+".join(p))
def test_the_state_read_back_is_the_state_and_says_the_same(paths):
    capture = analyzer.open(*paths)
    events = list(capture)
    signs = signs_of(events, capture.lines)
    again = WiringSigns.of_state(capture.lines, orjson.loads(orjson.dumps(signs.state())))
    assert again.state() == signs.state()
    assert findings(again) == findings(signs)
    if paths == (DEV, CTL):   # the dumps given the other way round: the check says so
        assert any("swapped" in title for _id, title, _d in findings(signs))


def test_a_garbled_line_read_back_is_the_same_state(tmp_path):
    tr = generate(400, baud=9600, seed=3, bit_error_rate=0.05, noise_rate=0.1)
    (tmp_path / "bus.bin").write_bytes(tr.single_line())
    capture = analyzer.open(str(tmp_path / "bus.bin"), baud=19200)   # read at the wrong rate: noise, samples
    signs = signs_of(list(capture), capture.lines)
    assert signs.state()["lines"]["AB"]["sample"]   # bytes that did not decode, kept
    again = WiringSigns.of_state(capture.lines, orjson.loads(orjson.dumps(signs.state())))
    assert again.state() == signs.state() and findings(again) == findings(signs)


def test_a_state_that_does_not_read_raises_a_value_or_key_error():
    with pytest.raises((KeyError, TypeError, ValueError)):
        WiringSigns.of_state(("A", "B"), {"lines": {}})
