"""Every count a finding states is of the thing it names, bounded by its whole,
and worded once: "12 of 402 characters", never "40,298 of 402 characters" or
"402 characters characters" (analyzer/analysis/findings.py's table, filled by
the doctor's rules; the waveform's counts come from the software UART,
analyzer/physical/uart.py).

The waveforms here are built bit by bit and their counts worked out by hand."""

from __future__ import annotations

import ast
import os
import re
from dataclasses import replace
from os.path import commonprefix

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from analyzer.analysis import findings
from analyzer.analysis.doctor import waveform_findings
from analyzer.analysis.findings import FINDINGS, FRAMING_ERRORS, TABLE, TWO_DRIVERS
from analyzer.physical.bitrate import named_rate
from analyzer.physical.charformat import LineFormat
from analyzer.physical.edges import Edges
from analyzer.physical.report import LineReport
from analyzer.physical.uart import SoftUart
from tests.conftest import ROOT
from tests.waveforms import uart_levels

# ------------------------------------------------------------------ reading the words
# a count: 7, 402, 40,298 (never a part of 25.6 or 0.003970)
_COUNT = r"(?<![\d.,])(?:\d{1,3}(?:,\d{3})+|\d+)(?![\d]|[.,]\d)"
# "N of M", "N in M", "N among M" where M counts things (not "in 60 s", "in 3.2 ms")
_WHOLE = re.compile(rf"\b(?:of|in|among) ({_COUNT})(?! ?(?:%|s\b|ms\b|µs\b|bit/s|bps\b|min\b))")
_CLAUSE = re.compile(r"[:;(\n]")


def _number(text: str) -> int:
    return int(text.replace(",", ""))


def parts_over_wholes(text: str) -> list[tuple[int, int, str]]:
    """Each "N of M" / "N in M" / "N among M" of ``text``: (the counts the clause
    states before the whole, summed; the whole; the clause). "2 framing errors and
    1 parity error in 20 characters" is (3, 20, ...)."""
    out = []
    for m in _WHOLE.finditer(text):
        start = max((c.end() for c in _CLAUSE.finditer(text, 0, m.start())), default=0)
        clause = text[start:m.end()]
        counts = [_number(n) for n in re.findall(_COUNT, text[start:m.start()])]
        if counts:
            out.append((sum(counts), _number(m.group(1)), clause.strip()))
    return out


def _same_stem(a: str, b: str) -> bool:
    a, b = a.lower(), b.lower()
    shared = len(commonprefix([a, b]))
    return shared >= 4 and shared >= min(len(a), len(b)) - 2


def doubled_words(text: str) -> list[str]:
    """Neighbouring words that are one word, or one stem: "characters characters",
    "addresses addressed"."""
    return [f"{a} {b}" for a, b in re.findall(r"(?=\b([A-Za-z]{3,})\s+([A-Za-z]{3,})\b)", text)
            if _same_stem(a, b)]


def test_the_readers_see_what_users_saw():
    assert parts_over_wholes("line A: two senders at once: 40,298 of 402 characters have edges") == \
        [(40298, 402, "40,298 of 402")]
    assert parts_over_wholes("2 framing errors and 1 parity error in 20 characters, and 3 breaks") == \
        [(3, 20, "2 framing errors and 1 parity error in 20")]
    assert parts_over_wholes("3 checksum errors and 2 noise runs in 60 s (3.0/min)") == []
    # a decimal is no count: 25.6 µs is not 25 and 6
    assert parts_over_wholes("2 pulses under 25.6 µs among 4,000 edges") == \
        [(2, 4000, "2 pulses under 25.6 µs among 4,000")]
    assert re.findall(_COUNT, "25.6 µs, first at 0.003970 s, line AB") == []
    assert doubled_words("nominal 9600 bit/s, measured over 402 characters characters; UARTs") == \
        ["characters characters"]
    assert doubled_words("4 device addresses addressed") == ["addresses addressed"]
    assert doubled_words("line A: 12 of 32 characters have edges off the bit grid") == []


def _texts(f) -> list[str]:
    return [f.title, f.detail, f.fix]


