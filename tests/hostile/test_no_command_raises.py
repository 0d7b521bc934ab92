"""Property: no input file makes any command raise.

Files are random bytes, or the sample captures and a recording made from them,
damaged the ways real files get damaged (cut, bytes flipped, junk inserted, a
slice repeated) and sometimes compressed. Every command that takes a file must
end with exit 0, 1 or 2 and, when it fails, one ``gimbalscope: error:`` line:
never an exception. The commands run in this process (``main(argv)``), so an
exception reaches the test as itself, with its traceback.
"""

from __future__ import annotations

import bz2
import contextlib
import gzip
import io
import lzma
import math
import os
import shutil
import struct
import tempfile
from pathlib import Path

import orjson
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from analyzer.cli.main import main
from tests.conftest import ROOT

CAPTURES = os.path.join(ROOT, "captures")
SAMPLES = ("demo-socat.log", "demo-bus.bin", "demo-ctl.bin")
EXAMPLES = 2000 if os.environ.get("HYPOTHESIS_PROFILE") == "deep" else 60


class Stdout(io.TextIOWrapper):
    """A text stdout with a ``buffer``, as the JSON Lines sink writes bytes."""

    def __init__(self) -> None:
        super().__init__(io.BytesIO(), encoding="utf-8", errors="surrogateescape")


def run(argv: list[str]) -> tuple[int, str]:
    """Run the CLI in this process: (exit code, stderr)."""
    err = io.StringIO()
    with contextlib.redirect_stdout(Stdout()), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as e:   # argparse's own exits
            code = e.code if isinstance(e.code, int) else 2
    return code, err.getvalue()


@pytest.fixture(scope="module")
def corpus_dir():
    d = tempfile.mkdtemp(prefix="gimbal-hostile-")
    bases = {name: Path(CAPTURES, name).read_bytes() for name in SAMPLES}
    rec = os.path.join(d, "base.mcap")
    code, err = run(["convert", os.path.join(CAPTURES, "demo-socat.log"), "-o", rec])
    assert code == 0, err
    bases["base.mcap"] = Path(rec).read_bytes()
    yield d, bases
    shutil.rmtree(d, ignore_errors=True)


def damage(data: bytes, ops: list[tuple[str, int, bytes]]) -> bytes:
    """Apply cuts, flips, insertions and repeats at positions taken modulo the size."""
    buf = bytearray(data)
    for op, pos, junk in ops:
        at = pos % (len(buf) + 1)
        if op == "cut":
            del buf[at:]
        elif op == "flip" and buf:
            buf[at % len(buf)] ^= 1 << (pos % 8)
        elif op == "insert":
            buf[at:at] = junk
        elif op == "repeat":
            buf[at:at] = buf[at:at + 64]
    return bytes(buf)


COMPRESS = {"": lambda b: b, ".gz": gzip.compress, ".xz": lzma.compress, ".bz2": bz2.compress}

ops = st.lists(st.tuples(st.sampled_from(("cut", "flip", "insert", "repeat")),
                         st.integers(0, 1 << 20), st.binary(max_size=32)), max_size=4)


MAGIC = b"\x89MCAP0\r\n"
# values a foreign tool might put where we expect our raw chunk's keys
odd_values = st.one_of(st.none(), st.booleans(), st.integers(-(1 << 63), (1 << 63) - 1),
                       st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
                       st.sampled_from(("f801", "zz", "f8 01", "0" * 7)), st.lists(st.integers(0, 9), max_size=3))
foreign_payload = st.one_of(
    st.binary(max_size=40),
    st.dictionaries(st.sampled_from(("line", "offset", "t", "data", "x")), odd_values, max_size=5)
    .map(lambda d: orjson.dumps(d, option=orjson.OPT_NON_STR_KEYS) if all(
        not isinstance(v, float) or math.isfinite(v) for v in d.values()) else b"{}"))


