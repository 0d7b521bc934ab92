"""The writer base: where a writer's bytes go, how they take the target's name,
and the one line that says what was written.

A writer (the registry: analyzer/writers/__init__.py) is a listener of the tap
runner that writes what it hears into one target:

- a path, atomically (the default): written into a hidden temporary file beside
  it (``outfile.AtomicOutput``) that replaces the path when the run ends well
  and is removed when it fails, so a failed run leaves no partial file and the
  file it would have replaced intact;
- a path written in place (``atomic=False``): the file is there under the name
  given from the start, and what was written and flushed stays, whatever happens
  next. That is what a live recording needs: a killed tap must leave its capture
  (analyzer/writers/mcap.py, whose recorder opens its files itself: ``in_place``);
- an open file the caller gives (``file=``): written into and flushed, never
  closed (the FIFO Wireshark reads, a test's buffer);
- standard output (``path=None``): flushed, never closed.

Whether a run ended well only its caller knows: the runner stops its listeners
after a failure too. A command writing a file runs the tap inside ``with
writer:``, and the file takes its name only if the block ends without an
exception. A writer used without ``with`` finishes its file when it stops, as
a file written in place is left when its writer stops.

A failed write is one line naming the target (``write_error``; ``StdoutError``
for standard output) through ``self.writes``, after which the writer writes
nothing more; a reader that went away (``| head``) stays a ``BrokenPipeError``,
which is no error (cli/main.py).
"""

from __future__ import annotations

import os
import sys
from abc import ABC, abstractmethod
from types import TracebackType
from typing import IO, Any, Self

from dissectors.event import Event

from ..info import CaptureInfo
from ..outfile import AtomicOutput, OutputError, show, write_error
from ..output import STDOUT, Writing, output_error
from ..runner import Listener
from ..words import counted


def wrote(counts: dict[str, int], name: str) -> str:
    """What a writer says it wrote, one line, as the other commands word their
    outputs: ``wrote 1,024 events to out.jsonl`` (``1 event``)."""
    said = (counted(n, noun.removesuffix("s"), noun) for noun, n in counts.items())
    return f"wrote {', '.join(said)} to {name}"


class Target:
    """Where a writer's bytes go: ``file`` (None: the format opens its files
    itself), and how it ends. ``close()``: the run ended well; ``discard()``: it
    did not. The base targets are a given file (or standard output): flushed and
    left open, whatever happened."""

    def __init__(self, file: IO[Any] | None, name: str | os.PathLike[str]) -> None:
        self.file = file
        self.name = name   # in messages: the path as given, or STDOUT

    def error(self, e: OSError) -> OutputError:
        """The one-line error for a failed write."""
        return output_error(os.fspath(self.name), e)

    def close(self) -> None:
        if self.file is not None:
            self.file.flush()

    def discard(self) -> None:
        pass


class Atomic(Target):
    """A path, written beside it and renamed onto it (module doc)."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.output = AtomicOutput(path)
        super().__init__(self.output.file, path)

    def close(self) -> None:
        self.output.commit()

    def discard(self) -> None:
        self.output.discard()


class InPlace(Target):
    """A path written in place: the file is there under its name from the
    start; a writer flushes when what it wrote must be in it (a live tap's)."""

    file: IO[bytes]

    def __init__(self, path: str | os.PathLike[str]) -> None:
        try:
            file = open(path, "wb")   # noqa: SIM115 - open until the run ends: close() or discard()
        except OSError as e:
            raise write_error(path, e) from None
        super().__init__(file, path)

    def close(self) -> None:
        self.file.close()

    def discard(self) -> None:
        try:
            self.file.close()   # what was written stays: that is the point
        except OSError:
            pass   # a full disk fails the last flush too


def _name_of(file: IO[Any]) -> str:
    """A given file's name in messages: STDOUT for standard output."""
    if file is sys.stdout or file is getattr(sys.stdout, "buffer", None):
        return STDOUT
    return str(getattr(file, "name", "output"))


class FileWriter(Listener):
    """The base of every writer: ``FileWriter(path, info, *, file=None, atomic=True)``
    (module doc). A writer sets its options, then calls this ``__init__``, which
    opens the target and calls ``begin()`` (a header, a stream over ``self.file``);
    it writes in the listener's calls through ``self.writes`` (or raising its own
    one-line error), writes what ends its format in ``finish()``, and counts
    what it wrote in ``count`` (``summary()``)."""

    noun = "events"    # what ``count`` counts
    count = 0          # written so far
    binary = True      # standard output as bytes; False: as text
    many_captures = False   # True: one file may hold several captures, one after the other (``export``)

    def __init__(self, path: str | os.PathLike[str] | None = None, info: CaptureInfo | None = None, *,
                 file: IO[Any] | None = None, atomic: bool = True) -> None:
        self.path = path
        self.info = info
        self.broken = False          # a write failed: nothing more is written
        self.writes = Writing(self._write_failed)
        self._held = False           # inside ``with``: the block's end closes the target
        self._stopped = self._closed = False
        self.target = self.open_target(path, file, atomic)
        self.file = self.target.file
        try:
            self.begin()
        except BaseException:
            self.discard()
            raise

    @property
    def name(self) -> str:
        """The target as printable text (messages, ``summary()``)."""
        return show(self.target.name)

    # ------------------------------------------------------------ what a writer adds
    def open_target(self, path: str | os.PathLike[str] | None, file: IO[Any] | None, atomic: bool) -> Target:
        if file is not None:
            return Target(file, _name_of(file) if path is None else path)
        if path is None:
            return Target(sys.stdout.buffer if self.binary else sys.stdout, STDOUT)
        return Atomic(path) if atomic else self.in_place(path)

    def in_place(self, path: str | os.PathLike[str]) -> Target:
        """The target of ``atomic=False``: the path itself. A writer whose format
        opens its files itself (a recording in parts) gives its own."""
        return InPlace(path)

    def begin(self) -> None:
        """Start the format in ``self.file`` (a header); a failure here removes
        what the target made."""

    def finish(self) -> None:
        """Write what ends the format (the last block, a trailer)."""

    def summary(self) -> str:
        """What was written, one line (a command prints it if it says so)."""
        return wrote({self.noun: self.count}, self.name)

    # ------------------------------------------------------------ the end of a run
    def _write_failed(self, e: OSError) -> OutputError:
        self.broken = True
        return self.target.error(e)

    def on_stop(self) -> None:
        """The run is over: finish the format, and close the target unless the
        caller decides (``with``). Safe to call twice."""
        if self._stopped:
            return
        self._stopped = True
        try:
            self.finish()
        except BaseException:
            self.discard()
            raise
        if not self._held:
            self.close()

    def close(self) -> None:
        """The target complete under its name (a failed writer's is discarded)."""
        if self._closed:
            return
        if self.broken:
            self.discard()
            return
        self._closed = True
        with self.writes:
            self.target.close()

    def discard(self) -> None:
        """The run failed: the target as its kind leaves it (module doc)."""
        if not self._closed:
            self._closed = True
            self.target.discard()

    def __enter__(self) -> Self:
        self._held = True
        return self

    def __exit__(self, kind: type[BaseException] | None, e: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._held = False
        if kind is not None:
            self.discard()
            return
        self.on_stop()   # when the runner did not (a run never started)
        self.close()


class EventLines(FileWriter, ABC):
    """A writer of a line per event (the formats of ``--format``): ``write(ev)``
    writes one, the printer's call after its filter."""

    def on_events(self, events: list[Event]) -> None:
        write = self.write
        for ev in events:
            write(ev)

    @abstractmethod
    def write(self, ev: Event) -> None: ...
