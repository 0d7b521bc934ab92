"""The text output's colour: each row style's escape codes (SGR) rendered once,
written around the line; the codes are worked out here from ECMA-48 and the
xterm colour numbers, not taken from the code."""

import io

import pytest

from analyzer.output import text_line
from analyzer.styles import ROW_CHECKSUM, ROW_NOISE, ROW_RETRANSMISSION, ROW_STYLE
from analyzer.writers.text import TextWriter
from dissectors.event import COMMAND, NOISE, Event

RESET = "\x1b[0m"


@pytest.fixture(autouse=True)
def terminal_256(monkeypatch):
    """A 256-colour terminal, whatever the machine running the tests says."""
    for name in ("NO_COLOR", "COLORTERM", "FORCE_COLOR", "TTY_COMPATIBLE", "TTY_INTERACTIVE"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("TERM", "xterm-256color")


def noise(number=7, raw=b"\x00\x13\x37") -> Event:
    e = Event("B", 40, NOISE, raw)
    e.number, e.t, e.problems = number, 1.5, ["noise: 3 bytes between frames"]
    return e


def command(**kw) -> Event:
    e = Event("A", 0, COMMAND, b"\xf8")
    e.number, e.t, e.status, e.payload = 1, 0.25, "ok", b"ZZ"
    for name, value in kw.items():
        setattr(e, name, value)
    return e


def printed(*events: Event) -> str:
    out = io.StringIO()
    writer = TextWriter(file=out, color=True)
    for e in events:
        writer.write(e)
    writer.on_stop()
    return out.getvalue()


def test_noise_is_red():
    assert ROW_STYLE[ROW_NOISE] == "red"
    e = noise()
    # SGR 31: foreground red; SGR 0: reset
    assert printed(e) == "\x1b[31m" + text_line(e)[0] + RESET + "\n"


def test_bad_checksum_is_bold_white_on_red():
    assert ROW_STYLE[ROW_CHECKSUM] == "bold white on red"
    e = command(checksum_ok=False)
    # 1 bold, 37 white foreground, 41 red background, in that order
    assert printed(e) == "\x1b[1;37;41m" + text_line(e)[0] + RESET + "\n"


def test_a_256_colour_style_uses_its_colour_number():
    assert ROW_STYLE[ROW_RETRANSMISSION] == "dark_orange"
    e = command(retransmission=True)
    # dark_orange is xterm colour 208: SGR 38;5;208
    assert printed(e) == "\x1b[38;5;208m" + text_line(e)[0] + RESET + "\n"


def test_a_plain_row_has_no_codes():
    e = Event("B", 9, "ack", b"\x06")
    e.number, e.t = 2, 0.5
    assert printed(e) == text_line(e)[0] + "\n"


def test_each_line_gets_its_own_codes():
    a, b = noise(1), command(checksum_ok=False)
    assert printed(a, b) == ("\x1b[31m" + text_line(a)[0] + RESET + "\n"
                             + "\x1b[1;37;41m" + text_line(b)[0] + RESET + "\n")


def test_no_color_keeps_bold_and_drops_colours(monkeypatch):
    monkeypatch.setenv("NO_COLOR", "1")          # no-color.org: what Rich did before
    e = command(checksum_ok=False)
    assert printed(e) == "\x1b[1m" + text_line(e)[0] + RESET + "\n"


def test_control_characters_are_not_passed_to_the_terminal():
    # a problem's text with a bell and a carriage return in it (none of ours
    # has them: this is the safety net): they are dropped, as Rich drops them
    e = noise()
    e.problems = ["noise: a\x07b\rc"]
    line = text_line(e)[0]
    shown = line.replace("\x07", "").replace("\r", "")
    out = printed(e)
    assert "\x07" not in out and "\r" not in out
    assert out.replace("\x1b[31m", "").replace(RESET, "") == shown + "\n"


def test_plain_output_is_untouched():
    out = io.StringIO()
    writer = TextWriter(file=out, color=False)
    e = noise()
    writer.write(e)
    assert out.getvalue() == text_line(e)[0] + "\n"
