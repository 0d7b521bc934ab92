"""``Capture``: from a source to paired events. Each line is deframed, the lines
are put in wire order, and the events are paired. This is what
``analyzer.open`` returns and what every CLI command reads.

- timed two-line input (socat logs, live taps): events of both lines merged by
  wire time (analyzer/capture/merge.py);
- untimed two-line input (two raw dumps): the lines aligned by
  ``analyzer.analysis.align``;
- a single-line tap: one stream, frames classified by pairing.

Time follows one model (docs/time.md): chunk times are placed so that no chunk
starts before an earlier chunk of its line ended, nor (one clock) before an
earlier chunk of the other line was read ("Byte order"); skew between the lines
is corrected only when each line had its own clock ("Clocks"); and the link's
rate is followed when a rate-set command is ACKed ("Rate changes",
analyzer/capture/rates.py).

Each line's settings (rate, framing, byte time, frame gap, the rate changes
followed) have one owner: the ``LineSettings`` the capture makes of its options
(``line_settings``). The source is given them (``Source.read_with``), as are the
deframers; the merge reads them; a followed rate change changes them in one place.

A live source that falls behind marks chunks as not to be decoded (``undecoded``):
they still reach the ``on_chunk`` hook (the recording), the deframer is told of the gap,
and the bytes are counted and said (``Capture.undecoded``, analyzer/capture/undecoded.py).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

from dissectors import Deframer
from dissectors.event import Event, Origin
from dissectors.wire import LineSettings

from ..analysis.align import align
from ..analysis.echo import EchoStripper
from ..analysis.pairing import Pairer
from ..analysis.rate import RateChange
from ..analysis.transactions import OpenTransaction, TransactionRows
from ..extras import missing_extra
from ..lines import LINE_AB, Chunk
from ..sources import Source
from .collector import fewer_collections
from .faults import with_faults
from .merge import SWAP, merged
from .options import Options
from .rates import RateFollowing, inserted
from .undecoded import UndecodedBytes
from .wireclock import WireClock

if TYPE_CHECKING:
    import pandas as pd
    import pyarrow as pa


class Capture:
    """Iterable over the paired events of one capture, in wire order.

    >>> for ev in analyzer.open("ctl.bin", "dev.bin"):
    ...     print(ev.number, ev.kind, ev.command, ev.status)
    """

    def __init__(self, source: Source, options: Options | None = None,
                 on_warning: Callable[[str], None] | None = None) -> None:
        self.source = source
        self.options = options = options or Options()
        self.warnings: list[str] = []
        self.on_warning = on_warning     # also told every warning (API users)
        self.keep: Callable[[Event], bool] | None = None   # open(filter=...): what iterating gives
        self._origin: Origin | None = None
        # while ``batches()`` runs: told (chunk, offset of its first byte) for every chunk read
        self.on_chunk: Callable[[Chunk, int], None] | None = None
        self.clock = WireClock()         # how far the wire has been seen (pairing's timeouts)
        self.skew: float = 0.0           # seconds line B's times are moved later (analyzer.analysis.skew)
        # line B events from this (corrected) time on carry the current correction;
        # earlier ones an older one: latencies are comparable only on one side of it
        self.skew_from: float | None = None
        self._pairer: Pairer | None = None
        # each line's settings: they start at the options' and follow ACKed
        # rate-set commands (docs/time.md, "Rate changes")
        self.line_settings: dict[str, LineSettings] = options.line_settings(tuple(source.lines))
        self.rates = (RateFollowing(self.line_settings, options.baud, source.live,
                                    self.warn) if options.follow_rate else None)
        # two lines: copies of line A's frames on line B are dropped (analyzer.analysis.echo)
        # (timed input only: a copy is told from a real frame by overlapping its original)
        self.echo = (EchoStripper() if tuple(source.lines) == ("A", "B") and source.timed and options.strip_echo
                     else None)
        # the tap's lines were wired the other way round: read A as B and B as A
        # (settable while a live capture runs: the TUI's swap key)
        self.swap_lines = options.swap_lines
        # the files or ports as given (analyzer.info.CaptureInfo)
        self.inputs: tuple[str, ...] = ()
        self.undecoded_bytes = UndecodedBytes(self.warn)
        source.read_with(self.line_settings)
        source.report_to(self.warn)

    def warn(self, msg: str) -> None:
        """A warning of the capture: kept in ``warnings`` and told ``on_warning``."""
        self.warnings.append(msg)
        if self.on_warning is not None:
            self.on_warning(msg)

    @property
    def latest(self) -> float | None:
        """The latest wire time seen, idle ticks included (None without time)."""
        return self.clock.latest

    @property
    def baud(self) -> int:
        """The link's rate now."""
        baud = self.line_settings[self.source.lines[0]].baud
        assert baud is not None   # made of the options' rate (only a deframer alone has none)
        return baud

    @property
    def rate_changes(self) -> list[RateChange]:
        """The rate changes followed so far, in order."""
        return self.line_settings[self.source.lines[0]].changes

    @property
    def undecoded(self) -> dict[str, int]:
        """Bytes per line passed on to ``on_chunk`` (the recording) but not decoded:
        a live source fell behind, or they were still queued when it stopped."""
        return self.undecoded_bytes.by_line

    @property
    def lines(self) -> tuple[str, ...]:
        return self.source.lines

    @property
    def timed(self) -> bool:
        return self.source.timed

    @property
    def clocks(self) -> int:
        """How many clocks stamped the chunks (docs/time.md, "Clocks")."""
        return self.source.clocks if self.source.timed else 0

    def deframer(self, line: str) -> Deframer:
        """A deframer for ``line``, reading the line's settings."""
        return Deframer(line, settings=self.line_settings[line])

    @property
    def origin(self) -> Origin:
        """Where this capture's events come from (``Event.source``, ``Event.ts``)."""
        origin = self._origin
        if origin is None:
            origin = self._origin = Origin("+".join(self.inputs) or self.source.description,
                                           self.source.start_time)
        return origin

    def __iter__(self) -> Iterator[Event]:
        keep = self.keep
        for batch in self.batches():
            if keep is None:
                yield from batch
            else:
                for ev in batch:
                    if keep(ev):
                        yield ev

    def transactions(self) -> Iterator[dict]:
        """One dict per transaction (a command and its answers, analyzer/analysis/transactions.py),
        in the order of the commands: ``txn``, ``number`` (the command's event),
        ``command``, ``device``, ``status``, ``retransmission``, ``ack_latency``,
        ``result_latency``, ``answers``, ``fields`` (the command's, then its
        result's), ``problems``, and ``ts``/``source`` as events have them. With
        a filter, the transactions whose command matches it. Reads the capture."""
        keep = self.keep
        rows = TransactionRows()
        for batch in self.batches():
            for ev in batch:
                done = rows.add(ev)
                if done is not None and (keep is None or keep(done.command)):
                    yield _transaction_dict(done)
        done = rows.finish()
        if done is not None and (keep is None or keep(done.command)):
            yield _transaction_dict(done)

    def to_arrow(self) -> pa.Table:
        """The capture's events (those the filter keeps) as a pyarrow Table, the
        columns of the dataset's ``events`` table (docs/dataset.md). Needs the
        fleet extra (pyarrow)."""
        try:
            from ..formats.parquet_rows import events_table
        except ImportError as e:
            hint = missing_extra(e, "to_arrow()")
            if hint is None:
                raise
            raise ImportError(hint, name=e.name) from None
        return events_table(self, keep=self.keep)

    def to_pandas(self) -> pd.DataFrame:
        """``to_arrow()`` as a pandas DataFrame (needs the pandas extra)."""
        try:
            import pandas  # noqa: F401
        except ImportError as e:
            raise ImportError(missing_extra(e, "to_pandas()") or str(e), name=e.name) from None
        return self.to_arrow().to_pandas()

    def batches(self, on_chunk: Callable[[Chunk, int], None] | None = None) -> Iterator[list[Event]]:
        """The events in wire order, a list per step of the source; a live source's
        idle ticks give (often empty) lists too, so a consumer regains control
        while the line is quiet (the tap runner, analyzer/runner.py). Between
        steps, ``unsettled()`` shows what pairing still holds.

        ``on_chunk(chunk, offset)`` is told every chunk read, before its events,
        with the offset of its first byte on its line (recordings keep them)."""
        self.on_chunk = on_chunk
        with fewer_collections(self.options.tune_gc):
            pairer = self._pairer = Pairer(self.options.timeouts)
            push_many = pairer.push_many
            strip = self.echo.strip if self.echo is not None else None
            origin = self.origin
            clock = self.clock
            wire = self._wire_order()
            if self.source.faults is not None:   # a source that sees the line's own errors
                wire = with_faults(wire, self.source.faults, lambda: self.swap_lines)
            for batch in wire:
                if batch and strip is not None:
                    batch = strip(batch)
                out = push_many(batch) if batch else []
                if clock.ticked:   # timeouts expire while the line is quiet
                    clock.ticked = False
                    out += pairer.advance(clock.now)
                if out:
                    if origin.start_time is None:   # a source may learn it from its first bytes
                        origin.start_time = self.source.start_time
                    for ev in out:
                        ev.origin = origin
                yield out
            out = pairer.finish()
            for ev in out:
                ev.origin = origin
            yield out

    def unsettled(self) -> list[Event]:
        """Events pairing still holds (a command waiting for its answers, and what
        came after it), numbered and linked so far; their status may change. Call
        between steps of ``batches()``, from the thread iterating it."""
        pairer = self._pairer
        return pairer.held() if pairer is not None else []

    # --------------------------------------------------------- wire order
    def _wire_order(self) -> Iterator[list[Event]]:
        """Batches of events in wire order."""
        src = self.source
        if src.lines == (LINE_AB,):
            return self._single()
        if src.timed:
            return merged(self)
        aligned = align(self._line_batches("A"), self._line_batches("B"))
        return self.rates.followed(aligned) if self.rates is not None else aligned

    def _line_batches(self, line: str) -> Iterator[list[Event]]:
        """One line's events (untimed input), a list per chunk read."""
        d = self.deframer(line)
        feed = d.feed
        tap = self.on_chunk
        rates = self.rates if line == "A" else None
        physical = SWAP[line] if self.swap_lines else line
        for chunk in self.source.line_chunks(physical):
            if not chunk.data:
                continue                  # untimed input: no ticks
            if physical != line:
                chunk = type(chunk)(line, chunk.data, chunk.t)   # its own type: undecoded stays so
            if tap is not None:
                tap(chunk, d.offset)
            if rates is not None:
                rates.marked(line, chunk.data)
            yield feed(chunk.data, chunk.t)
        yield d.finish()

    def _single(self) -> Iterator[list[Event]]:
        """A single-line tap: one line, one clock; the deframer keeps its order."""
        d = self.deframer(LINE_AB)
        tap, clock, rates = self.on_chunk, self.clock, self.rates
        for chunk in self.source.chunks():
            if not chunk.data:            # an idle tick: time passed
                if chunk.t is not None:
                    clock.seen(chunk.t)
                    out = d.idle(chunk.t)
                    pending = d.pending_since   # bytes of an event not complete yet
                    clock.tick(chunk.t if pending is None else min(chunk.t, pending))
                    yield out
                continue
            if tap is not None:
                tap(chunk, d.offset)
            if chunk.undecoded:
                out = self.undecoded_bytes.skip(d, chunk)
                clock.seen(d.last_end)
                yield out
                continue
            if rates is not None:
                rates.marked(LINE_AB, chunk.data)
            out = d.feed(chunk.data, chunk.t)
            clock.seen(d.last_end)
            if rates is not None and out and rates.watching():
                found = rates.follow(out)
                if found:
                    out = inserted(out, found)
            yield out
        yield d.finish()
        self.undecoded_bytes.say(final=True)
        yield self.clock.at_end()


def _transaction_dict(txn: OpenTransaction) -> dict:
    row = txn.to_dict()
    cmd = txn.command
    row["ts"] = cmd.ts
    row["source"] = cmd.source
    return row
