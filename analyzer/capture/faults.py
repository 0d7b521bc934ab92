"""Line faults onto events: a source that sees below the bytes (a logic capture's
software UART, a USB adapter's line status) tells each framing or parity error,
break and overrun as a ``LineFault`` at a byte offset of its line; the event
holding that byte carries it as a problem (``dissectors.problems.LINE``), so the
timeline, filters (``"line error" in problems``) and every output show it where
it happened.

A fault whose byte is in no event (bytes after the last one, or a break before
the capture's first byte) goes on the next event of its line, if any.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator

from dissectors.event import Event

from ..lines import LineFault
from .merge import SWAP


def with_faults(batches: Iterator[list[Event]], faults: list[LineFault],
                swapped: Callable[[], bool]) -> Iterator[list[Event]]:
    """``batches`` with each event given the faults of its bytes. ``faults`` is the
    source's list, which grows as it reads (a fault is told before the chunk
    holding its byte); ``swapped()`` says whether the capture reads the lines
    the other way round now (the source names them as wired)."""
    waiting: dict[str, deque[LineFault]] = {}
    taken = 0
    for batch in batches:
        if taken < len(faults):
            for f in faults[taken:]:
                waiting.setdefault(f.line, deque()).append(f)
            taken = len(faults)
        if any(waiting.values()):
            swap = swapped()
            for ev in batch:
                raw = ev.raw
                if not raw:
                    continue
                queue = waiting.get(SWAP.get(ev.line, ev.line) if swap else ev.line)
                if not queue:
                    continue
                end = ev.offset + len(raw)
                mine = []
                while queue and queue[0].offset < end:
                    mine.append(queue.popleft().problem)
                if mine:
                    ev.note(*mine)
        yield batch
