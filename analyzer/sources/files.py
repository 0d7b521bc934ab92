"""Opening inputs: files, FIFOs, pipes (``<(…)``, ``/dev/stdin``), ``-`` for
standard input, compressed or not, each with one clear error line for every way
it can fail.

Every input is opened exactly once. ``Input`` reads its head (for detection)
into memory, and the source then reads a stream that gives that head again
followed by the rest, so a pipe is read once and nothing read for detection is
lost. Compressed inputs (analyzer/sources/compressed.py) are recognised by their
magic bytes; their head is the head of the decompressed data.
"""

from __future__ import annotations

import io
import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, BinaryIO

from ..errors import CaptureError
from ..outfile import reason, show
from .compressed import Decompressed, sniff
from .meter import READS

if TYPE_CHECKING:
    from _typeshed import WriteableBuffer

STDIN = "-"
HEAD = 1 << 16      # bytes read for detection
BLOCK = 1 << 16     # read size of the streams handed to sources


def display_name(path: str) -> str:
    """The input as the user gave it, printable (``-`` is standard input)."""
    return "standard input" if path == STDIN else show(path)


def open_input(path: str) -> BinaryIO:
    """The input opened for reading (``-``: standard input, which is never closed
    here); any failure is a ``CaptureError`` naming it."""
    if path == STDIN:
        stdin = _stdin()
        READS.track(stdin)   # counted for progress (a file behind `<` has a size)
        return stdin
    name = show(path)
    try:
        if os.path.isdir(path):
            raise CaptureError(f"{name}: is a directory, not a capture file")
        f = open(path, "rb")   # noqa: SIM115 - the caller's to close (``Input``, ``with open_input(…)``)
        READS.track(f)       # every capture file is opened here: counted for progress
        return f
    except FileNotFoundError:
        raise CaptureError(f"{name}: no such file") from None
    except PermissionError:
        raise CaptureError(f"{name}: permission denied") from None
    except OSError as e:
        raise CaptureError(f"{name}: cannot read: {reason(e)}") from None


def _stdin() -> BinaryIO:
    stdin = sys.stdin
    if stdin is None or not hasattr(stdin, "buffer"):
        raise CaptureError("standard input: not open")
    try:
        if os.isatty(stdin.fileno()):
            # reading would wait for typing: a capture is piped in, never typed
            raise CaptureError("standard input is a terminal; pipe a capture into it "
                               "(cat tap.log | gimbalscope decode -)")
    except (OSError, ValueError, io.UnsupportedOperation):
        pass   # no descriptor (an embedding program's stream): read it as it is
    return stdin.buffer


def _read_fully(f: BinaryIO, n: int, name: str) -> bytes:
    """Up to ``n`` bytes: less only at the end of the input (pipes give what is there)."""
    parts, got = [], 0
    try:
        while got < n:
            data = f.read(n - got)
            if not data:
                break
            parts.append(data)
            got += len(data)
    except OSError as e:
        raise CaptureError(f"{name}: cannot read: {reason(e)}") from None
    return b"".join(parts)


class Replay(io.RawIOBase):
    """``head`` again, then the rest of ``rest``: a stream whose start was already
    read for detection. Closing it leaves ``rest`` open (its owner closes it)."""

    def __init__(self, head: bytes, rest: BinaryIO, name: str) -> None:
        super().__init__()
        self._head = memoryview(head)
        self._at = 0
        # what is there, not a full block
        self._read: Callable[[int], bytes] = rest.read1 if isinstance(rest, io.BufferedIOBase) else rest.read
        self.name = name
        self.past_head = False   # something beyond the head was asked for

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: WriteableBuffer) -> int:
        b = memoryview(buffer)
        if self._at < len(self._head):
            n = min(len(b), len(self._head) - self._at)
            b[:n] = self._head[self._at:self._at + n]
            self._at += n
            return n
        self.past_head = True
        try:
            data = self._read(len(b))
        except OSError as e:
            raise CaptureError(f"{self.name}: cannot read: {reason(e)}") from None
        n = len(data)
        b[:n] = data
        return n


