"""From a source to paired events: deframe each line, put the lines in wire order,
pair. This is what ``analyzer.open`` returns and what every CLI command reads.

- timed two-line input (socat logs, live taps): events of both lines merged by wire time;
- untimed two-line input (two raw dumps): the lines aligned by ``align``;
- a single-line tap: one stream, frames classified by pairing.

Time follows one model (docs/time.md): chunk times are placed so that no chunk
starts before an earlier chunk of its line ended, nor (one clock) before an
earlier chunk of the other line was read ("Byte order"); skew between the lines
is corrected only when each line had its own clock ("Clocks"); and the link's
rate is followed when a rate-set command is ACKed ("Rate changes").

A live source that falls behind marks chunks as not to be decoded (``undecoded``):
they still reach the ``on_chunk`` hook (the recording), the deframer is told of the gap,
and the bytes are counted and said (``Capture.undecoded``).
"""

from __future__ import annotations

import gc
from bisect import bisect_left
from dataclasses import dataclass, field
from operator import attrgetter
from typing import Callable, Iterator

from dissectors import Deframer
from dissectors.event import ACK, COMMAND, NAK, NOISE, Event, Origin
from dissectors.wire import byte_time

from .analysis.align import align
from .analysis.echo import EchoStripper
from .analysis.pairing import Pairer, Timeouts
from .analysis.rate import RATE_MARK, RateChange, RateFollower
from .analysis.skew import SkewEstimator
from .analysis.transactions import OpenTransaction, TransactionRows
from .info import recorded_options
from .sources import LINE_AB, Chunk, ReadSettings, Source, detect
from .sources.files import display_name


@dataclass
class Options:
    """Decoding options shared by the API and every CLI command."""
    baud: int = 9600
    data_bits: int = 8
    parity: str = "N"
    stop_bits: float = 1
    frame_gap: float | None = None        # seconds; default max(50 ms, 20 characters)
    timeouts: Timeouts = field(default_factory=Timeouts)
    tune_gc: bool = True                  # raise the GC's young threshold while iterating
    strip_echo: bool = True               # drop line B's copies of line A's frames (analyzer.analysis.echo)
    swap_lines: bool = False              # the tap's ports were given the other way round
    follow_rate: bool = True              # follow ACKed rate-set commands (docs/time.md, "Rate changes")
    tz: str | None = None                 # the zone of a socat log's stamps (None: this machine's)
    start_time: float | None = None       # epoch of a raw dump's first byte (None: from its mtime)
    # the options the user gave (flags, keywords): they win over what a recording
    # says of itself (docs/time.md, "Recordings"); the rest may be taken from it
    explicit: frozenset[str] = frozenset()

    @property
    def byte_time(self) -> float:
        return byte_time(self.baud, self.data_bits, self.parity, self.stop_bits)

    def settings(self) -> dict:
        """The settings a recording keeps and a flag overrides, by one name each
        (the ``Options`` field, or the ``Timeouts`` one with its unit)."""
        t = self.timeouts
        return {"baud": self.baud, "data_bits": self.data_bits, "parity": self.parity,
                "stop_bits": self.stop_bits, "ack_timeout": t.ack, "result_timeout": t.result,
                "timeouts": t.result_by_command, "frame_gap": self.frame_gap, "follow_rate": self.follow_rate,
                "swap_lines": self.swap_lines}

    @property
    def read_settings(self) -> ReadSettings:
        return ReadSettings(self.byte_time, tz=self.tz, start_time=self.start_time)


