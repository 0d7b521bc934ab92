"""The software UART on edges made here (docs/instruments.md, "The software
UART"): the format told from the characters, the rate measured past glitches
and junk, false starts judged in a loop. Pure: edges in, characters out.

Expectations are worked out by hand from the bits placed on the wire."""

from __future__ import annotations

import numpy as np

from analyzer.physical.bitrate import measure_bit
from analyzer.physical.charformat import LineFormat, Reading, tell_format
from analyzer.physical.edges import Edges
from analyzer.physical.report import LineReport
from analyzer.physical.uart import SoftUart
from tests.waveforms import back_to_back, uart_levels

RATE = 1_000_000


def edges_of(levels: np.ndarray) -> np.ndarray:
    return (np.flatnonzero(np.diff(levels)) + 1).astype(np.int64)


def read_all(levels: np.ndarray, **uart) -> tuple[bytes, LineReport]:
    report = LineReport("A", "0", samplerate=RATE)
    u = SoftUart(report, **uart)
    chars = u.feed(Edges(edges_of(levels), 1), levels.size) + u.finish()
    return bytes(c.value for c in chars if c.value is not None and c.fault is None), report


# ------------------------------------------------------------------ tell_format, by hand
def test_a_top_bit_that_agrees_with_even_parity_on_sixteen_characters_is_parity():
    # "Hello World!\r\nHi" as 7E1, read as eight bits: the top bit is the even parity of
    # the low seven. 'H' = 0x48 (two ones: parity 0 -> 0x48), 'e' = 0x65 (four: 0x65),
    # 'l' = 0x6C (four), 'o' = 0x6F (six), ' ' = 0x20 (one: parity 1 -> 0xA0), ...
    text = b"Hello World!\r\nHi"
    as_7e1 = [c | (c.bit_count() % 2) << 7 for c in text]
    assert as_7e1[:5] == [0x48, 0x65, 0x6C, 0x6C, 0x6F] and as_7e1[5] == 0xA0
    wider = [v | 0x100 for v in as_7e1]             # nine bits: the ninth is the stop bit, 1
    verdict = tell_format([Reading(9, wider, 0, []), Reading(8, as_7e1, 0, []),
                           Reading(7, [], 16, [])])   # seven: the stop sample on a data bit
    assert verdict.fmt == LineFormat(7, "E") and verdict.possible == ()


def test_a_top_bit_that_agrees_on_ten_characters_only_is_a_guess_said():
    # 0x11, 0x22 ... 0xAA: every one has an even number of ones, as 7E1 characters would
    values = [0x11 * k for k in range(1, 11)]
    verdict = tell_format([Reading(9, [v | 0x100 for v in values], 0, []), Reading(8, values, 0, [])])
    assert verdict.fmt == LineFormat(8, "N") and "7E1" in verdict.possible


def test_a_ninth_bit_that_is_not_parity_is_data():
    # a counter 0x0F0 ... 0x10F in nine bits: the ninth bit is 0 then 1, whatever the others
    values = list(range(0xF0, 0x110))
    verdict = tell_format([Reading(9, values, 0, []), Reading(8, [], 32, [])])
    assert verdict.fmt == LineFormat(9, "N")


def test_seven_bit_characters_with_idle_between_are_seven_bits():
    # 7N1 "ab 12 cd 34 ef 5" read eight bits wide: the eighth is the stop bit, always 1
    values = list(b"ab 12 cd 34 ef 5")
    verdict = tell_format([Reading(8, [v | 0x80 for v in values], 0, []), Reading(7, values, 0, []),
                           Reading(6, [], 16, [])])
    assert verdict.fmt == LineFormat(7, "N")


# ------------------------------------------------------------------ the UART on waveforms
def test_7o1_text_reads_as_text_and_says_7o1():
    text = b"506793002\r\n" * 3
    levels = uart_levels(back_to_back(text, 0.001, 2400, data_bits=7, parity="O", stop_bits=1),
                         RATE, 2400, 0.5, data_bits=7, parity="O")
    got, report = read_all(levels)
    assert got == text and report.format == "7O1" and report.nominal == 2400


