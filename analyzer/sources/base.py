"""The source interface: where bytes come from (python-can's ``BusABC``, for taps).

A source yields ``Chunk``s: bytes seen on one line, with the wire time of their
first byte when the source knows time. Raw dumps, socat logs, MCAP recordings and
live serial ports are sources.

Whoever reads a source (a ``Capture``) gives it, through methods the source owns,
where its warnings go (``report_to``) and each line's settings (``read_with``:
the ``LineSettings`` the capture changes when the link's rate changes, which a
source that back-dates its reads reads as it makes each chunk).
"""

from __future__ import annotations

import weakref
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Self

from dissectors.wire import LineSettings

from ..lines import LINE_A, LINE_B, Chunk, LineFault

if TYPE_CHECKING:
    from ..physical.report import LineReport
    from .files import Input


def _ignore(msg: str) -> None:
    pass


@dataclass(frozen=True)
class StoredColumns:
    """A source's stored columns: the record saying they are complete (None:
    none to use, ``why`` says why when there is something to say), and their
    messages (Arrow IPC, analyzer/formats/store_ipc.py) read in order, on demand."""
    record: dict[str, str] | None
    why: str | None
    messages: Callable[[], Iterator[bytes]] = lambda: iter(())


class Source(ABC):
    """A capture input with one line (``("AB",)``) or two (``("A", "B")``)."""

    lines: tuple[str, ...] = (LINE_A, LINE_B)
    timed: bool = False
    # how many clocks stamped the chunks (docs/time.md, "Clocks"): 0 untimed, 1 one
    # clock for every line (a socat log, a single-line tap), 2 a clock per line (two
    # live adapters, whose delays differ: the only case for skew correction)
    clocks: int = 0
    # chunk times are when each chunk's first start bit began on the wire, measured
    # (a logic analyser's samples), not when a read returned: no read-order floor
    # between the lines applies (docs/time.md, "Byte order")
    wire_times: bool = False
    start_time: float | None = None    # epoch seconds of t = 0, when known
    description: str = ""
    # the line's own errors (framing, parity, break, overrun) as the source reads
    # them, for a source that sees below the bytes; None: it cannot see them.
    # Told before the chunk holding the byte (analyzer/capture/faults.py).
    faults: list[LineFault] | None = None

    # What readers of a source (the capture, the runner, CaptureInfo, the commands)
    # may ask of any source; each default is a file of bytes' answer.
    # a live line (ports, a piped stream of samples): read until ``stop()``, in small
    # reads released soon (the merge, rate following), a recorder may join mid-run
    live: bool = False
    # each input is one line (two raw dumps, two ports): how CaptureInfo names the lines
    input_per_line: bool = False
    # where ``start_time`` came from ("host clock", a file's modification time): recordings keep it
    time_origin: str = ""
    # a live tap's state per line ("open", "lost", "reconnecting"), for the screen; empty for files
    state: Mapping[str, str] = MappingProxyType({})
    # a logic capture's lines as its software UART measures them (line → LineReport,
    # kept up to date while reading; a recording's as recorded), for the doctor and
    # the screen; None for a source of bytes
    physical: dict[str, LineReport] | None = None
    # a recording's ``gimbalscope`` metadata record (docs/mcap.md): its decoding
    # settings (analyzer/capture/recorded.py), its capture id and site (CaptureInfo)
    metadata: dict[str, str] | None = None
    # a source that should carry that record (a recording): a missing or garbled one
    # is said, with why it could not be read (``metadata_problem``) when known
    carries_metadata: bool = False
    metadata_problem: str | None = None

    def __init__(self) -> None:
        self._warn: Callable[[str], None] = _ignore
        self._early: list[str] = []                 # see warn_later
        self._cleanups: list[weakref.finalize] = []  # see on_close
        # each line's settings (docs/time.md, "Wire times"): 9600 8N1 until
        # whoever reads the source gives its own (read_with)
        self.line_settings: dict[str, LineSettings] = {}

    @property
    def warn(self) -> Callable[[str], None]:
        """Told every warning (``report_to`` says where they go)."""
        return self._warn

    def report_to(self, handler: Callable[[str], None]) -> None:
        """Give every warning to ``handler`` from now on; those found while the
        source was opened go to it at once."""
        self._warn = handler
        early, self._early = self._early, []
        for msg in early:
            handler(msg)

    def read_with(self, settings: dict[str, LineSettings]) -> None:
        """Read with these settings, one per line (docs/time.md, "Rate changes"):
        the capture reading the source changes them when the link's rate changes,
        and a source that back-dates its reads reads their byte time chunk by chunk."""
        self.line_settings = dict(settings)

    def settings_of(self, line: str) -> LineSettings:
        """``line``'s settings (9600 8N1 for a line never given any)."""
        settings = self.line_settings.get(line)
        if settings is None:
            settings = self.line_settings[line] = LineSettings()
        return settings

    def warn_later(self, msg: str) -> None:
        """A warning found while the source was being opened, before anyone listens:
        given to the handler when one is set."""
        if self.warn is _ignore:
            self._early.append(msg)
        else:
            self.warn(msg)

    def on_close(self, cleanup: Callable[[], None]) -> None:
        """Run ``cleanup`` once: at ``close()``, or when the source is collected or the
        program ends without closing it (a temporary file must not outlive the run)."""
        self._cleanups.append(weakref.finalize(self, cleanup))

    @abstractmethod
    def chunks(self) -> Iterator[Chunk]:
        """Every chunk in capture order (time order for timed sources)."""

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        """One line's chunks on their own; untimed multi-line sources override it
        so each line can be read at its own pace."""
        return (c for c in self.chunks() if c.line == line)

    def measured_settings(self) -> dict[str, Any]:
        """The serial settings the source measured (a logic capture's rate and
        format, as ``Options`` fields): the capture decodes with them unless they
        were given (analyzer/capture/recorded.py). A source of bytes measures none."""
        return {}

    def stored_columns(self) -> StoredColumns:
        """The decoded columns the source carries beside its bytes (a recording's:
        docs/mcap.md, "Stored columns"), so that reading it needs no decoding.
        Sources of bytes carry none."""
        return StoredColumns(None, None)

    def stop(self) -> None:
        """Stop reading a live line: what was read is still given, then the chunks
        end (a signal, a timer, the runner's ``stop``); a file ends by itself, so
        nothing to do. Safe from any thread."""

    def close(self) -> None:
        """Release what the source holds (files, temporary copies). Subclasses that
        override it call ``super().close()``."""
        for cleanup in self._cleanups:
            cleanup()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(frozen=True)