class Capture:
    """Iterable over the paired events of one capture, in wire order.

    >>> for ev in analyzer.open("ctl.bin", "dev.bin"):
    ...     print(ev.number, ev.kind, ev.command, ev.status)
    """

    def __init__(self, source: Source, options: Options | None = None,
                 on_warning: Callable[[str], None] | None = None) -> None:
        self.source = source
        self.options = options or Options()
        self.warnings: list[str] = []
        self.on_warning = on_warning     # also told every warning (API users)
        self.keep: Callable[[Event], bool] | None = None   # open(filter=...): what iterating gives
        self._origin: Origin | None = None
        # while ``batches()`` runs: told (chunk, offset of its first byte) for every chunk read
        self._tap: Callable[[Chunk, int], None] | None = None
        self._now: float | None = None   # after an idle tick: the time pairing may run on to
        self._tick = False               # an idle tick arrived: time passed with no bytes
        self._latest: float | None = None  # the latest time any chunk or tick showed
        self.skew: float = 0.0             # seconds line B's times are moved later (analyzer.analysis.skew)
        # line B events from this (corrected) time on carry the current correction;
        # earlier ones an older one: latencies are comparable only on one side of it
        self.skew_from: float | None = None
        self._pairer: Pairer | None = None
        # the link's rate now (docs/time.md, "Rate changes"): it starts at the
        # options' and follows ACKed rate-set commands
        self.baud = self.options.baud
        self._bt = self.options.byte_time
        source.byte_time = self._bt
        self.follower = RateFollower(self.baud) if self.options.follow_rate else None
        self.rate_changes: list[RateChange] = []
        # rate-set frames seen in the bytes (RATE_MARK) and not yet in the events:
        # the events are watched only then (a live tap's always: its reads are small)
        self._marks = 0
        self._misses = 0                     # looks since a mark last turned up (see _follow)
        self._tails: dict[str, bytes] = {}   # each line's last bytes (a mark split between reads)
        self._watch_all = bool(getattr(source, "live", False))
        self._deframers: list[Deframer] = []
        # two lines: copies of line A's frames on line B are dropped (analyzer.analysis.echo)
        # (timed input only: a copy is told from a real frame by overlapping its original)
        self.echo = (EchoStripper() if tuple(source.lines) == ("A", "B") and source.timed and self.options.strip_echo
                     else None)
        # the tap's lines were wired the other way round: read A as B and B as A
        # (settable while a live capture runs: the TUI's swap key)
        self.swap_lines = self.options.swap_lines
        # the files or ports as given (analyzer.info.CaptureInfo)
        self.inputs: tuple[str, ...] = ()
        # bytes per line passed on to on_chunk (the recording) but not decoded: a
        # live source fell behind, or they were still queued when it stopped
        self.undecoded: dict[str, int] = {}
        self._undecoded_said: float | None = None   # capture time of the last word on it
        self._undecoded_at_stop = 0                   # of which: still queued when the tap stopped
        source.warn = self._warn

    def _warn(self, msg: str) -> None:
        self.warnings.append(msg)
        if self.on_warning is not None:
            self.on_warning(msg)

    @property
    def latest(self) -> float | None:
        """The latest wire time seen, idle ticks included (None without time)."""
        return self._latest

    def _seen(self, t: float | None) -> None:
        if t is not None and (self._latest is None or t > self._latest):
            self._latest = t

    def _at_end(self) -> list[Event]:
        """Everything is released: let pairing run on to the latest time seen, so a
        recording decodes with the same timeouts its live tap applied."""
        if self._latest is not None:
            self._now, self._tick = self._latest, True
        return []

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

    def _deframer(self, line: str) -> Deframer:
        d = Deframer(line, byte_time=self._bt, frame_gap=self.options.frame_gap)
        self._deframers.append(d)
        return d

    # ------------------------------------------------------------ rate changes
    def _marked(self, line: str, data: bytes) -> None:
        """Count the rate-set frames ``data`` may hold (on a line commands travel).
        Once per chunk: the usual chunk has neither the mark's last two bytes nor a
        start byte among the last six before it, and costs two searches in C."""
        if line == "B":
            return
        tail = self._tails.get(line, b"")
        if (b"\x02C" in data and RATE_MARK.search(data)) or (0xF8 in tail and RATE_MARK.search(tail + data[:6])):
            self._marks += 1
        # the last six bytes read: a mark may begin in them and go on in the next read
        self._tails[line] = data[-6:] if len(data) >= 6 else (tail + data)[-6:]

    def _watching(self) -> bool:
        return self._watch_all or self._marks > 0 or self.follower.busy

    def _follow(self, events: list[Event]) -> list[Event]:
        """The rate events ``events`` cause (usually none), each with the
        link's new byte time applied from here on."""
        follower = self.follower
        seen = follower.marked
        out = [self._rate_changed(change) for change in follower.scan(events)]
        if follower.marked != seen:
            self._marks = max(0, self._marks - (follower.marked - seen))
            self._misses = 0
        elif self._marks:
            # a mark that never became a frame (bytes cut or damaged): stop looking
            # after a while, or every later event would be looked at for nothing
            self._misses += 1
            if self._misses > 64:
                self._marks = self._misses = 0
        if follower.unconfirmed:
            self._unconfirmed()
        return out

    def _rate_changed(self, change: RateChange) -> Event:
        """Deframing, the source's back-dating and a live tap's ports all take the
        new rate at once; the change becomes an event of the output."""
        o = self.options
        self.baud = change.baud
        self._bt = bt = byte_time(change.baud, o.data_bits, o.parity, o.stop_bits)
        for d in self._deframers:
            d.set_byte_time(bt)
        self.source.byte_time = bt
        set_rate = getattr(self.source, "set_rate", None)
        if set_rate is not None:   # a live tap: its ports listen at the new rate
            set_rate(change.baud)
        self.rate_changes.append(change)
        if change.taken_back:
            self._warn(f"the device answered NIC to the rate change at line {change.command.line} byte "
                       f"{change.command.offset}: back to {change.baud} bps")
        return change.event()

    def _unconfirmed(self) -> None:
        for cmd, baud in self.follower.unconfirmed:
            self._warn(f"a broadcast rate change to {baud} bps (line {cmd.line} byte {cmd.offset}) got no "
                       f"ACK: decoding stays at {self.baud} bps; if the devices switched, give --baud {baud}")
        self.follower.unconfirmed.clear()

    @property
    def origin(self) -> Origin:
        """Where this capture's events come from (``Event.source``, ``Event.ts``)."""
        origin = self._origin
        if origin is None:
            origin = self._origin = Origin("+".join(self.inputs) or self.source.description,
                                           getattr(self.source, "start_time", None))
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

    def to_arrow(self):
        """The capture's events (those the filter keeps) as a pyarrow Table, the
        columns of the dataset's ``events`` table (docs/dataset.md)."""
        from .formats.parquet_rows import events_table
        return events_table(self, keep=self.keep)

    def to_pandas(self):
        """``to_arrow()`` as a pandas DataFrame (needs pandas: pip install 'gimbalscope[pandas]')."""
        try:
            import pandas  # noqa: F401
        except ImportError:
            raise ImportError("to_pandas() needs pandas: pip install 'gimbalscope[pandas]'") from None
        return self.to_arrow().to_pandas()

    def batches(self, on_chunk: Callable[[Chunk, int], None] | None = None) -> Iterator[list[Event]]:
        """The events in wire order, a list per step of the source; a live source's
        idle ticks give (often empty) lists too, so a consumer regains control
        while the line is quiet (the tap runner, analyzer/runner.py). Between
        steps, ``unsettled()`` shows what pairing still holds.

        ``on_chunk(chunk, offset)`` is told every chunk read, before its events,
        with the offset of its first byte on its line (recordings keep them)."""
        self._tap = on_chunk
        if self.options.tune_gc:
            _gc_busy(+1)
        try:
            pairer = self._pairer = Pairer(self.options.timeouts)
            push_many = pairer.push_many
            strip = self.echo.strip if self.echo is not None else None
            origin = self.origin
            for batch in self._wire_order():
                if batch and strip is not None:
                    batch = strip(batch)
                out = push_many(batch) if batch else []
                if self._tick:   # timeouts expire while the line is quiet
                    self._tick = False
                    out += pairer.advance(self._now)
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
        finally:
            if self.options.tune_gc:
                _gc_busy(-1)

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
            return self._merged()
        aligned = align(self._line_batches("A"), self._line_batches("B"))
        return self._followed(aligned) if self.follower is not None else aligned

    def _followed(self, batches: Iterator[list[Event]]) -> Iterator[list[Event]]:
        """Untimed lines: the rate changes of the aligned stream, each right after
        the answer that made it (no byte times to change: the event is the news)."""
        for batch in batches:
            rates = self._follow(batch) if self._watching() else None
            yield _inserted(batch, rates) if rates else batch

    def _line_batches(self, line: str) -> Iterator[list[Event]]:
        """One line's events, a list per chunk read."""
        d = self._deframer(line)
        feed = d.feed
        tap = self._tap
        follow = self.follower is not None and line == "A"
        physical = _SWAP[line] if self.swap_lines else line
        for chunk in self.source.line_chunks(physical):
            if not chunk.data:
                continue                  # untimed input: no ticks
            if physical != line:
                chunk = Chunk(line, chunk.data, chunk.t)
            if tap is not None:
                tap(chunk, d.offset)
            if follow:
                self._marked(line, chunk.data)
            yield feed(chunk.data, chunk.t)
        yield d.finish()

    def _single(self) -> Iterator[list[Event]]:
        d = self._deframer(LINE_AB)
        tap = self._tap
        follow = self.follower is not None
        for chunk in self.source.chunks():
            if not chunk.data:            # an idle tick: time passed
                if chunk.t is not None:
                    self._seen(chunk.t)
                    out = d.idle(chunk.t)
                    pending = d.pending_since   # bytes of an event not complete yet
                    self._now = chunk.t if pending is None else min(chunk.t, pending)
                    self._tick = True
                    yield out
                continue
            if tap is not None:
                tap(chunk, d.offset)
            if chunk.undecoded:
                out = self._skip(d, chunk)
                self._seen(d.last_end)
                yield out
                continue
            if follow:
                self._marked(LINE_AB, chunk.data)
            out = d.feed(chunk.data, chunk.t)   # one line, one clock: the deframer keeps its order
            self._seen(d.last_end)
            if follow and out and self._watching():
                rates = self._follow(out)
                if rates:
                    out = _inserted(out, rates)
            yield out
        yield d.finish()
        self._say_undecoded(final=True)
        yield self._at_end()

    def _merged(self) -> Iterator[list[Event]]:
        """Merge timed lines by the wire time of each event's first byte.

        An event is released once no line can still produce an earlier one: not
        before the oldest byte a deframer still holds, nor before the start of the
        latest chunk minus a margin (chunks arrive in read order, and a later large
        chunk on the other line can have started a little earlier).
        """
        deframers = {line: self._deframer(line) for line in self.source.lines}
        # live ports deliver in arrival order within a few reads; logs can hold big chunks
        live = getattr(self.source, "live", False)
        chunks_ahead = 64 if live else 512
        # a file releases every 128 chunks: a release sorts what is held (the last
        # ~0.1 s of events), and a recording has a chunk an event, so releasing every
        # 32 sorted each event about four times (6% of re-dissecting a recording);
        # a live tap releases every 4, so the screen stays close to the wire
        release_every = 4 if live else 128
        merge = _Merge(self, skew=self.clocks == 2)
        arrived = merge.arrived
        # the common case, a chunk's events with no skew to apply and no rate-set
        # near, is merge.arrived inline: this loop runs once per chunk
        plain = merge.estimator is None
        follow = self.follower is not None
        follower, watch_all = self.follower, self._watch_all
        tap = self._tap
        since_release = 0
        # one clock: a chunk read later started no earlier than the other line's
        # latest read (docs/time.md, "Byte order"); the deframers keep each line's order
        one_clock = self.clocks < 2
        last_read = None
        for chunk in self.source.chunks():
            data = chunk.data
            if not data:                  # an idle tick: time passed
                if chunk.t is None:
                    continue
                self._seen(chunk.t)
                self._now, self._tick = chunk.t, True
                for d in deframers.values():
                    arrived(d.idle(chunk.t))
                t = chunk.t
            else:
                if self.swap_lines:
                    chunk = Chunk(_SWAP[chunk.line], data, chunk.t)
                line = chunk.line
                if follow and line != "B":   # (_marked's own first test, saving a call a chunk)
                    self._marked(line, data)
                d = deframers[line]
                if tap is not None:
                    tap(chunk, d.offset)
                t = chunk.t
                if chunk.undecoded:
                    arrived(self._skip(d, chunk))
                else:
                    events = d.feed(data, t, last_read if one_clock else None)
                    # (self._watching() inline: this runs once a chunk)
                    if plain and not (follow and (watch_all or self._marks > 0 or follower.busy)):
                        merge.held += events
                    else:
                        arrived(events)
                end = d.last_end
                if last_read is None or end > last_read:
                    last_read = end
                if self._latest is None or end > self._latest:
                    self._latest = end
            since_release += 1
            if not self._tick and since_release < release_every:
                continue
            since_release = 0
            mark = t - (chunks_ahead * self._bt + 0.05)
            for d in deframers.values():
                p = d.pending_since
                if p is not None and p < mark:
                    mark = p
            if self._tick:
                # pairing may only run up to what has been released: an answer still
                # held back here must not find its command already timed out
                self._now = mark
            yield merge.release(mark)
        for d in deframers.values():
            arrived(d.finish())
        self._say_undecoded(final=True)
        yield merge.release(None)
        yield self._at_end()

    # ------------------------------------------------------ undecoded bytes
    def _skip(self, d: Deframer, chunk: Chunk) -> list[Event]:
        """A chunk the source could not wait to decode (``chunk.undecoded`` says why:
        ``behind``, or ``stopped``): it reached the recording (``on_chunk``); the
        deframer closes what is pending and moves its offsets past it, so no frame
        is stitched across the gap."""
        n = len(chunk.data)
        self.undecoded[chunk.line] = self.undecoded.get(chunk.line, 0) + n
        if chunk.undecoded == "stopped":
            self._undecoded_at_stop += n
        else:
            self._say_undecoded(final=False, t=chunk.t)
        return d.skip(n, chunk.t)

    def _say_undecoded(self, final: bool, t: float | None = None) -> None:
        """One warning when decoding first falls behind, a running count at most
        every UNDECODED_EVERY seconds of capture while it stays behind, and the
        total at the end."""
        total = sum(self.undecoded.values())
        said = self._undecoded_said
        if not total or (not final and said is not None and (t is None or t - said < UNDECODED_EVERY)):
            return
        per_line = ", ".join(f"line {line}: {_bytes(n)}" for line, n in sorted(self.undecoded.items()))
        if final:
            why = []
            if total > self._undecoded_at_stop:
                why.append(f"{total - self._undecoded_at_stop:,} while decoding was behind the line")
            if self._undecoded_at_stop:
                why.append(f"{self._undecoded_at_stop:,} still waiting when the capture stopped")
            self._warn(f"{_bytes(total)} not decoded ({'; '.join(why)}; {per_line}); a recording keeps "
                       f"every byte read: decode it to see them")
        elif said is None:
            self._warn(f"decoding fell behind the line: bytes are passed over (a recording still keeps them) "
                       f"until it catches up (so far {per_line})")
        else:
            self._warn(f"decoding still behind: {_bytes(total)} not decoded so far ({per_line})")
        self._undecoded_said = t if t is not None else (said or 0.0)