# ------------------------------------------------------------------ the waveform's rules, on any consistent counts
@st.composite
def line_reports(draw) -> LineReport:
    """A LineReport whose counts could come from a line: errors among the
    characters, off-grid characters among them, two edges to each glitch."""
    characters = draw(st.integers(0, 2_000_000))
    framing = draw(st.integers(0, characters))
    parity_letter = draw(st.sampled_from("NEOMS"))
    parity = draw(st.integers(0, characters - framing)) if parity_letter != "N" else 0
    glitches = draw(st.integers(0, 500_000))
    edges = 2 * glitches + draw(st.integers(0, 2_000_000))
    measured = draw(st.none() | st.floats(50, 4_000_000))
    rate_given = draw(st.booleans())
    nominal = (draw(st.sampled_from([9600, 115200, 250000])) if rate_given
               else named_rate(measured) if measured else None)
    return LineReport(
        "A", "0", samplerate=1e6, measured=measured, nominal=nominal, given=rate_given,
        inverted=draw(st.booleans()), data_bits=draw(st.integers(5, 9)), parity=parity_letter,
        stop_bits=draw(st.sampled_from([1, 1.5, 2])), edges=edges, characters=characters,
        framing_errors=framing, parity_errors=parity, breaks=draw(st.integers(0, 2_000_000)),
        glitches=glitches, off_grid=draw(st.integers(0, characters)),
        first_error=draw(st.floats(0, 1e5)) if framing + parity else None)


@settings(max_examples=400, deadline=None)
@given(line_reports())
def test_every_waveform_finding_counts_a_part_of_its_whole_in_words_said_once(r):
    for f in waveform_findings("A", r):
        for text in _texts(f):
            for part, whole, clause in parts_over_wholes(text):
                assert part <= whole, f"{f.code}: {clause!r} in {text!r}"
            assert doubled_words(text) == [], f"{f.code}: {text!r}"


@settings(max_examples=200, deadline=None)
@given(line_reports())
def test_two_senders_and_framing_errors_state_the_counts_of_the_report(r):
    found = {f.code: f for f in waveform_findings("A", r)}
    if TWO_DRIVERS in found:
        assert found[TWO_DRIVERS].detail == \
            f"{r.off_grid:,} of {r.characters:,} characters have edges off the bit grid"
    if FRAMING_ERRORS in found:
        title = found[FRAMING_ERRORS].title
        if r.breaks:
            assert title.endswith(f"{r.breaks:,} break{'s' if r.breaks != 1 else ''}")
        if r.framing_errors + r.parity_errors:
            assert f" in {r.characters:,} character" in title


# ------------------------------------------------------------------ every template and phrase of the table
def _templates():
    for kind in TABLE:
        for name, text in (("title", kind.title), ("detail", kind.detail), ("fix", kind.fix), *kind.phrases.items()):
            yield kind, name, text


def test_no_template_or_phrase_doubles_a_word_of_its_own():
    for kind, name, text in _templates():
        words = re.sub(r"\{[^}]*\}", " X ", text)
        assert doubled_words(words) == [], f"{kind.id} {name}: {text!r}"


