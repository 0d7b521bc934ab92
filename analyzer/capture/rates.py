"""Following the link's rate while a capture is decoded (docs/time.md, "Rate
changes"): finding rate-set frames in the bytes read, watching the events only
when one may be among them, and, when a change is confirmed, changing the lines'
settings (``LineSettings``) in one place. The source back-dating its reads, the
deframers and the merge all read those settings, so they take the new byte time
at once, and a live tap's ports follow them. What counts as a change is decided
by ``analyzer.analysis.rate.RateFollower``, a pure observer of the events."""

from __future__ import annotations

from collections.abc import Callable, Iterator

from dissectors.event import Event
from dissectors.wire import LineSettings

from ..analysis.rate import RATE_MARK, RateChange, RateFollower


class RateFollowing:
    """One capture's following of the link's rate.

    ``marked`` is told every chunk read on a line commands travel on; ``follow``
    the events deframed while ``watching()``: a rate-set frame was seen in the
    bytes and has not turned up among the events yet, or a rate-set waits for its
    answer, or always for a live tap (its reads are small)."""

    def __init__(self, settings: dict[str, LineSettings], baud: int, watch_all: bool,
                 warn: Callable[[str], None]) -> None:
        self.settings = settings   # every line's: a change changes them all
        self.follower = RateFollower(baud)
        self.warn = warn
        self.watch_all = watch_all
        # rate-set frames seen in the bytes (RATE_MARK) and not yet in the events
        self.marks = 0
        self._misses = 0                     # looks since a mark last turned up (see follow)
        self._tails: dict[str, bytes] = {}   # each line's last bytes (a mark split between reads)

    def marked(self, line: str, data: bytes) -> None:
        """Count the rate-set frames ``data`` may hold (on a line commands travel).
        Once per chunk: the usual chunk has neither the mark's last two bytes nor a
        start byte among the last six before it, and costs two searches in C."""
        if line == "B":
            return
        tail = self._tails.get(line, b"")
        if (b"\x02C" in data and RATE_MARK.search(data)) or (0xF8 in tail and RATE_MARK.search(tail + data[:6])):
            self.marks += 1
        # the last six bytes read: a mark may begin in them and go on in the next read
        self._tails[line] = data[-6:] if len(data) >= 6 else (tail + data)[-6:]

    def watching(self) -> bool:
        return self.watch_all or self.marks > 0 or self.follower.busy

    def follow(self, events: list[Event]) -> list[Event]:
        """The rate events ``events`` cause (usually none), each with the
        link's new byte time applied from here on."""
        follower = self.follower
        seen = follower.marked
        out = [self._changed(change) for change in follower.follow(events)]
        if follower.marked != seen:
            self.marks = max(0, self.marks - (follower.marked - seen))
            self._misses = 0
        elif self.marks:
            # a mark that never became a frame (bytes cut or damaged): stop looking
            # after a while, or every later event would be looked at for nothing
            self._misses += 1
            if self._misses > 64:
                self.marks = self._misses = 0
        if follower.unconfirmed:
            self._unconfirmed()
        return out

    def followed(self, batches: Iterator[list[Event]]) -> Iterator[list[Event]]:
        """Untimed lines: the rate changes of the aligned stream, each right after
        the answer that made it (no byte times to change: the event is the news)."""
        for batch in batches:
            rates = self.follow(batch) if self.watching() else None
            yield inserted(batch, rates) if rates else batch

    def _changed(self, change: RateChange) -> Event:
        """Every line's settings take the new rate (the one place it changes: the
        source, the deframers, the merge and a live tap's ports follow them); the
        change becomes an event of the output."""
        for settings in self.settings.values():
            settings.set_rate(change.baud, change, at=change.t)
        if change.taken_back:
            self.warn(f"the device answered NIC to the rate change at line {change.command.line} byte "
                      f"{change.command.offset}: back to {change.baud} bps")
        return change.event()

    def _unconfirmed(self) -> None:
        for cmd, baud in self.follower.unconfirmed:
            self.warn(f"a broadcast rate change to {baud} bps (line {cmd.line} byte {cmd.offset}) got no "
                      f"ACK: decoding stays at {self.follower.baud} bps; if the devices switched, give --baud {baud}")
        self.follower.unconfirmed.clear()


def inserted(events: list[Event], rates: list[Event]) -> list[Event]:
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
