"""Every input format the analyzer reads, and the walk that picks one for the
inputs given (python-can's reader and writer registries, as a list of records).

Adding a format is a module that declares its ``READER`` (analyzer/sources/base.py,
``Reader``) and one line in ``READERS`` below. A format whose module is slow to
import is declared here instead, with an opener that imports it when called:
MCAP, whose module loads the mcap package, which detecting other inputs must not.

A reader's ``takes`` lists how many inputs it reads together; ``ANY_COUNT`` is
any number: MCAP recordings, whose parts are read as one capture (docs/time.md,
"Parts"), every input then having to be one.
"""

from __future__ import annotations

from ..errors import CaptureError
from . import pcapngfile, rawdump, saleae_binary, saleae_csv, sigrok, socatlog, usb, vcd
from .base import Reader, ReadSettings, Source
from .files import Input


class AnyCount(tuple):
    """``Reader.takes`` of a format read from any number of inputs together: every
    count from one is in it, and it lists none (it has no fixed count, so
    ``most_inputs`` does not see it)."""

    def __new__(cls) -> "AnyCount":
        return super().__new__(cls)

    def __contains__(self, count: object) -> bool:
        return isinstance(count, int) and count >= 1

    def __repr__(self) -> str:
        return "ANY_COUNT"


ANY_COUNT = AnyCount()

# Given with more inputs than any format of a fixed count reads (what detect() said
# before recordings came in parts, and still says for every other format).
TOO_MANY = "{count} inputs given: expected one capture file, or two raw dumps (line A then line B)"


def _open_mcap(inputs: list[Input], settings: ReadSettings) -> Source:
    # imported only for MCAP inputs: see the module doc
    if len(inputs) == 1:
        from .mcapfile import open_mcap
        return open_mcap(inputs, settings)
    from .mcapparts import open_mcap_parts   # the parts of one tap's recording (docs/time.md, "Parts")
    return open_mcap_parts(inputs, settings)


def _vet_mcap(inp: Input) -> None:
    """Among several recordings read as one capture, every input is one."""
    if not MCAP.recognises(inp.head):
        raise CaptureError(f"{inp.name}: not an MCAP recording; several inputs must all be recordings of one tap")


MCAP = Reader(
    # the start of mcapscan.MAGIC: a file that goes on differently is told apart by mcapfile
    "MCAP recording", _open_mcap, magic=b"\x89MCAP",
    takes=ANY_COUNT, vet=_vet_mcap,
    # named a recording but not one: a damaged file, not a raw dump to decode as noise
    suffixes=(".mcap",), misnamed="not an MCAP file (it does not start with the MCAP magic bytes)",
)

# Tried in order, most specific first: the first reader that recognises any of the
# inputs reads them all.
READERS: list[Reader] = [
    MCAP,               # magic bytes
    usb.READER,         # a pcap or pcapng of USB link types (usbmon, USBPcap): before gimbalscope's own pcapng
    pcapngfile.READER,  # magic bytes: gimbalscope's own pcapng (an export, a Wireshark capture through the extcap)
    sigrok.READER,      # a zip whose first member is sigrok's version or metadata
    vcd.READER,         # text starting with a VCD section ($timescale, $var, …)
    saleae_csv.READER,  # text whose first line is Time [s],… or the Async Serial table's columns
    saleae_binary.READER,  # magic bytes <SALEAE>: one file a channel
    socatlog.READER,    # text whose first line is a socat chunk header
    rawdump.READER,     # any bytes: the fallback, last
]


def formats() -> list[str]:
    """The names of the formats read, in the order they are tried."""
    return [r.name for r in READERS]


def most_inputs() -> int:
    """The most inputs a format of a fixed count reads together (two raw dumps);
    formats read from any number of inputs (``ANY_COUNT``) are left out."""
    return max((n for r in READERS for n in r.takes), default=1)


def any_count_read() -> bool:
    """Does some format read any number of inputs together? Until the inputs are
    opened, a count above ``most_inputs`` may then still be one capture."""
    return any(isinstance(r.takes, AnyCount) for r in READERS)


def reader_for(inputs: list[Input]) -> Reader:
    """The reader of ``inputs``, after the checks of every reader that cares:
    a CaptureError names the input that cannot be read and why."""
    _refuse_misnamed(inputs)
    for reader in READERS:
        claimed = [i for i in inputs if reader.recognises(i.head)]
        if not claimed:
            continue
        if len(inputs) not in reader.takes:
            if len(inputs) > most_inputs():
                raise CaptureError(TOO_MANY.format(count=len(inputs)))
            raise CaptureError(f"{claimed[0].name}: {reader.crowded or _crowded(reader)}")
        if reader.vet is not None:
            for i in inputs:
                reader.vet(i)
        return reader
    raise CaptureError(f"{inputs[0].name}: not a capture this analyzer reads ({', '.join(formats())})")


def source_for(inputs: list[Input], settings: ReadSettings) -> Source:
    """The source reading ``inputs`` (opened, heads read)."""
    return reader_for(inputs).opens(inputs, settings)


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
