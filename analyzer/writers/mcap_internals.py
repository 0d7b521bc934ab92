"""The one place that touches the mcap library's internals: its ``Writer`` as the
recording needs it (analyzer/writers/mcap_recorder.py), for two things mcap
offers no public hook for (it has none as of 1.6).

- **zstd at** ``ZSTD_LEVEL``. The writer compresses a chunk with its module's
  ``zstandard.compress``, at zstd's default level, and takes no level: this
  module puts a compressor at ``ZSTD_LEVEL`` in that name's place, for every
  MCAP writer of the process.
- **A chunk that zstd does not make smaller is stored as it is** (the format
  names each chunk's compression, "" for none). A live tap closes a chunk every
  second, and at a quiet moment that chunk holds a message or two, which zstd's
  frame makes larger: readers take it either way, but checkers flag it as
  inefficient. The writer closes a chunk in its name-mangled
  ``Writer.__finalize_chunk``, with the compression of ``Writer.__compression``:
  ``chunk_writer``'s writer overrides the one and, for such a chunk, sets the
  other, reading the chunk's bytes from ``Writer.__chunk_builder``. Only chunks
  of at most ``SMALL_CHUNK`` bytes are tried twice.

The two are checked apart, so that a new mcap reshaping one keeps the other:
``LEVEL_CHANGED`` and ``STORE_CHANGED`` say what of each one's internals the
installed mcap no longer has (None while it has them all).
tests/pure/test_mcap_internals.py fails, naming mcap's version, when either is
not None, or when the recordings it writes lose either thing. A recording goes
on all the same: without the level's internals nothing is put in mcap's place
(chunks at mcap's own zstd level), and without the others ``chunk_writer``
gives mcap's own writer (every chunk compressed).
"""

from __future__ import annotations

import inspect
import io
from types import FunctionType
from typing import IO, TYPE_CHECKING, Protocol, cast

import mcap
import mcap.writer
import zstandard
from mcap.writer import CompressionType, IndexType, Writer

if TYPE_CHECKING:
    from mcap._chunk_builder import ChunkBuilder

ZSTD_LEVEL = 9       # why 9: the recording's layout (mcap_recorder.py)
SMALL_CHUNK = 4096   # bytes: a chunk this small is compressed only if that makes it smaller


class Output(Protocol):
    """What the writer does with its output: a stream it writes, asks the
    position of, and flushes."""

    def write(self, data: bytes) -> int: ...

    def tell(self) -> int: ...

    def flush(self) -> None: ...


class _Zstd:
    """zstd at ``ZSTD_LEVEL``, in the place of the zstandard module mcap's writer calls."""

    @staticmethod
    def compress(data: bytes) -> bytes:
        # a compressor per chunk: a recording may be written from another thread (the TUI's)
        return zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress(data)


def _finalize_chunk() -> FunctionType | None:
    """mcap's ``Writer.__finalize_chunk(self)``, None if it no longer has one of that shape."""
    finalize = vars(Writer).get("_Writer__finalize_chunk")
    if not isinstance(finalize, FunctionType) or list(inspect.signature(finalize).parameters) != ["self"]:
        return None
    return finalize


def _level_changed() -> str | None:
    """``LEVEL_CHANGED`` (module doc): the zstd level needs the writer to
    compress a chunk with its module's ``zstandard.compress``."""
    finalize = _finalize_chunk()
    if finalize is None:
        missing = "Writer.__finalize_chunk(self)"
    elif not (hasattr(mcap.writer, "zstandard")
              and {"zstandard", "compress"} <= set(finalize.__code__.co_names)):
        missing = "zstandard.compress, called by Writer.__finalize_chunk"
    else:
        return None
    return _changed_message([missing])


def _store_changed() -> str | None:
    """``STORE_CHANGED`` (module doc): storing a chunk as it is needs the
    method that closes a chunk, its compression setting and its builder."""
    missing = []
    if _finalize_chunk() is None:
        missing.append("Writer.__finalize_chunk(self)")
    probe = vars(Writer(io.BytesIO()))
    if not isinstance(probe.get("_Writer__compression"), CompressionType):
        missing.append("Writer.__compression")
    builder = probe.get("_Writer__chunk_builder")
    records = getattr(builder, "record_writer", None)
    if not (hasattr(builder, "num_messages") and hasattr(builder, "count")
            and isinstance(getattr(records, "_buffer", None), io.BytesIO)):
        missing.append("Writer.__chunk_builder (num_messages, count, record_writer._buffer)")
    return _changed_message(missing) if missing else None


def _changed_message(missing: list[str]) -> str:
    return (f"mcap {mcap.__version__} no longer has the writer internals analyzer/writers/mcap_internals.py "
            f"adapts: {', '.join(missing)}")


LEVEL_CHANGED = _level_changed()
STORE_CHANGED = _store_changed()
if LEVEL_CHANGED is None:
    mcap.writer.zstandard = _Zstd   # type: ignore[assignment]  # in the module's place: compress() is all it calls


class _StoresIncompressibleChunks(Writer):
    """mcap's writer, storing a small chunk that zstd does not make smaller as it is (module doc)."""

    # mcap's own attributes, by their mangled names (Writer.__init__ sets them)
    _Writer__chunk_builder: ChunkBuilder | None
    _Writer__compression: CompressionType

    def _Writer__finalize_chunk(self) -> None:
        if not self._incompressible():
            super()._Writer__finalize_chunk()   # type: ignore[misc]  # mcap's private method: mypy does not mangle names
            return
        self._Writer__compression = CompressionType.NONE
        try:
            super()._Writer__finalize_chunk()   # type: ignore[misc]  # as above
        finally:
            self._Writer__compression = CompressionType.ZSTD

    def _incompressible(self) -> bool:
        builder = self._Writer__chunk_builder
        if builder is None or not builder.num_messages or builder.count > SMALL_CHUNK \
                or self._Writer__compression != CompressionType.ZSTD:
            return False
        data = builder.record_writer._buffer.getvalue()
        return len(_Zstd.compress(data)) >= len(data)


def chunk_writer(output: Output, *, chunk_size: int, index_types: IndexType, use_chunking: bool) -> Writer:
    """mcap's writer into ``output``, compressing with zstd at ``ZSTD_LEVEL`` and
    storing a chunk that zstd does not make smaller as it is (module doc)."""
    kind = _StoresIncompressibleChunks if STORE_CHANGED is None else Writer
    # the writer calls only write, tell and flush on a stream it is given (not a path)
    return kind(cast(IO[bytes], output), compression=CompressionType.ZSTD, chunk_size=chunk_size,
                index_types=index_types, use_chunking=use_chunking)