_time = attrgetter("t")
UNDECODED_EVERY = 10.0   # capture seconds between updates of the undecoded count
_SWAP = {"A": "B", "B": "A"}
_SKEW_KINDS = frozenset((COMMAND, ACK, NAK, NOISE))


class _Merge:
    """The events of a timed two-line capture not yet released (``Capture._merged``),
    in arrival order, with line B's skew correction applied as it is learnt
    (``skew``: only when each line had its own clock, docs/time.md "Clocks") and
    the link's rate changes found as they arrive.

    They are sorted by time (stably: ties keep arrival order) at each release.
    They arrive nearly in time order, so the sort is a merge of a few runs:
    cheaper than a heap operation per event."""

    def __init__(self, capture: "Capture", skew: bool) -> None:
        self.capture = capture
        self.held: list[Event] = []
        self.estimator = SkewEstimator() if skew else None
        self.reported = 0.0   # the correction last said

    def arrived(self, events: list[Event]) -> None:
        if not events:
            return
        cap = self.capture
        held = self.held
        if self.estimator is None:
            held += events
        else:
            observe = self.estimator.observe
            for ev in events:
                # only commands, ACK/NAK bytes and noise (a garbled command) inform the
                # estimate; it sees the times as read
                if ev.kind in _SKEW_KINDS and observe(ev):
                    self._learnt(ev)
                if cap.skew and ev.line == "B":
                    _shift(ev, cap.skew)
                held.append(ev)
        if cap.follower is not None and cap._watching():
            rates = cap._follow(events)
            if rates:
                held += rates   # after their answers: sorting by time keeps them there

    def _learnt(self, ev: Event) -> None:
        """The skew estimate moved. Line B events held back move with it, but only
        those near the pair that taught it (the estimator pairs within ``near``): a
        live tap has released anything older already, and decoding its recording,
        which holds events longer, must give the same times (live output equals
        decode of the recording)."""
        cap, estimator = self.capture, self.estimator
        delta = estimator.skew - cap.skew
        cap.skew = estimator.skew
        horizon = ev.t - estimator.near
        for other in self.held:
            if other.line == "B" and other.t is not None and other.t >= horizon:
                _shift(other, delta)
        if abs(cap.skew - self.reported) >= 0.001:
            self.reported = cap.skew
            cap.skew_from = horizon + cap.skew
            if cap.skew >= 0.00005:
                cap._warn(f"line B reads about {cap.skew * 1000:.1f} ms ahead of line A (adapter "
                          f"delays): its times are moved later by that much")
            else:   # the pairs that showed it have left the estimate's window
                cap._warn("line B no longer reads ahead of line A: its times are no longer moved")

    def release(self, mark: float | None) -> list[Event]:
        """The held events before ``mark`` (all of them for None), in time order."""
        held = self.held
        if not held:
            return []
        held.sort(key=_time)
        if mark is None:
            self.held = []
            return held
        k = bisect_left(held, mark, key=_time)
        ready = held[:k]
        del held[:k]
        return ready


