"""Every input format the analyzer reads, and the walk that picks one for the
inputs given (python-can's reader and writer registries, as a list of records).

Adding a format is a module that declares its ``READER`` (analyzer/sources/base.py,
``Reader``) and one line in ``READERS`` below. A format whose module is slow to
import is declared here instead, with an opener that imports it when called:
MCAP, whose module loads the mcap package, which detecting other inputs must not
(and the logic analysers' formats, whose readers load numpy).

A reader's ``takes`` lists how many inputs it reads together; ``ANY_COUNT`` is
any number: MCAP recordings, whose parts are read as one capture (docs/time.md,
"Parts"), every input then having to be one.
"""

from __future__ import annotations

from typing import Self

from ..errors import CaptureError
from . import pcapngfile, rawdump, signatures, socatlog, usb
from .base import OPTION_OF, Reader, ReadSettings, Source
from .files import Input


class AnyCount(tuple):
    """``Reader.takes`` of a format read from any number of inputs together: every
    count from one is in it, and it lists none (it has no fixed count, so
    ``most_inputs`` does not see it)."""

    def __new__(cls) -> Self:
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
    from .mcapparts import open_mcap_parts  # the parts of one tap's recording (docs/time.md, "Parts")
    return open_mcap_parts(inputs, settings)


def _vet_mcap(inp: Input) -> None:
    """Among several recordings read as one capture, every input is one."""
    if not MCAP.recognises(inp.head):
        raise CaptureError(f"{inp.name}: not an MCAP recording; several inputs must all be recordings of one tap")


MCAP = Reader(
    # the start of mcapwalk.MAGIC: a file that goes on differently is told apart by mcapfile
    "MCAP recording", _open_mcap, magic=b"\x89MCAP",
    takes=ANY_COUNT, vet=_vet_mcap, given_as=", or the parts of one in any order",
    # named a recording but not one: a damaged file, not a raw dump to decode as noise
    suffixes=(".mcap",), misnamed="not an MCAP file (it does not start with the MCAP magic bytes)",
)

LOGIC_CHANNELS = frozenset({"channels"})   # the logic analysers' formats choose channels (--channels)


def _open_sigrok(inputs: list[Input], settings: ReadSettings) -> Source:
    from .sigrok import open_sigrok
    return open_sigrok(inputs, settings)


def _open_vcd(inputs: list[Input], settings: ReadSettings) -> Source:
    from .vcd import open_vcd
    return open_vcd(inputs, settings)


def _open_saleae_csv(inputs: list[Input], settings: ReadSettings) -> Source:
    from .saleae_csv import open_saleae_csv
    return open_saleae_csv(inputs, settings)


def _open_saleae_binary(inputs: list[Input], settings: ReadSettings) -> Source:
    from .saleae_binary import open_saleae_binary
    return open_saleae_binary(inputs, settings)


SIGROK = Reader(  # the logic analysers' formats (docs/instruments.md): readers loaded when opened
    "sigrok session", _open_sigrok, reads=LOGIC_CHANNELS, looks=signatures.looks_like_session,
    given_as=" (.sr)",
    crowded="a sigrok session holds its channels; give it on its own",
    suffixes=(".sr",), misnamed="not a sigrok session (a .sr file is a zip whose first member is sigrok's "
                                "version, its metadata or a chunk of samples, logic-1…)",
)
VCD = Reader(
    "VCD", _open_vcd, reads=LOGIC_CHANNELS, looks=signatures.looks_like_vcd, given_as=" (.vcd)",
    crowded="a VCD holds its channels; give it on its own",
    suffixes=(".vcd",), misnamed="not a VCD (a .vcd file starts with a $date, $version, $timescale, $scope "
                                 "or $var section)",
)
# One reader for both CSV exports: a .csv file is claimed by its name, and must then be one of them.
SALEAE_CSV = Reader(
    "Saleae CSV export", _open_saleae_csv, reads=LOGIC_CHANNELS, looks=signatures.looks_like_export,
    given_as=" (digital, or Async Serial table)",
    crowded="a Saleae CSV export holds its channels; give it on its own",
    suffixes=(".csv",), misnamed="not a Saleae Logic 2 export (a digital CSV starts Time [s],<channels>; "
                                 "an Async Serial data table name,type,start_time,duration,data)",
)
SALEAE_BINARY = Reader(
    "Saleae binary export", _open_saleae_binary, reads=LOGIC_CHANNELS, magic=signatures.MAGIC, takes=(1, 2),
    vet=signatures.vet_binary, given_as=" (one file a channel: one, or two for lines A and B)",
    crowded="Saleae binary exports are one file a channel: give one or two (line A, line B)",
)

