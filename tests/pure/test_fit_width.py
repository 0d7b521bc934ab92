"""Tables and lines that fit the width (analyzer/formats/fit_width.py): every cell
whole, every line within the width and without trailing spaces, groups of columns
kept together, at widths from narrow to wide."""

import io

import pytest
from rich.console import Console

from analyzer.formats.fit_width import FitFields, FitLines, FitTable
from tests.text_tables import assert_fits, cells, headers, read_tables

GROUPS = [["commands", "ok", "nak", "nic", "no_ack", "no_result", "pending"],
          ["retransmissions", "checksum_errors"],
          ["ACK min", "ACK median", "ACK p95", "ACK max"],
          ["result median", "result max"]]
NAMES = [name for group in GROUPS for name in group]
ROWS = [["1.1.1", "1,071", "1,068", "0", "1", "2", "0", "0", "2", "0",
         "1.9 ms", "4.6 ms", "7.5 ms", "7.9 ms", "7.9 ms", "10.7 ms"],
        ["1.1.10", "5", "5", "0", "0", "0", "0", "0", "0", "0", "", "", "", "", "", ""]]


def draw(renderable, width: int) -> str:
    out = io.StringIO()
    Console(file=out, width=width, color_system=None).print(renderable)
    return out.getvalue()


@pytest.mark.parametrize("width", [40, 60, 80, 100, 120, 200])
def test_every_cell_is_shown_whole_once_within_the_width(width):
    text = draw(FitTable("device", GROUPS, ROWS, "per device"), width)
    assert_fits(text, width)
    tables = read_tables(text)
    assert headers(tables) == ["device", *NAMES]
    expected = {(row[0], name): cell for row in ROWS for name, cell in zip(NAMES, row[1:])}
    assert cells(tables) == expected
    assert tables[0].title == "per device"
    assert all(t.title == "per device, continued" for t in tables[1:])


def test_one_table_when_it_fits_and_groups_kept_together_when_not():
    groups = [["aaaa", "bbbb"], ["cccc", "dddd"]]
    rows = [["k", "1", "2", "3", "4"]]
    # the widths of key, aaaa..dddd (3, 4 each), and 3 a column (a bar, two spaces) and the last bar
    one_table = 3 + 4 * 4 + 3 * 5 + 1
    text = draw(FitTable("key", groups, rows), one_table)
    assert [t.headers for t in read_tables(text)] == [["key", "aaaa", "bbbb", "cccc", "dddd"]]
    assert max(len(line) for line in text.splitlines()) == one_table
    # a column short: the second group goes to a table of its own, whole (not dddd alone)
    tables = read_tables(draw(FitTable("key", groups, rows), one_table - 1))
    assert [t.headers for t in tables] == [["key", "aaaa", "bbbb"], ["key", "cccc", "dddd"]]


def test_headers_are_stacked_only_when_that_saves_a_table():
    text = draw(FitTable("device", GROUPS, ROWS), 80)
    tables = read_tables(text)
    # at 80: the statuses; the two counts of errors; the six latencies, their
    # names stacked a word a line (with them on one line they take two tables)
    assert [t.headers[1:] for t in tables] == [GROUPS[0], GROUPS[1], GROUPS[2] + GROUPS[3]]
    assert "┃    ACK ┃" in text and "┃ median ┃" in text
    wide = draw(FitTable("device", GROUPS, ROWS), 200)
    assert "┃ ACK median ┃" in wide and len(read_tables(wide)) == 1
    # just too narrow for one table with the names on a line: stacked, still one
    flat = max(len(line) for line in wide.splitlines())
    narrower = draw(FitTable("device", GROUPS, ROWS), flat - 1)
    assert len(read_tables(narrower)) == 1 and "┃ ACK median ┃" not in narrower


def test_a_group_wider_than_the_width_is_split_between_its_columns():
    text = draw(FitTable("device", GROUPS, ROWS), 30)
    tables = read_tables(text)
    assert_fits(text, 30)
    assert headers(tables) == ["device", *NAMES]
    assert len(tables) > len(GROUPS)


def test_cells_are_text_not_markup():
    text = draw(FitTable("command", [["commands"]], [["[bold]X[/]", "1"]]), 80)
    assert cells(read_tables(text)) == {("[bold]X[/]", "commands"): "1"}


def test_lines_wrap_without_trailing_spaces():
    line = ("problems (events per category): retransmission 18, bad checksum 13, unanswered 6, "
            "unknown command 6, noise 4, malformed payload 1")
    text = draw(FitLines(line, "short"), 80)
    assert_fits(text, 80)
    assert " ".join(text.split()) == line + " short"
    assert text.splitlines()[-1] == "short"


def test_fields_wrap_a_long_value_under_itself():
    pairs = [("capture", "/a/long/path/" + "x" * 70 + "/mon.log"), ("latency", ""), ("kind", "nak")]
    text = draw(FitFields(pairs), 40)
    assert_fits(text, 40)
    lines = text.splitlines()
    # names padded to the longest (7) and two spaces: values start at column 9
    assert lines[0].startswith("capture  /a/long/path/")
    assert all(line.startswith(" " * 9) and line[9] != " " for line in lines[1:-2])
    assert "".join(line[9:] for line in lines[:-2]) == pairs[0][1]
    assert lines[-2:] == ["latency", "kind     nak"]
