"""The generated sigrok decoder (analyzer/sigrok/decoder.py) read as Python: it
compiles, it carries every command of the table, and run outside
libsigrokdecode (a stand-in ``sigrokdecode`` module) it deframes and dissects
as gimbalscope does: the same events with the same deframing problems from
the sample captures' bytes, the same command codes, fields and summaries.
tests/integration/test_sigrok_decoder.py runs it in sigrok-cli."""

from __future__ import annotations

import os
import sys
import types

import pytest

import analyzer
from analyzer.output import summary
from analyzer.sigrok.decoder import init_source, pd_source
from dissectors import problems as P
from dissectors.commands import COMMANDS, field_types
from dissectors.deframer import Deframer
from dissectors.dissect import dissect_command

CAPTURES = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "captures")
DEFRAMING = (P.CHECKSUM, P.LENGTH, P.TRUNCATED, P.NOISE)


@pytest.fixture(scope="module")
def pd():
    """The generated pd.py as a module, over a stand-in for libsigrokdecode's module."""
    srd = types.ModuleType("sigrokdecode")

    class Decoder:
        def register(self, kind):
            return kind

        def put(self, ss, es, output, data):
            self.out.append((ss, es, output, data))

    srd.Decoder, srd.OUTPUT_ANN, srd.OUTPUT_PYTHON, srd.SRD_CONF_SAMPLERATE = Decoder, "ann", "python", 10000
    saved = sys.modules.get("sigrokdecode")
    sys.modules["sigrokdecode"] = srd
    try:
        module = types.ModuleType("gimbal_pd")
        exec(compile(pd_source(), "pd.py", "exec"), module.__dict__)   # noqa: S102 - our own decoder, as sigrok loads it
    finally:
        if saved is None:
            del sys.modules["sigrokdecode"]
        else:
            sys.modules["sigrokdecode"] = saved
    return module


def test_sources_compile():
    compile(pd_source(), "pd.py", "exec")
    compile(init_source(), "__init__.py", "exec")


def test_every_command_and_field_is_in_it(pd):
    assert [c["id"] for c in pd.COMMANDS] == [c.id for c in COMMANDS]
    text = pd_source()
    for c in COMMANDS:
        assert repr(c.id) in text
    carried = {f["name"] for c in pd.COMMANDS for layout in (c["layout"], *c["results"]) for f in layout["fields"]}
    assert carried <= set(field_types())
    assert carried == {f.name for c in COMMANDS for layout in (c.layout, *c.result) for f in layout.fields}


def _ours(pd, line: str, data: bytes) -> list[tuple]:
    out = []
    d = pd.LineDeframer(line, lambda kind, first, end, problem: out.append(
        (kind, first, end, [problem[1]] if problem else [])))
    for b in data:
        d.feed(b)
    d.finish()
    return out


def _theirs(line: str, data: bytes) -> list[tuple]:
    d = Deframer(line)
    events = d.feed(data) + d.finish()
    return [("frame" if ev.kind in ("command", "result", "frame") else ev.kind, ev.offset, ev.offset + len(ev.raw),
             [p for p in ev.problems if any(info.matches(p) for info in DEFRAMING)]) for ev in events]


@pytest.mark.parametrize("name, line", [("demo-ctl.bin", "A"), ("demo-dev.bin", "B"), ("demo-bus.bin", "AB")])
def test_deframes_as_gimbalscope(pd, name, line):
    with open(os.path.join(CAPTURES, name), "rb") as f:
        data = f.read()
    ours = _ours(pd, line, data)
    assert ours == _theirs(line, data)
    assert any(problems for *_, problems in ours)   # the samples do have broken frames and noise


@pytest.mark.parametrize("payload", [b"P?", b"P0FA0FC18", b"p0fa0fc18", b"C3", b"CA", b"L0", b"QQ", b"P0FA",
                                     b"*x1c,9600,8,1,0", b"*x1c,9600,8,1,7", b"GRP02", b"VM1", b"VMx", b"ZB",
                                     b"*x0tHELLO", b"*dAfoo", b"#05", b"#FF", b"LS123456789ABC"])
def test_dissects_commands_as_gimbalscope(pd, payload):
    entry, code, values, problems, _ = pd.dissect_command(payload)
    theirs = dissect_command(payload)
    assert (entry["id"] if entry else None, code, values) == (
        theirs.entry.id if theirs.entry else None, theirs.command, theirs.fields)
    assert [p[1] for p in problems] == list(theirs.problems)