def foreign_recording(payloads: list[bytes], topic: str) -> bytes:
    """An MCAP written by another tool on our raw topic name, with its own payloads."""
    from mcap.writer import Writer
    buf = io.BytesIO()
    w = Writer(buf)
    w.start()
    schema = w.register_schema("Other", "jsonschema", b"{}")
    ch = w.register_channel(topic, "json", schema)
    for k, data in enumerate(payloads):
        w.add_message(ch, log_time=k, data=data, publish_time=k)
    w.finish()
    return buf.getvalue()


records = st.lists(st.tuples(st.integers(0, 0x12), st.one_of(st.integers(0, 64), st.integers(0, (1 << 64) - 1)),
                             st.binary(max_size=64)), max_size=6)


def hand_made(recs: list[tuple[int, int, bytes]]) -> bytes:
    """MCAP magic, then records whose declared lengths need not match their bodies."""
    return MAGIC + b"".join(struct.pack("<BQ", op, n) + body for op, n, body in recs)


BAD_LINES = (b"junk", b"> 2026/13/45 25:61:61.000000  length=3 from=0 to=2",
             b"< 0000/00/00 00:00:00.000000  length=99999999999999999999 from=0 to=1",
             b" zz zz", b"\xff\xfe", b"> 2026/11/21 08:35:52.1  length=2 from=5 to=1")


def damage_lines(data: bytes, edits: list[tuple[int, int]]) -> bytes:
    lines = data.split(b"\n")
    for pos, which in edits:
        lines.insert(pos % (len(lines) + 1), BAD_LINES[which % len(BAD_LINES)])
    return b"\n".join(lines)


@st.composite
def hostile_file(draw):
    """(name, damage ops, bytes or None): a damaged sample, a hand-made or foreign
    MCAP, a socat log with bad lines, or random bytes under a capture's name."""
    kind = draw(st.sampled_from(("sample", "random", "records", "foreign", "lines")))
    if kind == "sample":
        return draw(st.sampled_from((*SAMPLES, "base.mcap"))), draw(ops), None
    if kind == "records":
        return "x.mcap", [], hand_made(draw(records))
    if kind == "foreign":
        topic = draw(st.sampled_from(("/serial/A/raw", "/serial/B/raw", "/serial/AB/raw")))
        return "x.mcap", [], foreign_recording(draw(st.lists(foreign_payload, max_size=5)), topic)
    if kind == "lines":
        base = Path(CAPTURES, "demo-socat.log").read_bytes()
        edits = draw(st.lists(st.tuples(st.integers(0, 1 << 16), st.integers(0, 99)), min_size=1, max_size=3))
        return "x.log", [], damage_lines(base, edits)
    return draw(st.sampled_from(("x.bin", "x.log", "x.mcap"))), [], draw(st.binary(max_size=2048))


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spec=hostile_file(), suffix=st.sampled_from(tuple(COMPRESS)))
def test_no_command_raises_on_any_file(corpus_dir, spec, suffix):
    d, bases = corpus_dir
    name, damage_ops, raw = spec
    data = damage(bases[name], damage_ops) if raw is None else raw
    path = os.path.join(d, "in-" + name + suffix)
    with open(path, "wb") as f:
        f.write(COMPRESS[suffix](data))
    out = os.path.join(d, "out.mcap")
    commands = [["decode", path, "--format", "jsonl"], ["decode", path], ["stats", path],
                ["doctor", path], ["convert", path, "-o", out, "--force"]]
    if name.endswith(".mcap"):
        commands += [["replay", path, "--no-tui", "--speed", "max"],
                     ["recover", path, "-o", os.path.join(d, "rec.mcap"), "--force"]]
    for argv in commands:
        code, err = run(argv)
        # 3: the doctor's error-level findings (docs/doctor.md, "Exit status"), no failure
        assert code in ((0, 1, 2, 3) if argv[0] == "doctor" else (0, 1, 2)), (argv, code, err)
        errors = [line for line in err.splitlines() if line.startswith("gimbalscope: error:")]
        assert len(errors) <= 1, (argv, err)
        if code == 2:
            assert errors, (argv, err)
