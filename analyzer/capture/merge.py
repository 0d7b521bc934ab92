"""Wire order for timed two-line captures (socat logs, live taps, recordings of
them): each line deframed, the events of both merged by the wire time of their
first byte, line B's skew corrected when each line had its own clock (docs/time.md,
"Clocks", analyzer/analysis/skew.py), and the link's rate changes found as the
events arrive (analyzer/capture/rates.py).

An event is released once no line can still produce an earlier one: not before
the oldest byte a deframer still holds, nor before the start of the latest chunk
minus a margin (chunks arrive in read order, and a later large chunk on the other
line can have started a little earlier). The margin counts chunks at the link's
byte time now, read from the lines' settings (``LineSettings``).
"""

from __future__ import annotations

from bisect import bisect_left
from collections.abc import Callable, Iterator
from operator import attrgetter
from typing import Protocol

from dissectors import Deframer
from dissectors.event import ACK, COMMAND, NAK, NOISE, Event
from dissectors.wire import LineSettings

from ..analysis.skew import SkewEstimator
from ..lines import Chunk
from ..sources import Source
from .rates import RateFollowing
from .undecoded import UndecodedBytes
from .wireclock import WireClock

_time = attrgetter("t")
SWAP = {"A": "B", "B": "A"}   # the other line: a tap whose ports were given the other way round
_SKEW_KINDS = frozenset((COMMAND, ACK, NAK, NOISE))


class CaptureToMerge(Protocol):
    """What the merge reads and sets of the capture it merges (analyzer/capture/capture.py)."""
    source: Source
    line_settings: dict[str, LineSettings]
    rates: RateFollowing | None
    on_chunk: Callable[[Chunk, int], None] | None
    clock: WireClock
    swap_lines: bool
    undecoded_bytes: UndecodedBytes
    skew: float
    skew_from: float | None

    @property
    def clocks(self) -> int: ...

    def deframer(self, line: str) -> Deframer: ...

    def warn(self, msg: str) -> None: ...


def merged(cap: CaptureToMerge) -> Iterator[list[Event]]:
    """The events of ``cap``'s timed lines in wire order, a batch per release.

    (This loop runs once per chunk: the common case, a chunk's events with no skew
    to apply and no rate-set near, is ``Merge.arrived`` inline.)"""
    deframers = {line: cap.deframer(line) for line in cap.source.lines}
    merge = Merge(cap, skew=cap.clocks == 2)
    arrived = merge.arrived
    plain = merge.estimator is None
    rates = cap.rates
    watch_all = rates is not None and rates.watch_all
    tap, clock, skip = cap.on_chunk, cap.clock, cap.undecoded_bytes.skip
    release_every = merge.release_every
    since_release = 0
    # one clock: a chunk read later started no earlier than the other line's
    # latest read (docs/time.md, "Byte order"); the deframers keep each line's order.
    # Times measured on the wire need no such floor: both lines send at once.
    one_clock = cap.clocks < 2 and not cap.source.wire_times
    last_read: float | None = None
    for chunk in cap.source.chunks():
        data = chunk.data
        t = chunk.t
        if not data:                  # an idle tick: time passed
            if t is None:             # without a time: nothing to mark
                continue
            merge.idle(deframers, t)
        else:
            # a timed source times every byte: bytes without a time are a broken
            # source, which fails here rather than being dropped unseen (and unrecorded)
            assert t is not None
            if cap.swap_lines:   # read a chunk: the TUI's swap key sets it while a live tap runs
                # its own type: a live tap's backlog stays undecoded on the other line too
                chunk = type(chunk)(SWAP[chunk.line], data, t)
            line = chunk.line
            if rates is not None and line != "B":   # (marked's own first test, saving a call a chunk)
                rates.marked(line, data)
            d = deframers[line]
            if tap is not None:
                tap(chunk, d.offset)
            if chunk.undecoded:
                arrived(skip(d, chunk))
            else:
                events = d.feed(data, t, last_read if one_clock else None)
                # (rates.watching() inline: this runs once a chunk)
                if plain and not (rates is not None and (watch_all or rates.marks > 0 or rates.follower.busy)):
                    merge.held += events
                else:
                    arrived(events)
            end = d.last_end
            if end is not None:       # (always: the chunk had a time)
                if last_read is None or end > last_read:
                    last_read = end
                if clock.latest is None or end > clock.latest:
                    clock.latest = end
        since_release += 1
        if not clock.ticked and since_release < release_every:
            continue
        since_release = 0
        yield merge.release(merge.mark(t, deframers))
    yield from merge.ending(deframers)


