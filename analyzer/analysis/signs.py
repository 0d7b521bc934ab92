"""The signs of the wiring that every reading of a capture can afford: per line, the
bytes and what they turned into; answer bytes on line A and command frames on
line B (lines swapped); commands answered as wired. A few additions an event, so
``decode``, ``stats``, ``convert`` and ``export`` keep them on every run and say
when the input is wrong (analyzer/listeners/wiring_check.py), while the wiring
doctor (analyzer/analysis/doctor.py) keeps them as the base of its rules.

The words come from the findings table (analyzer/analysis/findings.py):
``lines_swapped``, ``wrong_baud`` and ``not_this_protocol``, all errors."""

from __future__ import annotations

from collections import Counter, deque

from dissectors import dissect_command
from dissectors.event import COMMAND, NO_RESULT, NOISE, OK, RATE, RESULT, ST_NIC, Event

from .findings import FINDINGS, LINES_SWAPPED, NOT_THIS_PROTOCOL, WRONG_BAUD, Finding

MAX_EVIDENCE = 20
ANSWER_BYTES = {0x06, 0x15, 0x3F}   # ACK, NAK, NIC (§1.4.2)
GARBLED = 0.3       # a line with fewer of its bytes in valid frames or answers is garbled
UNRECOGNISED = 0.05  # every line this far below: not this protocol (or every line at a wrong rate)
MIN_BYTES = 100     # too few bytes to judge a line by


