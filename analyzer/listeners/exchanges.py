"""What ``gimbalscope diff`` keeps of a run besides its statistics: each
transaction as one line of text with no time in it (so that two captures are
aligned by their sequence of commands, not by when they came), and the latency
samples of each device and command, counted as ``stats`` counts them."""

from __future__ import annotations

from dissectors.event import ACK, COMMAND, NAK, RESULT, Event
from dissectors.wire import payload_text

from ..analysis.compare import Latencies
from ..runner import Listener


class Exchanges(Listener):
    """Each command's transaction as a line (``lines``: device, command payload,
    status, and the result's payload when one came), and ``latencies``."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.latencies = Latencies()
        self._results: dict[int, int] = {}   # a command's number -> its line, until its result comes
        self._parts: list[list[str]] = []

    def on_events(self, events: list[Event]) -> None:
        for ev in events:
            kind = ev.kind
            if kind == COMMAND:
                text = payload_text(ev.payload) if ev.payload is not None else ev.command or "?"
                if ev.number is not None:
                    self._results[ev.number] = len(self._parts)
                self._parts.append([ev.device or "?", text, ev.status or "pending"])
                continue
            txn = ev.transaction
            if txn is None:
                continue
            if kind == RESULT:
                at = self._results.pop(ev.request, None) if ev.request is not None else None
                if at is not None and ev.payload is not None:
                    self._parts[at].append(payload_text(ev.payload))
            if ev.latency is not None and ev.latency == ev.latency:   # NaN: none
                if kind in (ACK, NAK):
                    self.latencies.add("ack_latency", txn.device, txn.command, ev.latency)
                elif kind == RESULT:
                    self.latencies.add("result_latency", txn.device, txn.command, ev.latency)
        if len(self._results) > 4096:   # results come within a timeout: older commands have none
            for number in sorted(self._results)[:-1024]:
                del self._results[number]

    def on_stop(self) -> None:
        self.lines = [" ".join(parts) for parts in self._parts]
        self._parts = []
