"""Every error that crosses a layer, in one module at the bottom of the package:
the layer that raises one and the command line that turns it into one line and
an exit status import it from here, so neither imports the other.

Each message is one line for people, naming what and where. Exit statuses
(cli/main.py): usage mistakes, refused outputs and unusable datasets 2; a failure
while writing 1; an input that is no capture 2.

Errors that never leave their module (a damaged MCAP record met while walking a
file, a cancelled background sweep of the rows) stay where they are raised.
"""

from __future__ import annotations


class UsageError(Exception):
    """Bad command-line input; the message is shown as one line, exit 2."""


class CaptureError(Exception):
    """An input that cannot be read as a capture; the message names what and where."""


class OutputError(Exception):
    """An output that cannot be written; the message is one line naming it.
    ``exit_code``: 1, the run failed writing its output."""

    exit_code = 1


class OutputRefused(OutputError):
    """An output refused before any work was done (``check_output``): a mistake
    on the command line, so exit 2 like every other usage error."""

    exit_code = 2


class StdoutError(OutputError):
    """Standard output cannot be written (not a closed pipe: that is quiet)."""


class RecordingError(OutputError):
    """The recording file cannot be written; the message names it, ``reason``
    says why in a few words."""

    def __init__(self, message: str, reason: str = "") -> None:
        super().__init__(message)
        self.reason = reason


class DatasetError(Exception):
    """A path that is no dataset, or a query DuckDB refused: one line for people
    (cli/main.py prints it, exit 2). Raised without importing DuckDB or pyarrow."""


class FilterError(ValueError):
    """A display filter that does not compile, at ``column`` of ``source``."""

    def __init__(self, message: str, column: int, source: str) -> None:
        self.column = column
        self.source = source
        super().__init__(f"column {column}: {message}")

    def pointer(self, context: int = 60) -> str:
        """The expression with the bad spot marked, for one-line error messages:
        control characters (a newline typed into the filter) are shown escaped so
        the message stays one line, and a long expression is cut to ``context``
        characters either side of the spot."""
        c = self.column - 1
        before, after = self.source[:c], self.source[c:]
        if len(before) > context:
            before = "…" + before[-context:]
        if len(after) > context:
            after = after[:context] + "…"
        return f"{_one_line(before)}>>>{_one_line(after)}"


def _one_line(text: str) -> str:
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


class BadMetadata(ValueError):
    """A value of a recording's metadata record that cannot be what it says."""


class ExtcapError(Exception):
    """A configuration Wireshark gets back as one line."""


class ServeError(Exception):
    """An address cannot be served (busy, or not this machine's): Foxglove's or the web TUI's; one line."""


class KeymapError(ValueError):
    """A TUI keymap file that cannot be used."""
