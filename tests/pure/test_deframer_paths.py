"""The C deframing loop (dissectors/_deframe.c) against the pure-Python loop it stands
in for: the same events, field by field, for any bytes in any split; and the
environment switch that selects the pure loop."""

import contextlib
import itertools
import os
import subprocess
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dissectors import Deframer
from dissectors.deframer import COMPILED, use_compiled_loop
from dissectors.event import Event

compiled = pytest.mark.skipif(not COMPILED,
                              reason="the C deframing loop is not built (no compiler at install, or GIMBALSCOPE_PURE=1)")


def frame(dst, src, payload: bytes) -> bytes:
    """Built by hand (Table 1: checksum = sum of G through the payload, mod 256)."""
    body = bytes([*dst, src, len(payload) & 0xFF]) + payload
    return b"\xf8" + body + bytes([sum(body) & 0xFF])


@contextlib.contextmanager
def pure_loop(pure: bool = True):
    """Deframe with the pure-Python code while inside (``pure``), the C parts put back after."""
    before = use_compiled_loop(not pure)
    try:
        yield
    finally:
        use_compiled_loop(before)


def events(data: bytes, line: str, cuts: list[int], pure: bool, times: list[float] | None = None,
           byte_time: float = 0.0) -> list[Event]:
    """Deframe ``data`` fed in pieces cut at ``cuts``; ``times``: each piece's time
    (timed input), taken in turn."""
    with pure_loop(pure):
        d = Deframer(line, byte_time=byte_time)
        out, pos = [], 0
        for k, cut in enumerate(sorted(cuts) + [len(data)]):
            if cut > pos:
                t = None if times is None else times[k % len(times)]
                out += d.feed(data[pos:cut], t)
                pos = cut
        return out + d.finish()


def facts(ev: Event) -> tuple:
    return tuple(getattr(ev, name) for name in Event.__slots__)


tokens = st.one_of(
    st.builds(frame, st.tuples(*[st.integers(0, 255)] * 3), st.integers(0, 255),
              st.binary(min_size=1, max_size=40)),                                   # valid frames
    st.builds(lambda f, k: f[:-1] + bytes([(f[-1] + k) & 0xFF]),
              st.builds(frame, st.just((1, 1, 1)), st.just(0), st.binary(min_size=1, max_size=12)),
              st.integers(1, 255)),                                                  # bad checksums
    st.sampled_from([b"\x06", b"\x15", b"\x3f", b"\xf8", b"\xf8\x01\x01"]),        # simple bytes, stray starts
    st.binary(min_size=1, max_size=8),                                               # noise
)


@compiled
@settings(max_examples=300, deadline=None)
@given(st.lists(tokens, max_size=30), st.sampled_from(["A", "B", "AB"]), st.lists(st.integers(0, 400), max_size=6))
def test_compiled_loop_gives_the_pure_loops_events(parts, line, cuts):
    data = b"".join(parts)
    fast = events(data, line, cuts, pure=False)
    slow = events(data, line, cuts, pure=True)
    assert [facts(e) for e in fast] == [facts(e) for e in slow]


@compiled
@settings(max_examples=300, deadline=None)
@given(st.lists(tokens, max_size=30), st.sampled_from(["A", "B", "AB"]), st.lists(st.integers(0, 400), max_size=6),
       st.lists(st.floats(0, 100, allow_nan=False), min_size=1, max_size=7),
       st.sampled_from([1 / 9600 * 10, 1 / 115200 * 10, 0.0]))
def test_compiled_loop_gives_the_pure_loops_times(parts, line, cuts, times, byte_time):
    # chunks read at any times (earlier than the line allows too: the deframer
    # places them), at any rate; silences cut frames, so both loops meet them
    data = b"".join(parts)
    fast = events(data, line, cuts, pure=False, times=times, byte_time=byte_time)
    slow = events(data, line, cuts, pure=True, times=times, byte_time=byte_time)
    assert [facts(e) for e in fast] == [facts(e) for e in slow]
    assert [(type(e.t), type(e.t_end)) for e in fast] == [(type(e.t), type(e.t_end)) for e in slow]


@compiled
@settings(max_examples=300, deadline=None)
@given(st.lists(tokens, min_size=1, max_size=30), st.sampled_from(["A", "B", "AB"]),
       st.lists(st.floats(0, 100, allow_nan=False), min_size=1, max_size=7),
       st.sampled_from([1 / 9600 * 10, 1 / 115200 * 10, 0.0]), st.booleans())