class Input:
    """One input, opened once: ``head`` (up to ``HEAD`` bytes, decompressed) for
    detection, then ``stream()`` for the source.

    A regular file may be streamed again (it is opened afresh); a pipe, FIFO or
    standard input only once.
    """

    def __init__(self, path: str, head_size: int = HEAD) -> None:
        self.path = path
        self.name = display_name(path)
        self._head_size = head_size
        self._open()

    def _open(self) -> None:
        self._file = open_input(self.path)
        self._dec: Decompressed | None = None
        self._streamed = False
        try:
            self._read_head()
        except BaseException:
            self.close()
            raise

    def _read_head(self) -> None:
        if self.path != STDIN and _is_terminal(self._file):
            # reading would wait for typing (or for a serial line that is never closed)
            raise CaptureError(f"{self.name}: is a terminal or serial port, not a capture file "
                               f"(a live tap: gimbalscope live {self.name})")
        self.regular = self.path != STDIN and _is_regular(self._file)
        raw_head = _read_fully(self._file, self._head_size, self.name)
        self.compression = sniff(raw_head)
        self._rest: BinaryIO = self._file
        self.head = raw_head
        if self.compression is not None:
            self._start_decompressing(raw_head, self.compression)
        self.complete = len(self.head) < self._head_size   # the head is the whole input

    def _start_decompressing(self, raw_head: bytes, kind: str) -> None:
        replay = Replay(raw_head, self._file, self.name)
        dec = Decompressed(replay, kind, self.name)
        stream = io.BufferedReader(dec, BLOCK)
        head = _read_fully(stream, self._head_size, self.name)
        if dec.invalid_at_start and not replay.past_head:
            # magic bytes by chance (a raw dump can start with 1f 8b): not compressed
            self.compression = None
            return
        self._dec, self._rest, self.head = dec, stream, head

    def read_head(self, size: int) -> bytes:
        """A longer head (socat's time-unit check wants more headers); only before
        ``stream()``."""
        if not self.complete and len(self.head) < size and not self._streamed:
            more = _read_fully(self._rest, size - len(self.head), self.name)
            self.head += more
            self.complete = len(self.head) < size
        return self.head

    def stream(self) -> BinaryIO:
        """The whole input from its first byte (decompressed)."""
        if self._streamed:
            if not self.regular:
                raise CaptureError(f"{self.name}: already read (a pipe can be read only once)")
            self.close()
            self._open()   # a file again from the start: reopened, decompressed afresh
        self._streamed = True
        if self.regular and self._dec is None:
            try:
                self._file.seek(0)
            except OSError as e:
                raise CaptureError(f"{self.name}: cannot read: {reason(e)}") from None
            return self._file
        return io.BufferedReader(Replay(self.head, self._rest, self.name), BLOCK)

    def blocks(self, size: int) -> Iterator[bytes]:
        """The whole input (``stream()``) in reads of at most ``size`` bytes; a
        failed read is a CaptureError naming the input."""
        f = self.stream()
        while True:
            try:
                data = f.read(size)
            except OSError as e:
                raise CaptureError(f"{self.name}: cannot read: {reason(e)}") from None
            if not data:
                return
            yield data

    @property
    def problem(self) -> str | None:
        """Why the (compressed) data ended early, once the stream has reached its end."""
        return self._dec.problem if self._dec is not None else None

    def describe(self, kind: str | None = None) -> str:
        """The name, with what it is and its compression when there is one."""
        notes = [n for n in (kind, self.compression) if n]
        return f"{self.name} ({', '.join(notes)})" if notes else self.name

    def as_regular_file(self) -> tuple[str, bool]:
        """A path holding the (decompressed) input as a regular file, for readers that
        need random access, and whether it is a temporary copy the caller removes."""
        if self.regular and self._dec is None:
            return self.path, False
        fd, tmp = tempfile.mkstemp(prefix="gimbalscope-", suffix=".mcap")
        try:
            with os.fdopen(fd, "wb") as out:
                shutil.copyfileobj(self.stream(), out, BLOCK)
        except OSError as e:
            os.unlink(tmp)
            raise CaptureError(f"{self.name}: cannot copy to a temporary file: {reason(e)}") from None
        except BaseException:
            os.unlink(tmp)
            raise
        return tmp, True

    def close(self) -> None:
        if self._dec is not None:
            self._dec.close()
        if self.path != STDIN:
            self._file.close()


def _is_terminal(f: BinaryIO) -> bool:
    try:
        return f.isatty()
    except (OSError, ValueError):
        return False


def _is_regular(f: BinaryIO) -> bool:
    try:
        return stat.S_ISREG(os.fstat(f.fileno()).st_mode)
    except (OSError, ValueError, io.UnsupportedOperation):
        return False
