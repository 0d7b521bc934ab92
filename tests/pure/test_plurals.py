"""Counts read as English: "1 device address", "3 device addresses", never
"address(es)" or "(s)" (analyzer/words.py words them)."""

import ast
import os
import re
from types import SimpleNamespace

import numpy as np

from analyzer.analysis.doctor import DeviceTally, WiringDoctor, waveform_findings
from analyzer.analysis.findings import (
    CLOCK_OFF,
    CONTROLLER_IX_TIMEOUT,
    CONTROLLER_NO_RETRY,
    DEAD_LINK,
    DEVICE_MAP,
    FRAMING_ERRORS,
    LINE_INVERTED,
    LINES_SWAPPED,
    SILENT_AFTER_RATE,
    WRONG_BAUD,
)
from analyzer.analysis.signs import WiringSigns
from analyzer.output import summary
from analyzer.physical.edges import PackedSamples
from analyzer.physical.report import LineReport
from analyzer.sources.base import ReadSettings
from analyzer.sources.mcapwalk import Damaged, chunk_parts
from analyzer.sources.sampled import SampledSource
from tests.conftest import ROOT
from tests.pure.test_doctor import findings_of, polls
from tests.pure.test_problems import cmd, decode

# Lua source held in a Python string, where f(s) is a call, not a plural
LUA = os.path.join(ROOT, "analyzer", "wireshark", "lua.py")


def test_the_device_map_counts_addresses_and_commands_in_english(tmp_path):
    one = tmp_path / "one.log"
    one.write_text(polls(rounds=1).socat_log())            # one P? to 1.1.1
    found = findings_of(one)[DEVICE_MAP]
    assert found.title == "1 device addressed"
    assert found.detail == "1.1.1: 1 command, answers on B"
    three = tmp_path / "three.log"
    three.write_text(polls(rounds=3).socat_log())          # P? to 1.1.1, 1.1.2, 1.1.1
    found = findings_of(three)[DEVICE_MAP]
    assert found.title == "2 devices addressed"
    assert found.detail.splitlines() == ["1.1.1: 2 commands, answers on B", "1.1.2: 1 command, answers on B"]


def _strings(tree):
    """The string constants of a module but its docstrings (a bare string statement)."""
    bare = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in bare:
            yield node.lineno, node.value


def test_no_message_counts_with_an_optional_plural():
    hedged = re.compile(r"[a-z]\(e?s\)")
    found = [f"{where}:{line}: {text!r}" for where, tree in _analyzer_modules() for line, text in _strings(tree)
             if hedged.search(text)]
    assert found == []


def _analyzer_modules():
    """(path, syntax tree) of each module of analyzer/ (the generated Lua's template left out)."""
    for folder, _, files in os.walk(os.path.join(ROOT, "analyzer")):
        for name in files:
            path = os.path.join(folder, name)
            if name.endswith(".py") and path != LUA:
                with open(path, encoding="utf-8") as f:
                    yield os.path.relpath(path, ROOT), ast.parse(f.read())


def _ad_hoc_plurals(tree):
    """f-strings that pluralise by hand: ``{'' if n == 1 else 's'}``."""
    for node in ast.walk(tree):
        if isinstance(node, ast.FormattedValue) and isinstance(node.value, ast.IfExp):
            ends = {getattr(node.value.body, "value", None), getattr(node.value.orelse, "value", None)}
            if ends in ({"", "s"}, {"", "es"}):
                yield node.lineno


def test_no_message_pluralises_by_hand():
    # analyzer/ words every count with analyzer/words.py (dissectors/, the layer
    # below it, cannot import it, and keeps its own)
    found = [f"{where}:{line}" for where, tree in _analyzer_modules() for line in _ad_hoc_plurals(tree)]
    assert found == []


# ------------------------------------------------------------------ the waveform's findings
def _waveform(**counts) -> dict:
    r = LineReport("A", "0", samplerate=1e6, **counts)
    return {f.code: f for f in waveform_findings("A", r)}


def test_a_line_of_one_character_counts_it_in_the_singular():
    found = _waveform(characters=1, inverted=True, framing_errors=1, breaks=1, first_error=0.25)
    assert found[LINE_INVERTED].detail == "its 1 character read with the levels inverted"
    # a break has no value: it is no character, so it is not counted "in" them
    assert found[FRAMING_ERRORS].title == "line A: 1 framing error in 1 character, and 1 break"


