"""Compressed captures (``tap.log.gz``, ``rec.mcap.zst``, ``bus.bin.xz``, ``.bz2``),
recognised by their magic bytes and decompressed as a stream.

Each format is read through its incremental decompressor (``zlib``, ``lzma``,
``bz2`` from the standard library; ``zstandard``, which the mcap package brings),
so a capture is never held whole in memory and no output block grows past
``OUT_BLOCK``. Concatenated members (``cat a.gz b.gz``, ``pigz`` output, several
zstd frames or xz streams) are read one after the other.

Damaged or cut compressed data is no reason to lose what came before it: the
stream ends there and ``problem`` says where, for the source to pass on as a
warning once it has read everything before it.
"""

from __future__ import annotations

import bz2
import io
import lzma
import zlib
from typing import TYPE_CHECKING, Protocol

from ..errors import CaptureError

if TYPE_CHECKING:
    from _typeshed import WriteableBuffer

IN_BLOCK = 1 << 16       # compressed bytes read at a time
OUT_BLOCK = 1 << 18      # at most this many decompressed bytes per step
ZSTD_PIECE = 1 << 10     # zstd cannot cap its output, so it gets its input in small pieces

MAGIC = (
    (b"\x1f\x8b", "gzip"),
    (b"\x28\xb5\x2f\xfd", "zstd"),
    (b"\xfd7zXZ\x00", "xz"),
    (b"BZh", "bz2"),
)


def sniff(head: bytes) -> str | None:
    """The compression ``head`` starts with, or None."""
    for magic, kind in MAGIC:
        if head.startswith(magic):
            return kind
    return None


class _Decompressor(Protocol):
    """Every format's decompressor behind one interface: ``step(data)`` gives
    at most ``OUT_BLOCK`` bytes (zstd: see ``_Zstd``) and keeps the input it could
    not use yet, until ``needs_input``; ``eof`` at the end of a member, with what
    followed it in ``unused_data``."""

    def step(self, data: bytes) -> bytes: ...

    @property
    def needs_input(self) -> bool: ...

    @property
    def eof(self) -> bool: ...

    @property
    def unused_data(self) -> bytes: ...


class _Gzip:
    """zlib's decompressor, which hands the input it did not use back."""

    def __init__(self) -> None:
        self._d = zlib.decompressobj(16 + zlib.MAX_WBITS)   # 16+: the gzip wrapper
        self._tail = b""

    def step(self, data: bytes) -> bytes:
        out = self._d.decompress(self._tail + data if self._tail else data, OUT_BLOCK)
        self._tail = self._d.unconsumed_tail
        return out

    @property
    def needs_input(self) -> bool:
        return not self._tail

    @property
    def eof(self) -> bool:
        return self._d.eof

    @property
    def unused_data(self) -> bytes:
        return self._d.unused_data


class _Capped:
    """lzma's and bz2's decompressors, which keep the input they did not use."""

    def __init__(self, d: lzma.LZMADecompressor | bz2.BZ2Decompressor) -> None:
        self._d = d

    def step(self, data: bytes) -> bytes:
        return self._d.decompress(data, OUT_BLOCK)

    @property
    def needs_input(self) -> bool:
        return self._d.needs_input

    @property
    def eof(self) -> bool:
        return self._d.eof

    @property
    def unused_data(self) -> bytes:
        return self._d.unused_data


class _Zstd:
    """zstandard's decompressor with the same interface; it returns all the output
    of what it is given, so it is given ``ZSTD_PIECE`` bytes at a time."""

    def __init__(self) -> None:
        try:
            import zstandard
        except ImportError:   # pragma: no cover - mcap depends on it
            raise CaptureError("zstd-compressed input needs the zstandard package "
                               "(python3 -m pip install zstandard)") from None
        self._d = zstandard.ZstdDecompressor().decompressobj()
        self._buf = b""

    def step(self, data: bytes) -> bytes:
        buf = self._buf + data if self._buf else data
        piece, self._buf = buf[:ZSTD_PIECE], buf[ZSTD_PIECE:]
        return self._d.decompress(piece) if piece else b""

    @property
    def needs_input(self) -> bool:
        return not self._buf

    @property
    def eof(self) -> bool:
        return self._d.eof

    @property
    def unused_data(self) -> bytes:
        return self._d.unused_data + self._buf


