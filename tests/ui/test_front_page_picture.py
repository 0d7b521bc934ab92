"""The picture of the TUI on the README and the docs' home page
(docs/images/tui.svg) is what docs/images/draw_tui.py draws from the app as it
is now, and shows decoded traffic. It is redrawn in a process of its own, as the
script is run: Textual draws the same screen differently after other apps have
run in the same process (tests/ui/test_snapshots.py)."""

import html
import os
import re
import subprocess
import sys

import pytest

from tests.conftest import ROOT

PICTURE = os.path.join(ROOT, "docs", "images", "tui.svg")
DRAW = os.path.join(ROOT, "docs", "images", "draw_tui.py")
REDRAW = "python docs/images/draw_tui.py"


CELL = 12.2   # px: the width of a character in Rich's SVG (0.61 of its 20 px font)
TEXT = re.compile(r'<text [^>]*x="([0-9.]+)" [^>]*clip-path="url\(#[\w-]+-line-(\d+)\)">([^<]*)</text>')


def text_of(svg: str) -> str:
    """The characters on the screen, a line of text to a terminal line."""
    lines: dict[int, list[str]] = {}
    for x, line, cells in TEXT.findall(svg):
        row = lines.setdefault(int(line), [])
        column = round(float(x) / CELL)
        row.extend(" " * (column - len(row)))
        row[column:] = html.unescape(cells).replace("\xa0", " ").rstrip("\n")
    return "\n".join("".join(lines[n]) for n in sorted(lines))


def committed() -> str:
    with open(PICTURE, encoding="utf-8") as f:
        return f.read()


def test_the_picture_is_what_the_app_draws_now(tmp_path):
    out = tmp_path / "tui.svg"
    drawn = subprocess.run([sys.executable, DRAW, "-o", str(out)], cwd=ROOT, capture_output=True, text=True,
                           timeout=300, check=False)
    assert drawn.returncode == 0, f"{REDRAW} failed:\n{drawn.stderr}"
    new, old = out.read_text(encoding="utf-8"), committed()
    if new != old:
        new_lines, old_lines = new.splitlines(), old.splitlines()
        first = next((i for i, (a, b) in enumerate(zip(new_lines, old_lines)) if a != b),
                     min(len(new_lines), len(old_lines)))
        pytest.fail(f"docs/images/tui.svg is not what the TUI draws now (first difference at its line "
                    f"{first + 1}): redraw it with `{REDRAW}` and look at it before committing", pytrace=False)


def test_the_picture_shows_decoded_traffic():
    screen = text_of(committed())
    # the selected command with a bad checksum, its NAK, the retransmission and its ACK
    assert "291 4.960910" in screen and "bad checksum: expected 0xb1, got 0xa9" in screen
    assert "292 4.973415    ← B 1.1.2     nak" in screen
    assert "retransmission: repeats #291 after nak" in screen
    # a command with its ACK and result, paired and timed
    assert "286 4.884489    → A 1.1.1     command P?    current position query" in screen
    assert "result  P?    at az +114.93° el +83.82°" in screen
    # the detail pane, the status bar with the doctor's finding, the timeline
    assert "#291 command on line A" in screen and "checksum 0xa9 BAD" in screen
    assert "474 events" in screen and "line B is noisy" in screen
    assert "ms/c" in screen


def test_the_picture_names_its_styles_the_same_every_time():
    # Rich names them after a hash of the content; the script gives them one name
    assert re.search(r"terminal-\d+", committed()) is None
