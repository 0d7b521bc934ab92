"""Echo on a two-line tap: line B repeating line A's bytes (half-duplex adapters
and RS-485 converters hear themselves). A frame on line B identical to a command
on line A that overlaps it in time is a copy, not an answer: a real result never
equals its command (Table 3 swaps the groups, and result payloads are values).

Pure: ``strip(batch)`` drops the copies from a batch of events in wire order,
before pairing, and remembers which commands were echoed (for the doctor). The
bytes stay in recordings' raw topics: nothing is lost, only not decoded twice.
"""

from __future__ import annotations

from collections import deque

from dissectors.event import COMMAND, RESULT, Event


class EchoStripper:
    def __init__(self, window: float = 0.1) -> None:
        self.window = window        # seconds between a command and its copy, at most
        self._recent: deque[Event] = deque(maxlen=64)   # A commands of recent batches
        self.count = 0              # copies dropped
        self._echoed: list[Event] = []  # A commands whose copies were dropped, not yet taken

    def strip(self, batch: list[Event]) -> list[Event]:
        # commands of this batch and the last ones before it, by their bytes (a copy
        # can be stamped a little before its original, so both ways round)
        commands = [ev for ev in batch if ev.kind == COMMAND and ev.line == "A" and ev.t is not None]
        results = [ev for ev in batch if ev.kind == RESULT and ev.line == "B" and ev.t is not None]
        recent = self._recent
        if not results:
            recent.extend(commands)
            return batch
        # only commands with a result's bytes can have been copied: a real result
        # never has its command's bytes, so this is usually empty
        raws = {ev.raw for ev in results}
        by_raw: dict[bytes, list[Event]] = {}
        for ev in (*recent, *commands):
            if ev.raw in raws:
                by_raw.setdefault(ev.raw, []).append(ev)
        recent.extend(commands)
        if not by_raw:
            return batch
        copies: set[int] | None = None   # ids of the copies; usually none, and the batch is kept as it is
        window = self.window
        for ev in results:
            originals = by_raw.get(ev.raw)
            t = ev.t
            if originals and t is not None:   # (only timed events were taken)
                match = next((c for c in originals if c.t is not None and abs(c.t - t) < window), None)
                if match is not None:
                    originals.remove(match)    # one copy per command
                    self.count += 1
                    if len(self._echoed) < 10_000:   # nobody taking them: keep memory flat
                        self._echoed.append(match)
                    if copies is None:
                        copies = set()
                    copies.add(id(ev))
        if copies is None:
            return batch
        return [ev for ev in batch if id(ev) not in copies]

    def take_echoed(self) -> list[Event]:
        """The commands whose copies were dropped since the last call (the doctor's evidence)."""
        out, self._echoed = self._echoed, []
        return out