def _open_sample_stream(inputs: list[Input], settings: ReadSettings) -> Source:
    from .samplestream import open_sample_file
    return open_sample_file(inputs, settings)


SAMPLE_STREAM = Reader(   # what sigrok-cli -O binary writes: no header, so the sample rate given says it is one
    "logic sample stream", _open_sample_stream, chosen_by=lambda settings: settings.instrument.samplerate is not None,
    reads=LOGIC_CHANNELS | {"samplerate", "unitsize"}, given_as=" (sigrok-cli -O binary) with --samplerate",
    crowded="a stream of logic samples holds its channels; give it on its own",
)

# Tried in order, most specific first: the first reader that recognises any of the
# inputs reads them all.
READERS: list[Reader] = [
    MCAP,               # magic bytes
    usb.READER,         # a pcap or pcapng of USB link types (usbmon, USBPcap): before gimbalscope's own pcapng
    pcapngfile.READER,  # magic bytes: gimbalscope's own pcapng (an export, a Wireshark capture through the extcap)
    SIGROK,             # a zip whose first member is sigrok's version, metadata or samples
    VCD,                # text starting with a VCD section ($timescale, $var, …)
    SALEAE_CSV,         # text whose first line is Time [s],… or the Async Serial table's columns
    SALEAE_BINARY,      # magic bytes <SALEAE>: one file a channel
    socatlog.READER,    # text whose first line is a socat chunk header
    SAMPLE_STREAM,      # no head of its own: any input, when --samplerate says it is samples
    rawdump.READER,     # any bytes: the fallback, last
]


def formats() -> list[str]:
    """The names of the formats read, in the order they are tried."""
    return [r.name for r in READERS]


def input_kinds() -> str:
    """Every format read, as the help of each command that reads captures lists
    them (one list: the registry's)."""
    return "; ".join(r.name + r.given_as for r in READERS)


def input_help() -> str:
    return f"a capture: {input_kinds()}"


def most_inputs() -> int:
    """The most inputs a format of a fixed count reads together (two raw dumps);
    formats read from any number of inputs (``ANY_COUNT``) are left out."""
    return max((n for r in READERS for n in r.takes), default=1)


def any_count_read() -> bool:
    """Does some format read any number of inputs together? Until the inputs are
    opened, a count above ``most_inputs`` may then still be one capture."""
    return any(isinstance(r.takes, AnyCount) for r in READERS)


def reader_for(inputs: list[Input], settings: ReadSettings | None = None) -> Reader:
    """The reader of ``inputs`` (read with ``settings``), after the checks of every
    reader that cares: a CaptureError names the input that cannot be read and why."""
    _refuse_misnamed(inputs)
    for reader in READERS:
        claimed = [i for i in inputs if reader.claims(i.head, settings)]
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
    reader = reader_for(inputs, settings)
    source = reader.opens(inputs, settings)
    for field in settings.instrument.given():
        if field not in reader.reads:
            option = OPTION_OF[field]
            source.warn_later(f"{inputs[0].name}: {option} ignored: read as {reader.name}, which takes no "
                              f"{option} (it is for {_readers_of(field)})")
    return source


def _readers_of(field: str) -> str:
    """The formats that read an instrument option, as a message lists them."""
    names = [r.name for r in READERS if field in r.reads]
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"


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