def test_a_burst_of_1500_false_starts_is_read_past_in_a_loop():
    # ringing: 1,500 pulses of 40 µs (0.38 bit at 9600, over a quarter bit: no glitch)
    # 20 µs apart, then the characters; each pulse is back at idle by the middle of a
    # start bit (52 µs), so each is a false start, and the characters read as sent
    data = b"\xf8\x01\x01\x01\x00\x02P?\x94" * 4
    levels = uart_levels(back_to_back(data, 0.200, 9600), RATE, 9600, 0.3)
    for k in range(1500):
        a = 1000 + k * 60
        levels[a:a + 40] = 0
    got, report = read_all(levels, bit=RATE / 9600)
    assert got == data and report.framing_errors == 0


def test_a_million_false_starts_end():
    # a line toggling every 30 µs for a million pulses (60 s at 1 MHz in edges only)
    ticks = np.arange(2_000_000, dtype=np.int64) * 30 + 100
    report = LineReport("A", "0", samplerate=RATE)
    u = SoftUart(report, bit=RATE / 9600)
    chars = u.feed(Edges(ticks, 1), int(ticks[-1]) + 1000) + u.finish()
    assert [c for c in chars if c.value is not None and c.fault is None] == []


def test_the_rate_is_measured_past_a_glitch_in_the_only_character():
    # 0x4F at 115200 sampled at 2 MHz (17.4 samples a bit) with a one-sample pulse in
    # its two 0 bits: without it the intervals are 1, 4, 2, 1, 1 bits
    bit = 2_000_000 / 115200
    s = 5
    ticks = np.array([s, s + bit, s + 5 * bit, s + 5.6 * bit, s + 5.6 * bit + 1, s + 7 * bit, s + 8 * bit,
                      s + 9 * bit]).astype(np.int64)
    m = measure_bit(ticks, 4)
    assert m is not None and abs(m.bit - bit) / bit < 0.03


def test_a_line_that_never_shows_a_rate_holds_bounded_edges():
    # random pulses of 1 to 3 samples (no rate a sampled line can be read at), fed
    # in 200 blocks of 5,000 edges: what the UART keeps stays a few windows long
    rng = np.random.default_rng(7)
    report = LineReport("A", "0", samplerate=RATE)
    u = SoftUart(report, min_bit=4)
    at = 0
    kept = []
    for _ in range(200):
        ticks = at + np.cumsum(rng.integers(1, 4, 5000))
        at = int(ticks[-1])
        assert u.feed(Edges(ticks.astype(np.int64), 1), at + 1) == []
        kept.append(u.ticks.size)
    assert not u.started and max(kept) < 10_000 and report.edges == 1_000_000


# ------------------------------------------------------------------ a slower rate, block by block

def read_in_blocks(levels: np.ndarray, block: int) -> tuple[bytes, LineReport]:
    """As a capture is read: the edges of each ``block`` samples, then the end."""
    report = LineReport("A", "0", samplerate=RATE)
    u = SoftUart(report)
    ticks = edges_of(levels)
    chars = []
    for start in range(0, levels.size, block):
        end = min(start + block, levels.size)
        inside = ticks[(ticks >= start) & (ticks < end)]
        chars += u.feed(Edges(inside, 1), end)
    chars += u.finish()
    return bytes(c.value for c in chars if c.value is not None and c.fault is None), report


def test_a_slower_rate_is_followed_however_the_capture_is_cut_in_blocks():
    # three P? frames at 9600 from 10 ms (to 38 ms), then from 90 ms two at 4800:
    # read at 9600 the slower characters give framing errors and breaks (the
    # first, F8, reads as a valid 0x80: four slow zero bits are eight fast ones),
    # so the change is seen from the errors, in whatever blocks the samples come
    # (the errors of one block alone are too few to judge)
    p = bytes.fromhex("f80101010002503f94")
    fast = back_to_back(p * 3, 0.010, 9600)
    slow = back_to_back(p * 2, 0.010, 4800)   # (from the second part's start, at 80 ms)
    levels = np.concatenate((uart_levels(fast, RATE, 9600, 0.080), uart_levels(slow, RATE, 4800, 0.060)))
    for block in (levels.size, 65_536, 4_096, 1_024, 333):
        data, report = read_in_blocks(levels, block)
        assert data == p * 5, block
        assert report.framing_errors == 0 and report.breaks == 0, block
        assert [(c.t, round(c.after, -1)) for c in report.rate_changes] == [(0.090, 4800)], block
