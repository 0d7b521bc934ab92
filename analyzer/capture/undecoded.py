"""Bytes a live source could not wait to decode (``Chunk.undecoded``): they still
reach the ``on_chunk`` hook (the recording keeps them), the deframer is told of
the gap, and the bytes are counted per line and said as warnings."""

from __future__ import annotations

from collections.abc import Callable

from dissectors import Deframer
from dissectors.event import Event

from ..lines import Chunk
from ..words import counted

UNDECODED_EVERY = 10.0   # capture seconds between updates of the undecoded count


class UndecodedBytes:
    """The count of bytes passed over, per line, and what is said of it."""

    def __init__(self, warn: Callable[[str], None]) -> None:
        self.warn = warn
        # bytes per line passed on to on_chunk (the recording) but not decoded: a
        # live source fell behind, or they were still queued when it stopped
        self.by_line: dict[str, int] = {}
        self._said: float | None = None   # capture time of the last word on it
        self._at_stop = 0                 # of which: still queued when the tap stopped

    def skip(self, d: Deframer, chunk: Chunk) -> list[Event]:
        """A chunk the source could not wait to decode (``chunk.undecoded`` says why:
        ``behind``, or ``stopped``): it reached the recording (``on_chunk``); the
        deframer closes what is pending and moves its offsets past it, so no frame
        is stitched across the gap."""
        n = len(chunk.data)
        self.by_line[chunk.line] = self.by_line.get(chunk.line, 0) + n
        if chunk.undecoded == "stopped":
            self._at_stop += n
        else:
            self.say(final=False, t=chunk.t)
        return d.skip(n, chunk.t)

    def say(self, final: bool, t: float | None = None) -> None:
        """One warning when decoding first falls behind, a running count at most
        every UNDECODED_EVERY seconds of capture while it stays behind, and the
        total at the end."""
        total = sum(self.by_line.values())
        said = self._said
        if not total or (not final and said is not None and (t is None or t - said < UNDECODED_EVERY)):
            return
        per_line = ", ".join(f"line {line}: {counted(n, 'byte')}" for line, n in sorted(self.by_line.items()))
        if final:
            why = []
            if total > self._at_stop:
                why.append(f"{total - self._at_stop:,} while decoding was behind the line")
            if self._at_stop:
                why.append(f"{self._at_stop:,} still waiting when the capture stopped")
            self.warn(f"{counted(total, 'byte')} not decoded ({'; '.join(why)}; {per_line}); a recording keeps "
                      f"every byte read: decode it to see them")
        elif said is None:
            self.warn(f"decoding fell behind the line: bytes are passed over (a recording still keeps them) "
                      f"until it catches up (so far {per_line})")
        else:
            self.warn(f"decoding still behind: {counted(total, 'byte')} not decoded so far ({per_line})")
        self._said = t if t is not None else (said or 0.0)
