"""Follow mode and marks: the selection's part of the model, without Textual.

Following, the list stays on the newest event; any navigation stops it and
counts what arrives meanwhile ("+N new"); End resumes it. In ``view``, End
pressed while the file still loads keeps following until loading ends.
Marks are event numbers the user set (``m``), with notes (``M``), kept across filters.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Callable


class Follow:
    def __init__(self, on: bool) -> None:
        self.on = on
        self.away = False              # the user navigated away from the end
        self.new_while_away = 0        # rows that arrived since

    def grew(self, added: int) -> None:
        if self.away:
            self.new_while_away += added

    def stop(self) -> None:
        if self.on:
            self.on = False
            self.away = True
            self.new_while_away = 0

    def resume(self) -> None:
        self.on = True
        self.away = False
        self.new_while_away = 0


class Marks:
    """Marked event numbers and their notes ("" for none): ``m`` toggles a mark,
    ``M`` writes its note. Each change is also what the capture keeps
    (``changed``: the marks made since it was last asked, analyzer/formats/marks.py)."""

    def __init__(self) -> None:
        self.notes: dict[int, str] = {}
        self._changed: list[tuple[int, str | None]] = []   # (number, its note; None: unmarked)

    def __contains__(self, number: int) -> bool:
        return number in self.notes

    def __len__(self) -> int:
        return len(self.notes)

    def toggle(self, number: int) -> bool:
        """Mark ``number``, or take its mark (and note) off; is it marked now?"""
        if number in self.notes:
            del self.notes[number]
            self._changed.append((number, None))
            return False
        self.notes[number] = ""
        self._changed.append((number, ""))
        return True

    def write(self, number: int, note: str) -> None:
        """``number``'s note (marking it)."""
        self.notes[number] = note
        self._changed.append((number, note))

    def load(self, notes: dict[int, str]) -> None:
        """The marks a capture kept (not changes of this session)."""
        self.notes.update(notes)

    def changed(self) -> list[tuple[int, str | None]]:
        """The changes since the last call, in order."""
        out, self._changed = self._changed, []
        return out

    def note(self, number: int) -> str | None:
        return self.notes.get(number)

    def next(self, number: int, shown: Callable[[int], bool]) -> int | None:
        """The next mark after ``number`` among those ``shown(mark)`` says are shown, wrapping."""
        marks = sorted(m for m in self.notes if shown(m))
        if not marks:
            return None
        return marks[bisect_right(marks, number) % len(marks)]