class InstrumentSettings:
    """How to read an instrument's capture (docs/instruments.md): a logic
    analyser's channels and UART settings, a USB capture's adapter and device.
    ``None`` everywhere is "find it out from the capture"."""
    channels: tuple[tuple[str, str], ...] = ()   # (("A", "TX"), ("B", "3")): the channel of each line
    baud: int | None = None          # given: the software UART's rate, not measured
    data_bits: int | None = None     # given: not detected
    parity: str | None = None
    stop_bits: float | None = None
    adapter: str | None = None       # a USB capture's adapter: "ftdi", "cp210x" or "ch34x"
    usb_device: str | None = None    # "BUS.DEV": which device of a USB capture
    samplerate: float | None = None  # samples a second of a bare sample stream (--samplerate)
    unitsize: int = 1                # its bytes a sample (channel N at bit N)

    def given(self) -> list[str]:
        """The fields set that only some formats read (``Reader.reads``): the
        channels, a USB capture's adapter and device, a sample stream's rate and
        size. (The serial settings are read by every format.)"""
        return [name for name, unset in INPUT_KIND_FIELDS.items() if getattr(self, name) != unset]


# InstrumentSettings' fields that only some formats read, each with its unset value,
# and the option that sets it (as messages name it)
INPUT_KIND_FIELDS = {"channels": (), "adapter": None, "usb_device": None, "samplerate": None, "unitsize": 1}
OPTION_OF = {"channels": "--channels", "adapter": "--adapter", "usb_device": "--usb-device",
             "samplerate": "--samplerate", "unitsize": "--unitsize"}


@dataclass(frozen=True)
class ReadSettings:
    """What a reader needs to know to open its inputs (docs/time.md): the byte time
    at the start rate, the zone of a socat log's local timestamps (None: this
    machine's), and the capture start a raw dump's times count from (None: its
    modification time less its duration)."""
    byte_time: float
    tz: str | None = None
    start_time: float | None = None
    instrument: InstrumentSettings = InstrumentSettings()

    @classmethod
    def of(cls, settings: ReadSettings | float) -> ReadSettings:
        """A bare number is a byte time."""
        return settings if isinstance(settings, ReadSettings) else cls(float(settings))


@dataclass(frozen=True)
class Reader:
    """How one input format is recognised and opened. Each reader module declares
    one (``READER``; MCAP's is in the registry, to keep the mcap package unloaded);
    the list of them, most specific first, is ``READERS`` in
    analyzer/sources/registry.py, which ``detect()`` walks.

    An input is recognised by ``magic`` (what its head starts with) or ``looks``
    (a check of its head), the head being already decompressed (``Input.head``).
    """

    name: str                                        # the format, as messages and docs call it
    opens: Callable[[list[Input], ReadSettings], Source]   # (inputs, settings) -> the source reading them
    magic: bytes = b""
    looks: Callable[[bytes], bool] | None = None
    takes: tuple[int, ...] = (1,)                    # how many inputs it reads together
    crowded: str = ""                                # the error when given with a count not in ``takes``
    suffixes: tuple[str, ...] = ()                   # file names that claim the format (lower case) ...
    misnamed: str = ""                               # ... and the error when the head says otherwise
    vet: Callable[[Input], None] | None = None       # raises CaptureError for an input it must not take
    # a format with no head of its own, read when a setting says the input is one
    # (a bare stream of logic samples: --samplerate)
    chosen_by: Callable[[ReadSettings], bool] | None = None
    reads: frozenset[str] = frozenset()              # the InstrumentSettings.given() fields it reads
    given_as: str = ""                               # after the name in the commands' help: how it is given

    def __post_init__(self) -> None:
        if not self.magic and self.looks is None and self.chosen_by is None:
            raise ValueError(f"reader {self.name!r}: give magic bytes, a head check or the setting that chooses it")

    def recognises(self, head: bytes) -> bool:
        """Is ``head`` (an input's decompressed head) the start of this format?"""
        if self.magic and head.startswith(self.magic):
            return True
        return self.looks is not None and self.looks(head)

    def claims(self, head: bytes, settings: ReadSettings | None) -> bool:
        """Does this reader read an input of ``head`` with ``settings``?"""
        return self.recognises(head) or (self.chosen_by is not None and settings is not None
                                         and self.chosen_by(settings))

    def claimed_by_name(self, path: str) -> bool:
        """Does the file name say it is this format (``rec.mcap``)?"""
        return path.lower().endswith(self.suffixes)