class Merge:
    """The events of a timed two-line capture not yet released, in arrival order,
    with line B's skew correction applied as it is learnt (``skew``: only when each
    line had its own clock, docs/time.md "Clocks") and the link's rate changes
    found as they arrive.

    They are sorted by time (stably: ties keep arrival order) at each release.
    They arrive nearly in time order, so the sort is a merge of a few runs:
    cheaper than a heap operation per event."""

    def __init__(self, capture: CaptureToMerge, skew: bool) -> None:
        self.capture = capture
        self.held: list[Event] = []
        self.estimator = SkewEstimator() if skew else None
        self.reported = 0.0   # the correction last said
        # live ports deliver in arrival order within a few reads; logs can hold big chunks
        live = capture.source.live
        self.chunks_ahead = 64 if live else 512
        # a file releases every 128 chunks: a release sorts what is held (the last
        # ~0.1 s of events), and a recording has a chunk an event, so releasing every
        # 32 sorted each event about four times (6% of re-dissecting a recording);
        # a live tap releases every 4, so the screen stays close to the wire
        self.release_every = 4 if live else 128

    def arrived(self, events: list[Event]) -> None:
        if not events:
            return
        cap = self.capture
        held = self.held
        estimator = self.estimator
        if estimator is None:
            held += events
        else:
            observe = estimator.observe
            for ev in events:
                # only commands, ACK/NAK bytes and noise (a garbled command) inform the
                # estimate; it sees the times as read
                if ev.kind in _SKEW_KINDS and observe(ev):
                    self._learnt(ev, estimator)
                if cap.skew and ev.line == "B":
                    _shift(ev, cap.skew)
                held.append(ev)
        rates = cap.rates
        if rates is not None and rates.watching():
            found = rates.follow(events)
            if found:
                held += found   # after their answers: sorting by time keeps them there

    def idle(self, deframers: dict[str, Deframer], t: float) -> None:
        """An idle tick at ``t``: time passed with no bytes; silences close frames."""
        self.capture.clock.seen(t)
        self.capture.clock.tick(t)
        for d in deframers.values():
            self.arrived(d.idle(t))

    def mark(self, t: float, deframers: dict[str, Deframer]) -> float:
        """The time before which every event is in (see the module doc): the
        latest chunk's start less the margin, or the oldest byte a deframer holds."""
        cap = self.capture
        byte_time = max(settings.byte_time for settings in cap.line_settings.values())
        mark = t - (self.chunks_ahead * byte_time + 0.05)
        for d in deframers.values():
            p = d.pending_since
            if p is not None and p < mark:
                mark = p
        if cap.clock.ticked:
            # pairing may only run up to what has been released: an answer still
            # held back here must not find its command already timed out
            cap.clock.now = mark
        return mark

    def _learnt(self, ev: Event, estimator: SkewEstimator) -> None:
        """The skew estimate moved. Line B events held back move with it, but only
        those near the pair that taught it (the estimator pairs within ``near``): a
        live tap has released anything older already, and decoding its recording,
        which holds events longer, must give the same times (live output equals
        decode of the recording)."""
        cap = self.capture
        delta = estimator.skew - cap.skew
        cap.skew = estimator.skew
        assert ev.t is not None   # the estimator learns from timed events only
        horizon = ev.t - estimator.near
        for other in self.held:
            if other.line == "B" and other.t is not None and other.t >= horizon:
                _shift(other, delta)
        if abs(cap.skew - self.reported) >= 0.001:
            self.reported = cap.skew
            cap.skew_from = horizon + cap.skew
            if cap.skew >= 0.00005:
                cap.warn(f"line B reads about {cap.skew * 1000:.1f} ms ahead of line A (adapter "
                         f"delays): its times are moved later by that much")
            else:   # the pairs that showed it have left the estimate's window
                cap.warn("line B no longer reads ahead of line A: its times are no longer moved")

    def ending(self, deframers: dict[str, Deframer]) -> Iterator[list[Event]]:
        """Once the chunks have ended: what the deframers and the merge still hold,
        then the tick that lets pairing run on to the latest time seen."""
        for d in deframers.values():
            self.arrived(d.finish())
        cap = self.capture
        cap.undecoded_bytes.say(final=True)
        yield self.release(None)
        yield cap.clock.at_end()

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


def _shift(ev: Event, delta: float) -> None:
    t, end = ev.t, ev.t_end
    if t is not None and end is not None:
        ev.t, ev.t_end = t + delta, end + delta
