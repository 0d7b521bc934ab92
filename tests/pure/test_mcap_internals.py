"""The recorder's adapter of the mcap library's writer (analyzer/writers/mcap_internals.py),
the one place that touches mcap's internals: these tests fail, naming the installed
mcap's version, when the library changes what the adapter relies on. Then adapt
mcap_internals.py to the new version (or pin mcap below it in pyproject.toml)."""

import io
import random
import subprocess
import sys
import textwrap

import mcap
import zstandard
from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from mcap.writer import IndexType

from analyzer.writers.mcap_internals import LEVEL_CHANGED, SMALL_CHUNK, STORE_CHANGED, ZSTD_LEVEL, chunk_writer
from tests.conftest import ROOT

MCAP = f"mcap {mcap.__version__}"


def chunks(*contents: bytes) -> list[Chunk]:
    """The chunks of an MCAP written by the adapter, one message of each of
    ``contents`` per chunk."""
    out = io.BytesIO()
    writer = chunk_writer(out, chunk_size=1 << 20, index_types=IndexType.ALL, use_chunking=True)
    writer.start(profile="", library="test")
    channel = writer.register_channel("/t", "", writer.register_schema("s", "", b""))
    for k, data in enumerate(contents):
        t = 1_795_000_000_123_456_789 + k   # a recording's times: nanoseconds since 1970
        writer.add_message(channel, log_time=t, data=data, publish_time=t, sequence=k)
        writer.flush()
    writer.finish()
    out.seek(0)
    return [r for r in StreamReader(out, emit_chunks=True).records if isinstance(r, Chunk)]


def test_the_installed_mcap_has_the_internals_the_adapter_relies_on():
    assert (LEVEL_CHANGED, STORE_CHANGED) == (None, None), f"{LEVEL_CHANGED}; {STORE_CHANGED}"


def test_a_small_chunk_that_zstd_would_make_larger_is_stored_as_it_is():
    noise = random.Random(5).randbytes(64)
    compressible = b"P?" * 1000
    _, stored, squeezed = chunks(b"\x06", noise, compressible)   # the first with the schema and channel
    assert stored.compression == "", f"{MCAP}: the adapter no longer stores an incompressible chunk as it is"
    assert len(stored.data) == stored.uncompressed_size < SMALL_CHUNK
    assert squeezed.compression == "zstd", f"{MCAP}: a compressible chunk is no longer compressed"


def test_chunks_are_compressed_at_the_adapters_zstd_level():
    (first,) = chunks(b"P?" * 5000)
    raw = zstandard.ZstdDecompressor().decompress(first.data, max_output_size=first.uncompressed_size)
    assert first.data == zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress(raw), \
        f"{MCAP}: the writer no longer compresses with the adapter's compressor (level {ZSTD_LEVEL})"


# A new mcap whose chunk builder is reshaped (here: its buffer no longer a BytesIO),
# the rest as it is; in a process of its own, where the adapter is imported after.
RESHAPED_BUILDER = textwrap.dedent("""
    import io
    import mcap.data_stream

    class Buffer:
        def __init__(self):
            self.bytes = io.BytesIO()

        def __getattr__(self, name):
            return getattr(self.bytes, name)

    def reshaped_init(self):
        self._buffer = Buffer()

    mcap.data_stream.RecordBuilder.__init__ = reshaped_init

    from analyzer.writers import mcap_internals
    from tests.pure.test_mcap_internals import test_chunks_are_compressed_at_the_adapters_zstd_level
    assert mcap_internals.STORE_CHANGED is not None and mcap_internals.LEVEL_CHANGED is None
    test_chunks_are_compressed_at_the_adapters_zstd_level()
""")


def test_a_reshaped_chunk_builder_keeps_the_zstd_level():
    done = subprocess.run([sys.executable, "-c", RESHAPED_BUILDER], check=False, cwd=ROOT,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