def _decompressor(kind: str) -> _Decompressor:
    if kind == "zstd":
        return _Zstd()
    if kind == "gzip":
        return _Gzip()
    return _Capped(lzma.LZMADecompressor() if kind == "xz" else bz2.BZ2Decompressor())


def _errors() -> tuple[type[BaseException], ...]:
    errors: tuple[type[BaseException], ...] = (zlib.error, lzma.LZMAError, OSError, EOFError)
    try:
        import zstandard
        errors += (zstandard.ZstdError,)
    except ImportError:   # pragma: no cover
        pass
    return errors


class Decompressed(io.RawIOBase):
    """The decompressed bytes of ``raw`` (a binary stream of compressed data).

    Ends early, without raising, at damaged or cut data: ``problem`` then says
    what and where (in compressed bytes). ``invalid_at_start`` tells a file that only looked compressed
    (its magic bytes by chance, nothing decodable after them) from a damaged one.
    """

    def __init__(self, raw: io.RawIOBase, kind: str, name: str) -> None:
        super().__init__()
        self.kind = kind
        self.name = name
        self.problem: str | None = None
        self.invalid_at_start = False
        self._raw = raw
        self._read = raw.read
        self._errors = _errors()
        self._d = _decompressor(kind)
        self._consumed = 0          # compressed bytes read from raw
        self._pending = b""         # compressed bytes read but not given to the decompressor
        self._out = b""             # decompressed bytes, handed out from _at on
        self._at = 0
        self._made = 0              # decompressed bytes so far
        self._last_full = False     # the last step filled OUT_BLOCK: more may be held inside
        self._done = False

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: WriteableBuffer) -> int:
        b = memoryview(buffer)
        while self._at >= len(self._out) and not self._done:
            self._out, self._at = self._next(), 0
        n = min(len(b), len(self._out) - self._at)
        b[:n] = self._out[self._at:self._at + n]
        self._at += n
        return n

    def _fill(self) -> bool:
        """Read more compressed input; False at its end."""
        try:
            data = self._read(IN_BLOCK) or b""   # (None: nothing yet, from a stream that never waits)
        except OSError as e:
            raise CaptureError(f"{self.name}: cannot read: {e.strerror or e}") from None
        self._consumed += len(data)
        self._pending += data
        return bool(data)

    def _next(self) -> bytes:
        """The next block of output (possibly empty); sets ``_done`` at the end."""
        d = self._d
        if d.eof:
            return self._next_member()
        if not self._pending and d.needs_input and not self._last_full and not self._fill():
            # more input was needed, and it ends inside a member
            self._stop(f"compressed data ends early at byte {self._consumed}; decoded what came before")
            return b""
        data, self._pending = self._pending, b""
        try:
            out = d.step(data)
        except self._errors as e:
            if self._made == 0:
                self.invalid_at_start = True   # nothing came out: maybe not compressed at all
            self._stop(f"compressed data is damaged before byte {self._consumed} ({e or type(e).__name__}); "
                       f"decoded what came before")
            return b""
        self._last_full = len(out) >= OUT_BLOCK
        self._made += len(out)
        return out

    def _next_member(self) -> bytes:
        """After the end of one member: the next one, if more data follows. Zero bytes
        between members are padding (xz streams, tape blocks) and are skipped."""
        rest = self._d.unused_data + self._pending
        self._pending = b""
        while True:
            rest = rest.lstrip(b"\x00")
            if rest:
                break
            if not self._fill():
                self._done = True
                return b""
            rest, self._pending = self._pending, b""
        self._d = _decompressor(self.kind)
        self._last_full = False
        self._pending = rest
        return b""

    def _stop(self, problem: str) -> None:
        self.problem = f"{self.name}: {problem}"
        self._done = True

    def close(self) -> None:
        try:
            self._raw.close()
        finally:
            super().close()