def _counted_fields() -> list[tuple[str, object, str | None, str, list[str]]]:
    """Every field a rule of doctor.py or signs.py fills with ``counted(n, noun)``
    (in the call, or through a local set to it): (where, the table entry, the
    phrase or None for the finding, the field, the noun's words singular and
    plural)."""
    out = []
    for module in ("doctor.py", "signs.py"):
        with open(os.path.join(ROOT, "analyzer", "analysis", module), encoding="utf-8") as f:
            tree = ast.parse(f.read())

        def nouns(node):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "counted":
                words = [a.value for a in node.args[1:] if isinstance(a, ast.Constant)]
                return words + [words[0] + "s"] if len(words) == 1 else words
            return None

        for fn in (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)):
            local_nouns = {t.id: w for a in ast.walk(fn) if isinstance(a, ast.Assign) and (w := nouns(a.value))
                           for t in a.targets if isinstance(t, ast.Name)}
            local_kinds = {t.id: FINDINGS[getattr(findings, a.value.slice.id)] for a in ast.walk(fn)
                           if isinstance(a, ast.Assign) and isinstance(a.value, ast.Subscript)
                           and getattr(a.value.value, "id", None) == "FINDINGS"
                           for t in a.targets if isinstance(t, ast.Name)}
            for call in ast.walk(fn):
                if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute)
                        and call.func.attr in ("found", "phrase")):
                    continue
                owner = call.func.value
                kind = (FINDINGS[getattr(findings, owner.slice.id)] if isinstance(owner, ast.Subscript)
                        else local_kinds.get(getattr(owner, "id", None)))
                if kind is None:
                    continue
                phrase = call.args[0].value if call.func.attr == "phrase" and isinstance(call.args[0], ast.Constant) \
                    else None
                for k in call.keywords:
                    words = nouns(k.value) or (local_nouns.get(k.value.id) if isinstance(k.value, ast.Name) else None)
                    if words:
                        out.append((f"{module}:{call.lineno}", kind, phrase, k.arg, words))
    return out


def test_a_counted_field_is_not_followed_or_led_by_its_own_noun():
    # "{characters} characters" with characters = counted(n, "character") reads
    # "402 characters characters"; "{devices} addressed" with "device addresses",
    # "4 device addresses addressed"
    fields = _counted_fields()
    assert {(kind.id, field) for _w, kind, _p, field, _n in fields} >= {
        ("clock_off", "characters"), ("device_map", "devices"), ("wrong_baud", "bad_frames")}
    for where, kind, phrase, field, words in fields:
        texts = [kind.phrases[phrase]] if phrase else [kind.title, kind.detail, kind.fix]
        for text in texts:
            for m in re.finditer(r"(\w+)?\W*\{" + re.escape(field) + r"(?:[:!][^}]*)?\}\W*(\w+)?", text):
                near = [w for w in m.groups() if w]
                for noun in (w.split()[-1] for w in words):
                    assert not any(_same_stem(noun, w) for w in near), \
                        f"{where}: {kind.id}'s {field!r} ({noun}) beside {near} in {text!r}"


# ------------------------------------------------------------------ the software UART on a contended, noisy line
RATE = 1_000_000
BIT = 100                      # ticks a bit: 10,000 bit/s
EVERY = 30 * BIT               # a character every 30 bits: 20 bits of idle between
CLEAN, CONTENDED, HELD, GLITCHES, FALSE_STARTS = 20, 12, 60, 7, 5


def contended_line() -> np.ndarray:
    """One line (idle high, 8N1, 10,000 bit/s at 1 MHz), in four stretches:

    - CLEAN characters, every edge on the bit grid;
    - CONTENDED characters 0x55 with a second sender starting 0xFF 40 ticks (0.4
      bit) later, the line the AND of both (the active level wins, as on a bus).
      0x55's bits are 0 1 0 1 0 1 0 1 0 then stop; 0xFF's start bit holds the line
      low to 140, so the edges are 0, 140, 200, 300, ... 900: one edge, at 1.4 bits,
      off the grid (by 0.4 > 0.3 bit), and the samples at 50, 150, ... 950 read
      0x55 with its stop bit: one character, no error, off the grid;
    - noise in the idle after them: GLITCHES pulses of 10 ticks (under a quarter
      bit: removed), and FALSE_STARTS pulses of 35 ticks (back at idle by the
      middle of a start bit, 50: no character);
    - the line held at the active level by a stuck driver, HELD times: from each
      start edge s it stays low through every sample (s+50 ... s+950), with a
      spike to idle at s+460..s+495 between two samples (an edge 4.6 bits in: off
      the grid) and one at s+1000..s+1030 whose falling edge starts the next.
      Each is a break: no value, so no character, whatever its edges.

    So: CLEAN + CONTENDED characters, CONTENDED of them off the grid, HELD breaks,
    GLITCHES glitches, no framing or parity error."""
    duration = 0.2
    clean = [(0.001 + k * EVERY / RATE, b) for k, b in enumerate(b"a gimbal's own line!")]
    assert len(clean) == CLEAN
    t = 0.001 + CLEAN * EVERY / RATE
    first = [(t + k * EVERY / RATE, 0x55) for k in range(CONTENDED)]
    second = [(at + 40 / RATE, 0xFF) for at, _v in first]
    line = uart_levels(clean + first, RATE, 10_000, duration) & uart_levels(second, RATE, 10_000, duration)
    at = round((t + CONTENDED * EVERY / RATE) * RATE)
    for _ in range(GLITCHES):
        line[at:at + 10] = 0
        at += 1000
    for _ in range(FALSE_STARTS):
        line[at:at + 35] = 0
        at += 1000
    s = at + 2000
    line[s:] = 0
    for _ in range(HELD):
        line[s + 460:s + 495] = 1
        line[s + 1000:s + 1030] = 1
        s += 1030
    line[s - 30:] = 1              # released: back at idle after the last break's stop bit
    return line