def test_summaries_as_gimbalscope(pd):
    """Every command and result of the two-line sample: the text after the code is
    the one gimbalscope prints, the fields the same values."""
    by_id = {c["id"]: c for c in pd.COMMANDS}
    seen = set()
    for ev in analyzer.open(os.path.join(CAPTURES, "demo-ctl.bin"), os.path.join(CAPTURES, "demo-dev.bin")):
        if ev.kind == "command":
            entry, code, values, problems, _ = pd.dissect_command(ev.payload)
            assert (code, values) == (ev.command, ev.fields)
            problems = [(None, p) for p in ev.problems]   # the deframing's first, as the decoder has them
            assert pd.command_summary(entry, values, problems, ev.payload) == summary(ev)
        elif ev.kind == "result" and ev.entry is not None:
            values, problems, _ = pd.dissect_result(by_id[ev.entry.id], ev.payload)
            assert values == ev.fields
            assert pd.result_summary(by_id[ev.entry.id], values, ev.payload) == summary(ev)
        seen.add(ev.kind)
    assert {"command", "result"} <= seen


def _run(pd, packets, lines="tx-a-rx-b"):
    dec = pd.Decoder()
    dec.out = []
    dec.options = {"lines": lines, "frame_gap_ms": 0}
    dec.start()
    dec.metadata(10000, 1_000_000)
    for packet in packets:
        dec.decode(*packet)
    return [(ss, es, data) for ss, es, output, data in dec.out if output == "ann"]


def _bytes(rxtx, data, at, char=1042):
    return [(at + k * char, at + (k + 1) * char - 1, ["FRAME", rxtx, (b, True)]) for k, b in enumerate(data)]


def test_one_annotation_a_frame_spanning_it(pd):
    from dissectors.wire import build_frame
    cmd = build_frame((1, 1, 2), 0, "P?")
    res = build_frame((0, 1, 2), 1, "0FA0FC18")
    anns = _run(pd, _bytes(pd.TX, cmd, 0) + _bytes(pd.RX, b"\x06", 20_000) + _bytes(pd.RX, res, 30_000))
    frames = [(ss, es, data[1][0]) for ss, es, data in anns if data[0] <= 5]
    assert frames == [(0, 9 * 1042 - 1, "command P? 1.1.2 current position query"),
                      (20_000, 21_041, "ack P? 1.1.2"),
                      (30_000, 30_000 + 15 * 1042 - 1, "result P? 1.1.2 at az +40.00° el -10.00°")]
    fields = [(ss, es, data[1][0]) for ss, es, data in anns if data[0] == pd.FIELD_CLASS]
    assert (30_000 + 6 * 1042, 30_000 + 10 * 1042 - 1, "azimuth_deg=40.0 deg") in fields
    assert (30_000 + 10 * 1042, 30_000 + 14 * 1042 - 1, "elevation_deg=-10.0 deg") in fields
    assert (5 * 1042, 6 * 1042 - 1, "length=2") in fields   # the length byte alone


def test_a_silence_cuts_a_frame(pd):
    from dissectors.wire import build_frame
    cmd = build_frame((1, 1, 2), 0, "P0FA0FC18")
    # half a frame, 100 ms of silence (the gap at 1 MHz: 50 ms), then a whole one
    anns = _run(pd, _bytes(pd.TX, cmd[:8], 0) + _bytes(pd.TX, cmd, 200_000))
    texts = [data[1][0] for _, _, data in anns if data[0] in (0, 5, 7)]
    assert texts == ["noise 8 bytes: f8 01 01 02 00 09 50 30", "truncated frame: 8 of 16 bytes, then silence",
                     "command P 1.1.2 go to az +40.00° el -10.00°"]


def test_one_wire_pairs_as_gimbalscope(pd):
    """The single-line sample through the decoder: each event's kind, command,
    fields and problems are gimbalscope's, answers named by the command they
    answer (the pairing is the portable decoder's, analyzer/portable)."""
    with open(os.path.join(CAPTURES, "demo-bus.bin"), "rb") as f:
        data = f.read()
    dec = pd.Decoder()
    dec.out = []
    dec.options = {"lines": "single-line", "frame_gap_ms": 0}
    dec.start()
    dec.metadata(10000, 1_000_000)
    for k, b in enumerate(data):
        dec.decode(k * 10, k * 10 + 9, ["FRAME", pd.RX, (b, True)])
    dec.silence(pd.RX)
    events = [data for _, _, output, data in dec.out if output == "python"]
    ours = [(kind, info.get("command"), info.get("fields", {}), [p[1] for p in info.get("problems", [])])
            for kind, _line, info in events]
    exchange = (P.UNANSWERED, P.NO_RESULT, P.RETRANSMISSION, P.LATE)   # what only time tells
    theirs = [(ev.kind,
               ev.command if ev.kind in ("command", "result") else ev.transaction.command if ev.transaction else None,
               ev.fields or {}, [p for p in ev.problems if not any(info.matches(p) for info in exchange)])
              for ev in analyzer.open(os.path.join(CAPTURES, "demo-bus.bin"))]
    theirs = [(kind, "?" if kind == "result" and cmd is None else cmd, fields, problems)
              for kind, cmd, fields, problems in theirs]
    assert ours == theirs