def _transaction_dict(txn: OpenTransaction) -> dict:
    row = txn.to_dict()
    cmd = txn.command
    row["ts"] = cmd.ts
    row["source"] = cmd.source
    return row


def _inserted(events: list[Event], rates: list[Event]) -> list[Event]:
    """``events`` with each rate event right after the answer that made it (it
    sits one byte past the answer on the answer's line)."""
    out = list(events)
    for rate in rates:
        at = len(out)
        for k, ev in enumerate(out):
            if ev.line == rate.line and ev.offset + len(ev.raw) == rate.offset and ev.kind != "rate":
                at = k + 1
                break
        out.insert(at, rate)
    return out


def _bytes(n: int) -> str:
    return f"{n:,} byte{'' if n == 1 else 's'}"


def _shift(ev: Event, delta: float) -> None:
    if ev.t is not None:
        ev.t += delta
        ev.t_end += delta


_gc_depth = 0
_gc_saved: tuple[int, ...] | None = None


def _gc_busy(step: int) -> None:
    """Decoding allocates millions of short-lived, cycle-free events; with the
    default young threshold (700) the collector scans each of them once or
    more before reference counting frees it, which costs as much as decoding.
    While any capture is being iterated, collect the young generation every
    100 000 allocations instead; the old thresholds come back afterwards."""
    global _gc_depth, _gc_saved
    if step > 0:
        if _gc_depth == 0:
            _gc_saved = gc.get_threshold()
            gc.set_threshold(100_000, *_gc_saved[1:])
        _gc_depth += 1
    else:
        _gc_depth -= 1
        if _gc_depth == 0 and _gc_saved is not None:
            gc.set_threshold(*_gc_saved)