def _read(line: np.ndarray, block: int, **uart) -> LineReport:
    """The line through a software UART, fed ``block`` samples at a time."""
    report = LineReport("A", "0", samplerate=RATE)
    u = SoftUart(report, **uart)
    ticks = (np.flatnonzero(np.diff(line)) + 1).astype(np.int64)
    for start in range(0, line.size, block):
        end = min(start + block, line.size)
        mine = ticks[(ticks >= start) & (ticks < end)]
        u.feed(Edges(mine, int(line[start - 1]) if start else int(line[0])), end)
    u.finish()
    return report


def test_a_contended_noisy_line_counts_off_grid_characters_among_its_characters():
    line = contended_line()
    for block in (line.size, 65_536, 4_096, 997):     # a file at once, a pipe's reads, small reads
        r = _read(line, block, bit=BIT, fmt=LineFormat())
        assert (r.characters, r.off_grid, r.breaks, r.glitches) == (CLEAN + CONTENDED, CONTENDED, HELD, GLITCHES), block
        assert (r.framing_errors, r.parity_errors) == (0, 0)
        assert r.off_grid <= r.characters
    found = {f.code: f for f in waveform_findings("A", r)}
    assert found[TWO_DRIVERS].detail == "12 of 32 characters have edges off the bit grid"
    # two senders explain the line's framing errors and breaks (the findings table's "hides")
    assert FRAMING_ERRORS not in found
    alone = {f.code: f for f in waveform_findings("A", replace(r, off_grid=0))}
    assert alone[FRAMING_ERRORS].title == "line A: 60 breaks"


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.binary(min_size=4, max_size=40), offset=st.integers(1, 99), other=st.integers(0, 255),
       noise=st.lists(st.tuples(st.integers(0, 119_000), st.integers(1, 150)), max_size=60),
       held=st.booleans(), rate_given=st.booleans(), block=st.sampled_from([997, 4096, 65_536, 200_000]))
def test_any_contended_noisy_line_keeps_every_count_within_its_whole(data, offset, other, noise, held, rate_given,
                                                                     block):
    # two senders on one line, the second starting ``offset`` ticks into each of
    # the first's characters, noise pulses anywhere, perhaps a stretch held active
    duration = 0.12
    chars = [(0.001 + k * 12 * BIT / RATE, b) for k, b in enumerate(data)]
    line = uart_levels(chars, RATE, 10_000, duration) & \
        uart_levels([(t + offset / RATE, other) for t, _b in chars[::2]], RATE, 10_000, duration)
    for at, width in noise:
        line[at:at + width] ^= 1
    if held:
        line[60_000:90_000] = 0
    r = _read(line, block, **({"bit": BIT} if rate_given else {"min_bit": 4}))
    assert r.off_grid <= r.characters
    assert r.framing_errors + r.parity_errors <= r.characters
    assert 2 * r.glitches <= r.edges
    for f in waveform_findings("A", r):
        for text in _texts(f):
            assert all(part <= whole for part, whole, _c in parts_over_wholes(text)), text
            assert doubled_words(text) == [], text
