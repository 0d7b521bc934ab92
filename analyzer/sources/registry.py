"""Every input format the analyzer reads, and the walk that picks one for the
inputs given (python-can's reader and writer registries, as a list of records).

Adding a format is a module that declares its ``READER`` (analyzer/sources/base.py,
``Reader``) and one line in ``READERS`` below. A format whose module is slow to
import is declared here instead, with an opener that imports it when called:
MCAP, whose module loads the mcap package, which detecting other inputs must not.
"""

from __future__ import annotations

from . import rawdump, socatlog
from .base import CaptureError, Reader, Source
from .files import Input


def _open_mcap(inputs: list[Input], byte_time: float) -> Source:
    from .mcapfile import open_mcap   # only for an MCAP input: see the module doc
    return open_mcap(inputs, byte_time)


MCAP = Reader(
    # the start of mcapscan.MAGIC: a file that goes on differently is told apart by mcapfile
    "MCAP recording", _open_mcap, magic=b"\x89MCAP",
    crowded="an MCAP recording carries all its lines; give it on its own",
    # named a recording but not one: a damaged file, not a raw dump to decode as noise
    suffixes=(".mcap",), misnamed="not an MCAP file (it does not start with the MCAP magic bytes)",
)

# Tried in order, most specific first: the first reader that recognises any of the
# inputs reads them all.
READERS: list[Reader] = [
    MCAP,               # magic bytes
    socatlog.READER,    # text whose first line is a socat chunk header
    rawdump.READER,     # any bytes: the fallback, last
]


def formats() -> list[str]:
    """The names of the formats read, in the order they are tried."""
    return [r.name for r in READERS]


def most_inputs() -> int:
    """The most inputs any one format reads together."""
    return max(n for r in READERS for n in r.takes)


def reader_for(inputs: list[Input]) -> Reader:
    """The reader of ``inputs``, after the checks of every reader that cares:
    a CaptureError names the input that cannot be read and why."""
    _refuse_misnamed(inputs)
    for reader in READERS:
        claimed = [i for i in inputs if reader.recognises(i.head)]
        if not claimed:
            continue
        if len(inputs) not in reader.takes:
            raise CaptureError(f"{claimed[0].name}: {reader.crowded or _crowded(reader)}")
        if reader.vet is not None:
            for i in inputs:
                reader.vet(i)
        return reader
    raise CaptureError(f"{inputs[0].name}: not a capture this analyzer reads ({', '.join(formats())})")


def source_for(inputs: list[Input], byte_time: float) -> Source:
    """The source reading ``inputs`` (opened, heads read)."""
    return reader_for(inputs).opens(inputs, byte_time)


def _refuse_misnamed(inputs: list[Input]) -> None:
    """An input named as one format but not starting like it is damaged, not
    something for a later reader (the fallback would decode it as noise)."""
    for i in inputs:
        for reader in READERS:
            if reader.claimed_by_name(i.path) and not reader.recognises(i.head):
                raise CaptureError(f"{i.name}: {reader.misnamed or 'not a ' + reader.name}")


def _crowded(reader: Reader) -> str:
    """The error for a reader that declares none of its own."""
    if reader.takes == (1,):
        return f"a {reader.name} is one input; give it on its own"
    return f"a {reader.name} is {' or '.join(str(n) for n in reader.takes)} inputs"