def test_one_token_a_read_gives_the_pure_events(parts, line, times, byte_time, timed):
    # a recording or a live port: each read is usually one whole token, which
    # the C code turns into its event directly (_deframe.c, whole)
    data = b"".join(parts)
    cuts = list(itertools.accumulate(len(p) for p in parts))[:-1]
    times = times if timed else None
    fast = events(data, line, cuts, pure=False, times=times, byte_time=byte_time)
    slow = events(data, line, cuts, pure=True, times=times, byte_time=byte_time)
    assert [facts(e) for e in fast] == [facts(e) for e in slow]
    assert [(type(e.t), type(e.t_end)) for e in fast] == [(type(e.t), type(e.t_end)) for e in slow]


@compiled
def test_compiled_events_carry_the_wire_facts():
    # §1.4.1: F8 G P D S L payload C; a result from 0.1.2 (source group 1) on line B, then an ACK
    res = frame((0, 1, 2), 1, b"0FA0FC18")
    evs = events(res + b"\x06", "B", [], pure=False)
    assert [(e.kind, e.offset, e.raw) for e in evs] == [("result", 0, res), ("ack", len(res), b"\x06")]
    r = evs[0]
    assert (r.dst, r.src, r.payload, r.checksum_ok, r.t, r.t_end) == ((0, 1, 2), 1, b"0FA0FC18", True, None, None)
    # the defaults of Event's own __init__: nothing paired or dissected yet
    assert (r.number, r.command, r.fields, r.problems, r.txn, r.status, r.transaction) == (0, None, {}, (), None,
                                                                                          None, None)
    assert r.device == "1.1.2"   # a result's device: source group, port and device kept (Table 3)


@compiled
def test_compiled_events_are_timed_from_the_byte_time():
    # 9600 8N1: 10 bits a byte. Two P? commands (9 bytes each) read at t = 2.0 s: the
    # first starts at 2.0 and its last byte ends 9 byte times later, the second
    # follows it; two ACKs on line B read at 3.0 take one byte time each
    bt = 10 / 9600
    cmd = frame((1, 1, 1), 0, b"P?")
    evs = events(cmd + cmd, "A", [], pure=False, times=[2.0], byte_time=bt)
    assert [(e.t, e.t_end) for e in evs] == [(2.0, 2.0 + 9 * bt), (2.0 + 9 * bt, 2.0 + 18 * bt)]
    two = events(b"\x06\x06", "B", [], pure=False, times=[3.0], byte_time=bt)
    assert [(e.t, e.t_end) for e in two] == [(3.0, 3.0 + bt), (3.0 + bt, 3.0 + 2 * bt)]
    # one read one token: a result read at 4.0 (15 bytes), then an ACK read on its own
    res = frame((0, 1, 1), 1, b"0FA0FC18")
    one = events(res + b"\x06", "B", [len(res)], pure=False, times=[4.0, 5.0], byte_time=bt)
    assert [(e.kind, e.t, e.t_end) for e in one] == [("result", 4.0, 4.0 + 15 * bt), ("ack", 5.0, 5.0 + bt)]
    # a time given as an int (by hand through the API) stays an int, as Python's arithmetic keeps it
    whole_int = events(b"\x06", "B", [], pure=False, times=[3], byte_time=0)
    assert [(e.t, type(e.t)) for e in whole_int] == [(3, int)]


def test_pure_switch_in_the_environment():
    code = "import dissectors.deframer as d; print(d.COMPILED)"
    env = dict(os.environ, GIMBALSCOPE_PURE="1")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@compiled
@pytest.mark.parametrize("inputs", [["demo-ctl.bin", "demo-dev.bin"], ["demo-bus.bin"], ["demo-socat.log"]])
def test_decode_output_is_the_same_on_both_paths(inputs):
    here = os.path.dirname(os.path.abspath(__file__))
    paths = [os.path.join(here, "..", "..", "captures", name) for name in inputs]
    cmd = [sys.executable, "-m", "analyzer", "decode", *paths, "--format", "jsonl"]
    compiled_out = subprocess.run(cmd, capture_output=True, check=True).stdout
    pure_out = subprocess.run(cmd, capture_output=True, check=True,
                              env=dict(os.environ, GIMBALSCOPE_PURE="1")).stdout
    assert compiled_out.count(b"\n") > 10
    assert compiled_out == pure_out
