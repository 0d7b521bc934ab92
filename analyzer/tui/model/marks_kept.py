"""Where a file's marks are kept while it is viewed: its sidecar, beside its first
input (analyzer/formats/marks.py), written whole after every change and read
when the file opens. (A live tap's marks go into its recording instead.)"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from ...formats.marks import Mark, MarksError, notes_of, write_sidecar


class MarksKept:
    def __init__(self, inputs: Sequence[str]) -> None:
        self.inputs = tuple(inputs)

    def read(self) -> tuple[dict[int, str], str | None]:
        """The marks the file kept (number -> note), and why none could be read."""
        try:
            return notes_of(self.inputs), None
        except MarksError as e:
            return {}, str(e)

    def keep(self, marks: Iterable[Mark]) -> str:
        """Every mark into the sidecar; its path. Raises OSError."""
        return write_sidecar(self.inputs, marks)
