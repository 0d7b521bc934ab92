"""Writing output files so that nothing is lost: never over an input, never
half-written, and every failure one line saying what and where.

- ``check_output(path, inputs, force)`` runs before any work: the output must not
  be a folder, its folder must exist and be writable, it must not be (through a
  symlink or a hard link: the same inode) any of the inputs, and it may replace an
  existing file only with ``--force``.
- ``AtomicOutput(path)`` writes into a hidden temporary file beside the target
  (same folder, so the final rename is atomic) and renames it over the target only
  on ``commit()``; ``discard()`` (or an exception in a ``with`` block) removes it,
  so a failed run leaves no partial file and the old file, if any, intact.
- ``show(path)`` gives a file name as text that can always be printed: names are
  kept as the OS gives them (``os.fsdecode``: undecodable bytes become surrogate
  escapes), and only shown with those bytes as ``\\xNN``; ``one_line(message)``
  escapes control characters too, for the messages on standard error.

A refusal (``OutputRefused``, from ``check_output``) is a usage mistake: exit 2.
A failure while writing (``OutputError``) is exit 1.

Every writer of the registry writes through ``AtomicOutput`` (the writer base,
analyzer/writers/base.py). Live recordings are the exception (``atomic=False``,
analyzer/writers/mcap.py): they are written in place and flushed every second,
because a killed tap must leave its capture under the name the user gave.
"""

from __future__ import annotations

import errno
import os
import tempfile
from collections.abc import Callable, Iterable
from types import TracebackType
from typing import BinaryIO, Self

from .errors import OutputError, OutputRefused


def show(path: str | bytes | os.PathLike) -> str:
    """``path`` as printable text: undecodable bytes as ``\\xNN`` escapes."""
    name = os.fsdecode(path)
    return name.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def one_line(message: str) -> str:
    """A message as the one line it is meant to be: undecodable bytes as
    ``\\xNN`` (``show``) and control characters escaped (``\\x0b``, ``\\x1b``),
    for the names it quotes come from files (a channel named with a vertical tab
    or a terminal's escape sequence would break the line, or clear the screen)."""
    text = show(message)
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def reason(e: OSError) -> str:
    """An OS error in a few words (ENOSPC: "no space left on device")."""
    if e.errno == errno.ENOSPC:
        return "no space left on device"
    if e.errno == errno.EDQUOT:
        return "disk quota exceeded"
    text = e.strerror or str(e) or type(e).__name__
    return text[:1].lower() + text[1:]


def write_error(path: str | os.PathLike, e: OSError) -> OutputError:
    return OutputError(f"{show(path)}: cannot write: {reason(e)}")


def user_data_folder() -> str:
    """The user's data folder as XDG (and GLib) name it: ``$XDG_DATA_HOME``, else
    ``~/.local/share``; installers put what other tools load under it."""
    return os.environ.get("XDG_DATA_HOME") or os.path.join(os.path.expanduser("~"), ".local", "share")


def install_text(path: str, text: str, mode: int | None = None) -> None:
    """An installer's file: ``text`` written beside ``path`` and renamed onto it,
    so a tool reading the folder never sees half of it; ``mode``: its permission
    bits (an executable). Raises OSError."""
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    if mode is not None:
        os.chmod(tmp, mode)
    os.replace(tmp, path)


def install_into(install: Callable[[str | None], list[str]], folder: str | None) -> list[str]:
    """Run an installer (``install(folder)`` writes files into ``folder``, or its
    tool's own folder for None) and return what it wrote; a folder that is a
    file, or cannot be written, is one line (OutputRefused)."""
    if folder is not None and os.path.exists(folder) and not os.path.isdir(folder):
        raise OutputRefused(f"{show(folder)}: is a file; --dir takes a folder")
    try:
        return install(folder)
    except OSError as e:
        raise OutputRefused(f"{show(e.filename or folder or '')}: cannot write: {e.strerror or e}") from None


def _same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def check_output(path: str | os.PathLike, inputs: Iterable[str | os.PathLike] = (), *,
                 force: bool = False, role: str = "input") -> None:
    """Refuse an output that cannot or must not be written (see module doc);
    ``role`` names what ``inputs`` are in the message ("input", "port")."""
    name = show(path)
    if os.path.isdir(path):
        raise OutputRefused(f"{name}: is a directory; give a file name")
    for inp in inputs:
        if _same_file(path, inp):
            same = "is" if os.path.abspath(path) == os.path.abspath(inp) else "is the same file as"
            raise OutputRefused(f"{name}: {same} the {role} {show(inp)}; write the output to another file")
    folder = os.path.dirname(os.path.realpath(path)) or "."
    if not os.path.isdir(folder):
        raise OutputRefused(f"{name}: cannot write: no such folder {show(folder)}")
    if os.path.lexists(path) and not force:
        raise OutputRefused(f"{name}: exists (use --force to overwrite)")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputRefused(f"{name}: cannot write in {show(folder)}: permission denied")


def _default_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


_MODE = _default_mode()


class AtomicOutput:
    """A file written beside ``path`` and renamed onto it on ``commit()``.

    ``file`` is the open binary file. Write errors raised through this class's
    methods become ``OutputError``; code writing to ``file`` directly can turn an
    ``OSError`` into one with ``write_error(path, e)``.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = path
        # a symlinked output is written through: its target gets the new content
        self.target = os.path.realpath(path)
        folder, base = os.path.split(self.target)
        try:
            fd, self.tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=".part", dir=folder or ".")
        except OSError as e:
            raise write_error(path, e) from None
        try:
            mode = os.stat(self.target).st_mode & 0o7777   # replacing a file keeps its mode
        except OSError:
            mode = _MODE
        os.fchmod(fd, mode)
        self.file: BinaryIO = os.fdopen(fd, "wb")
        self.done = False

    def write(self, data: bytes) -> None:
        try:
            self.file.write(data)
        except OSError as e:
            raise write_error(self.path, e) from None

    def commit(self) -> None:
        """Flush, sync and rename onto the target; on failure the temporary file is
        removed and the target left as it was."""
        if self.done:
            return
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            os.replace(self.tmp, self.target)
        except OSError as e:
            self.discard()
            raise write_error(self.path, e) from None
        self.done = True

    def discard(self) -> None:
        """Remove the temporary file; the target is untouched."""
        if self.done:
            return
        self.done = True
        try:
            self.file.close()
        except OSError:
            pass   # a full disk fails the final flush too: the file goes anyway
        try:
            os.unlink(self.tmp)
        except FileNotFoundError:
            pass

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()
