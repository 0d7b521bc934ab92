"""Warnings on standard error: -q leaves them out, and warnings that differ only
in their numbers are said three times in full, then counted in one line."""

from analyzer.listeners.printer import NotePrinter, warning_kind
from analyzer.runner import DOCTOR, INFO, RECORDING, Note


def said(capsys, printer: NotePrinter, notes) -> list[str]:
    for note in notes:
        printer.on_note(note)
    printer.on_stop()
    out, err = capsys.readouterr()
    assert out == ""
    return err.splitlines()


def skew(ms: float) -> Note:
    return Note(f"line B reads about {ms:.1f} ms ahead of line A (adapter delays differ)")


def test_a_warning_repeated_627_times_is_three_lines_and_a_count(capsys):
    notes = [skew(10 + i / 10) for i in range(627)]
    lines = said(capsys, NotePrinter(), notes)
    assert lines == [
        "gimbalscope: warning: line B reads about 10.0 ms ahead of line A (adapter delays differ)",
        "gimbalscope: warning: line B reads about 10.1 ms ahead of line A (adapter delays differ)",
        "gimbalscope: warning: line B reads about 10.2 ms ahead of line A (adapter delays differ)",
        # 627 - 3 said in full
        ("gimbalscope: warning: … and 624 more like this: "
         "line B reads about 10.0 ms ahead of line A (adapter delays differ)"),
    ]


def test_each_kind_is_counted_separately(capsys):
    gap = [Note(f"tap.log:{n}: stray line skipped") for n in (12, 40, 41, 90, 95)]      # 5 of one kind
    lines = said(capsys, NotePrinter(), [skew(1.0), *gap, skew(2.0), skew(3.0), skew(4.0), skew(5.0)])
    assert lines[:7] == [
        "gimbalscope: warning: line B reads about 1.0 ms ahead of line A (adapter delays differ)",
        "gimbalscope: warning: tap.log:12: stray line skipped",
        "gimbalscope: warning: tap.log:40: stray line skipped",
        "gimbalscope: warning: tap.log:41: stray line skipped",
        "gimbalscope: warning: line B reads about 2.0 ms ahead of line A (adapter delays differ)",
        "gimbalscope: warning: line B reads about 3.0 ms ahead of line A (adapter delays differ)",
        # the 4th and 5th skew lines and the 4th and 5th stray lines are held back
        ("gimbalscope: warning: … and 2 more like this: "
         "line B reads about 1.0 ms ahead of line A (adapter delays differ)"),
    ]
    assert lines[7:] == ["gimbalscope: warning: … and 2 more like this: tap.log:12: stray line skipped"]


def test_three_or_fewer_are_all_said_and_nothing_is_added(capsys):
    lines = said(capsys, NotePrinter(), [skew(1.0), skew(2.0), skew(3.0)])
    assert len(lines) == 3 and not any("more like this" in line for line in lines)


def test_different_words_are_different_kinds(capsys):
    notes = [Note("port /dev/ttyUSB0 lost"), Note("port /dev/ttyUSB0 back"),
             Note("port /dev/ttyUSB0 lost"), Note("port /dev/ttyUSB0 back")]
    assert len(said(capsys, NotePrinter(repeats=1), notes)) == 4   # 1 + 1 said, 1 more of each counted


def test_kinds_leave_out_numbers_of_every_shape():
    assert warning_kind("a 12 b -3.5 c 0x94 d 1,024 e 08:35:52") == "a # b -# c # d # e #"
    assert warning_kind("compressed data ends early at byte 4096") == warning_kind(
        "compressed data ends early at byte 77")


def test_quiet_says_no_warnings_but_findings_and_status_lines(capsys):
    notes = [skew(1.0), Note("recorded 12 messages to a.mcap", INFO, origin=RECORDING),
             Note("dead link", "error", origin=DOCTOR), skew(2.0), skew(3.0), skew(4.0), skew(5.0)]
    assert said(capsys, NotePrinter(quiet=True), notes) == [
        "gimbalscope: recorded 12 messages to a.mcap",
        "gimbalscope: dead link",
    ]


def test_findings_and_status_lines_are_never_collapsed(capsys):
    notes = [Note(f"recorded {n} messages to a-{n}.mcap", INFO, origin=RECORDING) for n in range(5)]
    assert len(said(capsys, NotePrinter(), notes)) == 5