class Tally:
    """A count and some evidence (the first and the latest event numbers): memory
    stays flat however long the capture, and re-checking costs the same."""

    __slots__ = ("n", "first", "last")

    def __init__(self) -> None:
        self.n = 0
        self.first: list[int] = []
        self.last: deque[int] = deque(maxlen=MAX_EVIDENCE)

    def add(self, number: int) -> None:
        self.n += 1
        if len(self.first) < MAX_EVIDENCE:
            self.first.append(number)
        self.last.append(number)

    def __len__(self) -> int:
        return self.n

    def __iter__(self):
        return iter(self.evidence())

    def evidence(self) -> list[int]:
        return sorted(set(self.first[:MAX_EVIDENCE // 2]) | set(list(self.last)[-MAX_EVIDENCE // 2:]))


class LineTally:
    """Per line: bytes, and what they turned into."""

    def __init__(self) -> None:
        self.bytes = 0
        self.good_bytes = 0        # in frames whose checksum holds, and answer bytes where they belong
        self.noise_bytes = 0
        self.frames = 0
        self.bad_frames = 0
        self.noise_runs = 0
        self.errors = Tally()      # checksum errors and noise runs: count and evidence
        self.per_second: deque[list[int]] = deque()   # [second, errors] of the last minute (timed)
        self.by_length: Counter[tuple[bool, bool]] = Counter()   # (long frame, bad) -> count

    @property
    def error_count(self) -> int:
        return self.errors.n

    @property
    def share(self) -> float:
        """The share of the line's bytes that decode."""
        return self.good_bytes / self.bytes if self.bytes else 1.0

    def recent_errors(self, since: float) -> int:
        """Errors from capture time ``since`` on (the last minute is kept)."""
        return sum(n for sec, n in self.per_second if sec + 1 > since)

    def error(self, t: float | None, number: int) -> None:
        self.errors.add(number)
        if t is None:
            return                      # no time, no trend
        # one bucket per second of capture time: a flood of errors costs no memory
        sec = int(t)
        buckets = self.per_second
        if buckets and buckets[-1][0] == sec:
            buckets[-1][1] += 1
        else:
            buckets.append([sec, 1])
        while buckets and buckets[0][0] < sec - 61:
            buckets.popleft()


class WiringSigns:
    """Fed every event in wire order (``add``); ``findings(invocation)`` says what
    the signs show: swapped lines, a garbled line, or nothing of this protocol."""

    def __init__(self, lines: tuple[str, ...] = ("A", "B")) -> None:
        self.two_lines = tuple(lines) == ("A", "B")
        self.lines = {line: LineTally() for line in lines}
        self.answer_bytes_on_a = Tally()
        self.commands_on_b = Tally()
        self.ok_transactions = 0

    def add(self, ev: Event) -> bool:
        """Count ``ev``; True when it is a command frame travelling device→controller
        (line B), which is no answer to anything."""
        line = self.lines.get(ev.line)
        if line is None:
            line = self.lines[ev.line] = LineTally()
        n = len(ev.raw)
        line.bytes += n
        kind = ev.kind
        if kind == RATE:
            return False
        if kind == NOISE:
            line.noise_bytes += n
            line.noise_runs += 1
            line.error(ev.t, ev.number)
            if ev.line == "A" and all(b in ANSWER_BYTES for b in ev.raw):
                self.answer_bytes_on_a.add(ev.number)
            return False
        if kind in (COMMAND, RESULT) or ev.checksum_ok is not None:
            line.frames += 1
            bad = ev.checksum_ok is False
            line.by_length[(len(ev.payload or b"") >= 8, bad)] += 1
            if bad:
                line.bad_frames += 1
                line.error(ev.t, ev.number)
            else:
                line.good_bytes += n
        else:
            line.good_bytes += n      # ACK/NAK/NIC where they belong
        if kind == COMMAND:
            if ev.status in (OK, ST_NIC, NO_RESULT):
                self.ok_transactions += 1
        elif kind == RESULT and ev.request is None and ev.line == "B" and ev.payload is not None \
                and dissect_command(ev.payload).entry is not None:
            self.commands_on_b.add(ev.number)
            return True
        return False

    # --------------------------------------------------------------- findings
    def findings(self, swap_fix: str, baud_fix: str, live: bool = False) -> list[Finding]:
        """The error-level findings the signs show; ``swap_fix`` and ``baud_fix``
        say how to fix them where the traffic is read (doctor.Invocation), ``live``
        whether it is read off ports."""
        return self.swapped(swap_fix) + self.garbled(baud_fix, live)

    def swapped(self, swap_fix: str) -> list[Finding]:
        if not self.two_lines:
            return []
        a, b = len(self.answer_bytes_on_a), len(self.commands_on_b)
        if a + b < 6 or a + b <= 2 * self.ok_transactions:
            return []
        evidence = self.answer_bytes_on_a.evidence()[:10] + self.commands_on_b.evidence()[:10]
        return [FINDINGS[LINES_SWAPPED].found("A,B", evidence, answer_bytes=a, command_frames=b,
                                              answered=self.ok_transactions, swap_fix=swap_fix)]

    def garbled(self, baud_fix: str, live: bool = False) -> list[Finding]:
        """Lines that carry bytes of which almost none decode: in a file, every such
        line far below (nothing of the protocol anywhere) is one finding about the
        input; otherwise each garbled line is a wrong baud rate. A port carries
        serial traffic by nature: what fails to decode there is read at the wrong
        rate (``doctor --scan-baud`` finds it)."""
        carrying = {name: line for name, line in self.lines.items() if line.bytes}
        bad = {name: line for name, line in carrying.items() if line.bytes >= MIN_BYTES and line.share < GARBLED}
        if not bad:
            return []
        # nothing of the protocol on any line, and every line has said enough
        if not live and len(bad) == len(carrying) and all(line.share < UNRECOGNISED for line in bad.values()):
            total = sum(line.bytes for line in bad.values())
            good = sum(line.good_bytes for line in bad.values())
            evidence = sorted(n for line in bad.values() for n in line.errors.evidence())
            return [FINDINGS[NOT_THIS_PROTOCOL].found(",".join(bad), evidence, bytes=total, share=good / total,
                                                      baud_fix=baud_fix)]
        return [FINDINGS[WRONG_BAUD].found(
            name, line.errors.evidence(), line=name, bytes=line.bytes, share=line.share, noise_bytes=line.noise_bytes,
            bad_frames=line.bad_frames, baud_fix=baud_fix) for name, line in bad.items()]
