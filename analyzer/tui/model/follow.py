"""Follow mode and marks: the selection's part of the model, without Textual.

Following, the list stays on the newest event; any navigation stops it and
counts what arrives meanwhile ("+N new"); End resumes it. In ``view``, End
pressed while the file still loads keeps following until loading ends.
Marks are event numbers the user set (``m``), kept across filters.
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
    def __init__(self) -> None:
        self.numbers: set[int] = set()

    def __contains__(self, number: int) -> bool:
        return number in self.numbers

    def toggle(self, number: int) -> bool:
        if number in self.numbers:
            self.numbers.discard(number)
            return False
        self.numbers.add(number)
        return True

    def next(self, number: int, shown: Callable[[int], bool]) -> int | None:
        """The next mark after ``number`` among those ``shown(mark)`` says are shown, wrapping."""
        marks = sorted(m for m in self.numbers if shown(m))
        if not marks:
            return None
        return marks[bisect_right(marks, number) % len(marks)]
