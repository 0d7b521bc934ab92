"""A link that changes its rate with the protocol's own rate-set command (Table
4: ``C7`` is 115200 bit/s, ``C3`` 9600), sampled by a logic analyser at 1 MHz
on both lines (docs/instruments.md, "Rate changes").

After the ACK both ends switch. Going up twelvefold, the new bits are shorter
than a quarter of the old bit: the software UART must take them for a faster
rate, not for glitches. Going down, the slow start bits read as breaks at the
fast rate. Either way every message must read as sent: framed, paired and
timed to the microsecond, as a serial tap of the same traffic reads it.

Expectations come from the frames placed on the wire (Table 1, built by
``tests.conftest.frame``) and the times they were placed at.
"""

from __future__ import annotations

import shutil

import pytest

import analyzer
from tests.conftest import frame
from tests.waveforms import back_to_back, sigrok_session, uart_levels

pytestmark = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")

RATE = 1_000_000
CTL, DEV = 0, 1
QUERY = frame((DEV, 1, 1), CTL, b"P?")                    # 9 bytes
RESULT = frame((CTL, 1, 1), DEV, b"0FA0FC18")             # 15 bytes
ACK = b"\x06"
PERIOD = 0.040           # one exchange every 40 ms: a 9600 bit/s result takes 15.6 ms


def set_rate(code: int) -> bytes:
    return frame((DEV, 1, 1), CTL, f"C{code}".encode())   # 9 bytes: Table 4's rate code


def exchanges(start: float, count: int, baud: int, rate_code: int | None = None):
    """``count`` queries answered by ACK and result, each PERIOD apart from
    ``start``; then, if ``rate_code``, the rate-set command and its ACK at the
    same rate. Returns line A's and line B's characters and the command times."""
    a, b, times = [], [], []
    char = 10 / baud
    t = start
    for _ in range(count):
        a += back_to_back(QUERY, t, baud)
        ack_at = t + 9 * char + 0.002
        b += back_to_back(ACK, ack_at, baud) + back_to_back(RESULT, ack_at + char + 0.001, baud)
        times.append(t)
        t += PERIOD
    if rate_code is not None:
        a += back_to_back(set_rate(rate_code), t, baud)
        b += back_to_back(ACK, t + 9 * char + 0.002, baud)
        times.append(t)
        t += PERIOD
    return a, b, times, t


def capture(tmp_path, first: int, second: int, code: int, count: int = 12) -> tuple[str, list[float]]:
    a1, b1, times1, t = exchanges(0.010, count, first, rate_code=code)
    a2, b2, times2, end = exchanges(t, count, second)
    duration = end + 0.010
    a = uart_levels(a1, RATE, first, duration) & uart_levels(a2, RATE, second, duration)
    b = uart_levels(b1, RATE, first, duration) & uart_levels(b2, RATE, second, duration)
    return sigrok_session(tmp_path, a, b, samplerate=RATE, name="rate"), times1 + times2


@pytest.mark.parametrize("first, second, code", [(9600, 115200, 7), (115200, 9600, 3)],
                         ids=["up to 115200", "down to 9600"])
def test_every_message_reads_as_sent_across_the_rate_change(tmp_path, first, second, code):
    path, times = capture(tmp_path, first, second, code)
    cap = analyzer.open(path)
    events = list(cap)
    commands = [e for e in events if e.kind == "command"]
    # 12 queries, the rate-set command, 12 queries: every one answered
    assert [e.command for e in commands] == ["P?"] * 12 + ["C"] + ["P?"] * 12
    assert [e.status for e in commands] == ["ok"] * 25
    assert [e.t for e in commands] == pytest.approx(times, abs=2e-6)
    assert sum(e.kind == "ack" for e in events) == 25
    assert sum(e.kind == "result" for e in events) == 24
    assert not [e for e in events if e.problems]
    rate = [e for e in events if e.kind == "rate"]
    assert len(rate) == 1 and rate[0].fields == {"baud": second, "previous_baud": first}
    # a 9-byte query lasts 9 characters at its own rate, before and after
    spans = [e.t_end - e.t for e in commands if e.command == "P?"]
    for span, expected in zip(spans, [9 * 10 / first] * 12 + [9 * 10 / second] * 12):
        assert span == pytest.approx(expected, rel=0.02)
    for line in ("A", "B"):
        report = cap.source.physical[line]
        assert report.glitches == 0 and report.framing_errors == 0 and report.breaks == 0
        # measured to a sample in 8.7 at 115200: within half a per cent
        assert [c.after for c in report.rate_changes] == [pytest.approx(second, rel=0.005)]
        assert report.nominal == second


def test_a_faster_rate_without_a_rate_set_command_is_no_glitch(tmp_path):
    # one line, no rate-set frame to hint at it: queries at 9600, then after a
    # silence at 115200, whose bits are under a quarter of the old bit
    a1, _, times1, t = exchanges(0.010, 4, 9600)
    a2, _, times2, end = exchanges(t, 8, 115200)
    a = uart_levels(a1, RATE, 9600, end) & uart_levels(a2, RATE, 115200, end)
    cap = analyzer.open(sigrok_session(tmp_path, a, samplerate=RATE, name="up"))
    events = list(cap)
    commands = [e for e in events if e.kind == "command"]
    assert [e.t for e in commands] == pytest.approx(times1 + times2, abs=2e-6)
    # unanswered (line B is not there), but read as sent: no noise, no bad checksum
    assert all(e.command == "P?" and e.checksum_ok for e in commands)
    assert [e.kind for e in events if e.kind != "command"] == []
    report = cap.source.physical["AB"]
    assert report.glitches == 0
    assert [c.t for c in report.rate_changes] == [pytest.approx(t, abs=2e-6)]