def test_the_clock_is_measured_over_characters_said_once():
    found = _waveform(characters=402, measured=10_000.0, nominal=9600)
    assert found[CLOCK_OFF].detail.startswith("nominal 9600 bit/s, measured over 402 characters; UARTs")


def test_breaks_alone_are_counted_separately_from_the_characters():
    found = _waveform(characters=402, breaks=40_298, first_error=None)
    assert found[FRAMING_ERRORS].title == "line A: 40,298 breaks"
    found = _waveform(characters=20, framing_errors=2, parity_errors=1, breaks=3, parity="E")
    assert found[FRAMING_ERRORS].title == "line A: 2 framing errors and 1 parity error in 20 characters, and 3 breaks"


# ------------------------------------------------------------------ the wiring signs and the doctor's rules
def test_a_garbled_line_counts_one_noise_byte_and_one_bad_frame():
    signs = WiringSigns(("A", "B"))
    a = signs.lines["A"]
    a.bytes, a.good_bytes, a.noise_bytes, a.frames, a.bad_frames = 200, 2, 1, 1, 1
    (f,) = signs.garbled("give --baud", live=True)
    assert f.code == WRONG_BAUD
    assert f.detail == "200 bytes, 1% in valid frames or answers, 1 byte of noise, 1 frame with a bad checksum"


def test_swapped_lines_count_one_command_frame_and_one_answer():
    signs = WiringSigns(("A", "B"))
    for n in range(6):
        signs.answer_bytes_on_a.add(n)
    signs.commands_on_b.add(9)
    signs.ok_transactions = 1
    (f,) = signs.swapped("--swap-lines")
    assert f.code == LINES_SWAPPED
    assert f.detail == ("6 ACK/NAK/NIC bytes arrived on line A and 1 command frame on line B; "
                        "1 command answered as wired")


def test_the_controller_and_a_dead_link_count_ones_in_the_singular():
    doctor = WiringDoctor()
    controller = doctor.controller
    for n in range(3):
        controller.never_retried.add(n)
    controller.retried = 1
    controller.ix_given_up.add(7)
    found = {f.code: f for f in controller.findings(p95=0.0)}
    assert found[CONTROLLER_NO_RETRY].detail == "3 commands NAK'd or unanswered were not sent again (1 was)"
    assert found[CONTROLLER_IX_TIMEOUT].detail.startswith("1 IX command was sent again before its result came;")
    doctor.commands = 5
    doctor.signs.lines["B"].bytes = 1
    found = {f.code: f for f in doctor.findings()}
    assert found[DEAD_LINK].detail == "5 commands, no ACK or NAK; line B carries 1 byte but no answer to a command"


def test_a_device_silent_after_a_rate_change_answered_once():
    doctor = WiringDoctor()
    dev = doctor.devices["1.1.1"] = DeviceTally()
    dev.commands_since_rate, dev.answers = 3, 1
    doctor.rate_change = (SimpleNamespace(fields={"baud": 19200, "previous_baud": 9600}, number=5), 4, "1.1.1")
    (f,) = [f for f in doctor.findings() if f.code == SILENT_AFTER_RATE]
    # rates as the spec writes them (no thousands separator), like the title's
    assert f.detail == "3 commands to 1.1.1 since the rate change, no ACK or NAK; it answered 1 time at 9600 bps before"


# ------------------------------------------------------------------ inputs and events
def test_a_header_cut_after_one_byte_and_a_noise_byte_are_one_byte():
    (ev,) = decode((0.0, "A", cmd("P0FA0FC18")[:1]))        # the start byte alone
    assert ev.problems == ["truncated frame: header cut after 1 byte"]
    (noise,) = decode((0.0, "A", b"\x00"))
    assert summary(noise) == "1 byte: 00"


def test_a_chunk_header_of_one_byte_is_one_byte():
    try:
        chunk_parts(b"x", False)
    except Damaged as e:
        assert str(e) == "its header is cut short (1 byte)"
    else:
        raise AssertionError("a one-byte chunk header read")


def test_a_line_of_one_edge_says_so_in_the_singular():
    # D0 falls once: it toggles, and shows no rate
    samples = np.array([1] * 1000 + [0] * 1000, dtype=np.uint8).tobytes()
    source = SampledSource(PackedSamples(iter([samples]), 1, ["D0"], 1e6, name="one.bin"), ReadSettings(10 / 9600),
                           "one.bin (logic samples)")
    said: list[str] = []
    source.report_to(said.append)
    assert [c for c in source.chunks() if c.data] == []
    assert said == ["one.bin: line AB (D0): no bit rate in its 1 edge; give it with --baud"]