def open_live(ports: list[str], options: Options | None = None,
              on_warning: Callable[[str], None] | None = None) -> Capture:
    """A live capture from one or two serial ports (device names or pyserial URLs)."""
    from .sources.serialport import SerialTap

    options = options or Options()
    tap = SerialTap(ports, baud=options.baud, data_bits=options.data_bits, parity=options.parity,
                    stop_bits=options.stop_bits)
    capture = Capture(tap, options, on_warning)
    capture.inputs = tuple(ports)
    return capture


def open(*paths: str, options: Options | None = None, on_warning: Callable[[str], None] | None = None,
         filter: str | None = None, **kw) -> Capture:
    """Open a capture: one socat log, one raw single-line dump, two raw dumps
    (line A then line B), or MCAP recordings of one tap (one, or its parts).
    Keyword arguments set ``Options`` fields (``baud=19200``); those given, like
    the ``explicit`` fields of ``options``, win over what a recording says of its
    own settings, and each that differs from it is said once (a warning).
    ``filter`` (the language of ``decode --filter``, analyzer/analysis/filter.py) keeps
    only the events it matches when iterating, in ``to_arrow()`` and in
    ``transactions()`` (by their command); a bad one raises ``FilterError``.
    Raises ``CaptureError`` with a one-line message for anything unreadable."""
    keep = None
    if filter is not None:
        from .analysis.filter import compile_filter
        keep = compile_filter(filter)   # first: a typo costs no file opened
    if options is None:
        timeouts = kw.pop("timeouts", None)
        given = frozenset(kw) | ({"ack_timeout", "result_timeout", "timeouts"} if timeouts else frozenset())
        options = Options(timeouts=timeouts or Timeouts(), explicit=given, **kw)
    source = detect(list(paths), options.read_settings)
    try:
        name = paths[0] if len(paths) == 1 else f"{paths[0]} (and {len(paths) - 1} more)"
        options, said = recorded_options(options, source, display_name(name))
    except BaseException:
        source.close()
        raise
    for message in said:
        source.warn_later(message)
    capture = Capture(source, options, on_warning)
    capture.inputs = tuple(paths)
    capture.keep = keep
    return capture
