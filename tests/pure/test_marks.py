"""Marks and notes (analyzer/formats/marks.py, the TUI's Marks): what is kept,
where, and what a sidecar that does not read says."""

from __future__ import annotations

import json

import pytest

from analyzer.formats.marks import Mark, MarksError, read_marks, read_sidecar, sidecar_path, write_sidecar
from analyzer.tui.model.follow import Marks


def test_marks_toggle_write_and_say_what_changed():
    marks = Marks()
    assert marks.toggle(6) is True and 6 in marks and marks.note(6) == ""
    marks.write(6, "ACK late here")
    marks.write(9, "noise burst")
    assert marks.toggle(9) is False and 9 not in marks and marks.note(9) is None
    assert marks.changed() == [(6, ""), (6, "ACK late here"), (9, "noise burst"), (9, None)]
    assert marks.changed() == []
    marks.load({3: "kept"})
    assert marks.changed() == [] and marks.note(3) == "kept"
    assert marks.next(3, lambda n: True) == 6 and marks.next(6, lambda n: True) == 3


def test_a_sidecar_round_trips_beside_the_first_input(tmp_path):
    capture = tmp_path / "tap.log"
    capture.write_text("")
    path = write_sidecar([str(capture)], [Mark(12, "second", 1.5), Mark(3, "first ✓", None)])
    assert path == str(capture) + ".marks.json" == sidecar_path([str(capture)])
    data = json.loads((tmp_path / "tap.log.marks.json").read_text())
    assert data["version"] == 1 and data["capture"] == [str(capture)]
    assert data["marks"] == [{"number": 3, "t": None, "note": "first ✓"}, {"number": 12, "t": 1.5, "note": "second"}]
    assert read_marks([str(capture)]) == [Mark(3, "first ✓", None), Mark(12, "second", 1.5)]


def test_no_sidecar_and_no_recording_is_no_marks(tmp_path):
    capture = tmp_path / "ctl.bin"
    capture.write_bytes(b"\x06")
    assert read_marks([str(capture)]) == []


@pytest.mark.parametrize("text", ["", "{", "[]", '{"marks": [{"note": "no number"}]}', '{"marks": 3}'])
def test_a_sidecar_that_does_not_read_is_one_error_naming_it(tmp_path, text):
    path = tmp_path / "x.log.marks.json"
    path.write_text(text)
    with pytest.raises(MarksError) as e:
        read_sidecar(str(path))
    assert str(path) in str(e.value) and "\n" not in str(e.value)
