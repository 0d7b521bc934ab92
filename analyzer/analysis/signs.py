"""The signs of the wiring that every reading of a capture can afford: per line, the
bytes and what they turned into; answer bytes on line A and command frames on
line B (lines swapped); commands answered as wired. A few additions an event, so
``decode``, ``stats``, ``convert`` and ``export`` keep them on every run and say
when the input is wrong (analyzer/listeners/wiring_check.py), while the wiring
doctor (analyzer/analysis/doctor.py) keeps them as the base of its rules.

Lines that do not decode keep their first bytes (``SAMPLE``), the rate the tap
read them at (from the events' byte times) and the rhythm of their turns: bytes
sent at one rate and read at another carry the reader's start and stop bits in
fixed places, and a garbled link still talks in commands and answers. That
tells a wrong rate (``wrong_baud``, naming the line's rate where one stands out:
analyzer/analysis/rate.py re-simulates each) from input that is not this
protocol at all (``not_this_protocol``: text, another protocol, random bytes).

The words come from the findings table (analyzer/analysis/findings.py):
``lines_swapped``, ``wrong_baud`` and ``not_this_protocol``, all errors."""

from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from dissectors import dissect_command
from dissectors.event import COMMAND, NO_RESULT, NOISE, OK, RATE, RESULT, ST_NIC, Event

from ..words import counted
from .findings import FINDINGS, LINES_SWAPPED, NOT_THIS_PROTOCOL, WRONG_BAUD, Finding
from .rate import PROTOCOL_RATES, rate_scores

MAX_EVIDENCE = 20
ANSWER_BYTES = {0x06, 0x15, 0x3F}   # ACK, NAK, NIC (§1.4.2)
GARBLED = 0.3       # a line with fewer of its bytes in valid frames or answers is garbled
UNRECOGNISED = 0.05  # every line this far below: not this protocol (or every line at a wrong rate)
MIN_BYTES = 100     # too few bytes to judge a line by
SAMPLE = 4096       # bytes kept per line of what did not decode: what they look like, which rate
# Bits per byte by which a sample is likelier to be this protocol misread at some
# rate than random bytes (analysis/rate.py): misread traffic scores 2 to 7 with the
# line at 1/8 to 12 times the tap's rate, random bytes and Modbus RTU below -2.5
# (tests/pure/test_doctor_rate.py); text is not scored.
MISREAD = 1.0       # the bytes alone say "a wrong rate"
MISREAD_WITH_RHYTHM = 0.0   # enough when the lines also take turns: command, answer, command...
NAME_MARGIN = 0.5   # the best rate this far ahead of the next is named
ASSUMED_BAUD = 9600  # the rate a capture without time was read at, unless told (§1.5.1's default)
RHYTHM = 3          # exchanges (a turn of line A, then one of line B) that make a request/answer rhythm
ANSWER_WITHIN = 1.0  # s: a turn of line B this soon after one of line A ends answers it
MAX_TURNS = 100_000  # turns counted per line (the counts are all that is kept)
PRINTABLE = frozenset(range(0x20, 0x7F)) | {0x09, 0x0A, 0x0D}


class Tally:
    """A count and some evidence (the first and the latest event numbers): memory
    stays flat however long the capture, and re-checking costs the same."""

    __slots__ = ("first", "last", "n")

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

    def state(self) -> list:
        return [self.n, self.first, list(self.last)]

    @classmethod
    def of_state(cls, state: list) -> Tally:
        tally = cls()
        tally.n, tally.first = int(state[0]), [int(x) for x in state[1]]
        tally.last.extend(int(x) for x in state[2])
        return tally


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
        self.sample = bytearray()   # the first SAMPLE bytes that are not valid frames

    def state(self) -> dict[str, Any]:
        return {"bytes": self.bytes, "good_bytes": self.good_bytes, "noise_bytes": self.noise_bytes,
                "frames": self.frames, "bad_frames": self.bad_frames, "noise_runs": self.noise_runs,
                "errors": self.errors.state(), "per_second": [list(b) for b in self.per_second],
                "by_length": [[long, bad, n] for (long, bad), n in self.by_length.items()],
                "sample": self.sample.hex()}

    @classmethod
    def of_state(cls, state: dict[str, Any]) -> LineTally:
        line = cls()
        for name in ("bytes", "good_bytes", "noise_bytes", "frames", "bad_frames", "noise_runs"):
            setattr(line, name, int(state[name]))
        line.errors = Tally.of_state(state["errors"])
        line.per_second.extend([int(sec), int(n)] for sec, n in state["per_second"])
        line.by_length.update({(bool(long), bool(bad)): int(n) for long, bad, n in state["by_length"]})
        line.sample = bytearray.fromhex(state["sample"])
        return line

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
        # the rate the tap read at (None: from the events' byte times, when they have time)
        self.read_baud: int | None = None
        self._rate_votes: Counter[int] = Counter()
        self._votes_left = 256
        # the rhythm of what does not decode: turns of line A, each answered by line B soon after
        self.turns = {"A": 0, "B": 0}
        self.exchanges = 0
        self._turn: list | None = None   # the latest turn: [line, start, end]
        self._guessed: tuple | None = None   # (what it was worked out from, the guess)

    def state(self) -> dict[str, Any]:
        """What the signs hold after the events so far, as JSON values: a recording
        keeps it with its stored columns (docs/mcap.md), so that reading the columns
        says what reading every event would (``of_state``)."""
        return {"lines": {name: line.state() for name, line in self.lines.items()},
                "answer_bytes_on_a": self.answer_bytes_on_a.state(), "commands_on_b": self.commands_on_b.state(),
                "ok_transactions": self.ok_transactions, "rate_votes": [[r, n] for r, n in self._rate_votes.items()],
                "votes_left": self._votes_left, "turns": self.turns, "exchanges": self.exchanges, "turn": self._turn}

    @classmethod
    def of_state(cls, lines: tuple[str, ...], state: dict[str, Any]) -> WiringSigns:
        """The signs ``state()`` gave; raises ``KeyError``, ``TypeError`` or
        ``ValueError`` for what it did not give."""
        signs = cls(lines)
        signs.take_state(state)
        return signs

    def take_state(self, state: dict[str, Any]) -> None:
        """Hold what ``state()`` gave, in place of what the events so far left."""
        self.lines = {str(name): LineTally.of_state(line) for name, line in state["lines"].items()}
        self.answer_bytes_on_a = Tally.of_state(state["answer_bytes_on_a"])
        self.commands_on_b = Tally.of_state(state["commands_on_b"])
        self.ok_transactions = int(state["ok_transactions"])
        self._rate_votes = Counter({int(r): int(n) for r, n in state["rate_votes"]})
        self._votes_left = int(state["votes_left"])
        self.turns = {str(k): int(v) for k, v in state["turns"].items()}
        self.exchanges = int(state["exchanges"])
        turn = state["turn"]
        self._turn = None if turn is None else [str(turn[0]), float(turn[1]), float(turn[2])]
        self._guessed = None

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
        if self._votes_left and ev.t is not None and ev.t_end is not None and n:
            self._vote(ev.t_end - ev.t, n)
        if kind == NOISE:
            line.noise_bytes += n
            line.noise_runs += 1
            line.error(ev.t, ev.number)
            if ev.line == "A" and all(b in ANSWER_BYTES for b in ev.raw):
                self.answer_bytes_on_a.add(ev.number)
            self._keep(line, ev)
            return False
        if kind in (COMMAND, RESULT) or ev.checksum_ok is not None:
            line.frames += 1
            bad = ev.checksum_ok is False
            line.by_length[(len(ev.payload or b"") >= 8, bad)] += 1
            if bad:
                line.bad_frames += 1
                line.error(ev.t, ev.number)
                self._keep(line, ev)
            else:
                line.good_bytes += n
        else:
            line.good_bytes += n      # ACK/NAK/NIC where they belong (or misread bytes that look like them)
            if len(line.sample) < SAMPLE:
                line.sample += ev.raw
        if kind == COMMAND:
            if ev.status in (OK, ST_NIC, NO_RESULT):
                self.ok_transactions += 1
        elif kind == RESULT and ev.request is None and ev.line == "B" and ev.payload is not None \
                and dissect_command(ev.payload).entry is not None:
            self.commands_on_b.add(ev.number)
            return True
        return False

    def _vote(self, span: float, n: int) -> None:
        """The rate the tap read at, from the byte time the capture gave an event
        of ``n`` bytes that took ``span`` seconds (its bytes are spaced at the rate
        it was read at, 8N1)."""
        self._votes_left -= 1
        if span <= 0:
            return
        baud = 10 * n / span
        rate = min(PROTOCOL_RATES, key=lambda r: abs(r - baud))
        if abs(rate - baud) <= 0.02 * rate:
            self._rate_votes[rate] += 1

    @property
    def read_rate(self) -> int | None:
        """The rate the capture was read at: as told, else as its byte times say."""
        if self.read_baud is not None:
            return self.read_baud
        if self._rate_votes:
            rate, votes = self._rate_votes.most_common(1)[0]
            if votes >= 3:
                return rate
        return None

    def _keep(self, line: LineTally, ev: Event) -> None:
        """Keep the first bytes of what did not decode, and the rhythm of its turns
        from line to line."""
        sample = line.sample
        if len(sample) < SAMPLE:
            sample += ev.raw[:SAMPLE - len(sample)]
        t = ev.t
        name = ev.line
        if t is None or not self.two_lines or self.turns[name] >= MAX_TURNS:
            return
        end = ev.t_end if ev.t_end is not None else t
        turn = self._turn
        if turn is not None and turn[0] == name:
            turn[2] = end                      # the same turn goes on
            return
        # the other line's turn; one of line B's soon after one of line A's answers it
        self.turns[name] += 1
        if name == "B" and turn is not None and turn[1] <= t <= turn[2] + ANSWER_WITHIN:
            self.exchanges += 1
        self._turn = [name, t, end]

    @property
    def rhythm(self) -> bool:
        """Turns of line A followed shortly by turns of line B, again and again, and
        most turns so: a controller's commands and the devices' answers, whatever
        their bytes. (A turn: what one line carries until the other line's next
        event, in wire order; a line that carries everything has one turn.)"""
        a, b = self.turns["A"], self.turns["B"]
        return self.exchanges >= RHYTHM and 2 * self.exchanges >= max(a, b)

    def misread(self, names: list[str]) -> Misread:
        """What the bytes of ``names``' lines that did not decode say about the
        rate (analysis/rate.py), worked out again only when there is more to go on."""
        read = self.read_rate
        key = (tuple(names), tuple(len(self.lines[n].sample) for n in names), read)
        if self._guessed is None or self._guessed[0] != key:
            sample = b"".join(bytes(self.lines[n].sample) for n in names)
            self._guessed = (key, Misread.of(sample, read))
        return self._guessed[1]

    # --------------------------------------------------------------- findings
    def findings(self, swap_fix: str, baud_fix: str, live: bool = False,
                 rate_fix: Callable[[int, int], str] | None = None) -> list[Finding]:
        """The error-level findings the signs show; ``swap_fix`` and ``baud_fix``
        say how to fix them where the traffic is read (doctor.Invocation), ``live``
        whether it is read off ports; ``rate_fix(rate, read)``, when given, how to
        fix a line read at ``read`` that runs at ``rate``."""
        return self.swapped(swap_fix) + self.garbled(baud_fix, live, rate_fix)

    def swapped(self, swap_fix: str) -> list[Finding]:
        if not self.two_lines:
            return []
        a, b = len(self.answer_bytes_on_a), len(self.commands_on_b)
        if a + b < 6 or a + b <= 2 * self.ok_transactions:
            return []
        evidence = self.answer_bytes_on_a.evidence()[:10] + self.commands_on_b.evidence()[:10]
        return [FINDINGS[LINES_SWAPPED].found("A,B", evidence, answer_bytes=counted(a, "ACK/NAK/NIC byte"),
                                              command_frames=counted(b, "command frame"),
                                              answered=counted(self.ok_transactions, "command"), swap_fix=swap_fix)]

    def garbled(self, baud_fix: str, live: bool = False,
                rate_fix: Callable[[int, int], str] | None = None) -> list[Finding]:
        """Lines that carry bytes of which almost none decode. A wrong rate leaves
        its signs (``Misread``: bytes a UART misreads, turns in a request/answer
        rhythm): each such line is ``wrong_baud``, naming the line's rate when one
        stands out. In a file, lines far below (nothing of the protocol anywhere)
        without those signs, and no valid frame on a shorter line, are one finding
        about the input, ``not_this_protocol``.
        A port carries serial traffic by nature: what fails to decode there is
        read at the wrong rate (``doctor --scan-baud`` finds it)."""
        carrying = {name: line for name, line in self.lines.items() if line.bytes}
        bad = {name: line for name, line in carrying.items() if line.bytes >= MIN_BYTES and line.share < GARBLED}
        if not bad:
            return []
        guess = self.misread(list(bad))
        wrong_rate = guess.looks_misread(self.rhythm)
        # nothing of the protocol on any line (the lines too short to judge have no valid
        # frame either), and no sign of a wrong rate
        if not live and not wrong_rate and all(line.share < UNRECOGNISED for line in bad.values()) \
                and all(line.frames == line.bad_frames for name, line in carrying.items() if name not in bad):
            return [_not_this_protocol(bad, guess, baud_fix)]
        return self._wrong_baud(bad, guess, wrong_rate, baud_fix, live, rate_fix)

    def _wrong_baud(self, bad: dict[str, LineTally], guess: Misread, wrong_rate: bool, baud_fix: str, live: bool,
                    rate_fix: Callable[[int, int], str] | None) -> list[Finding]:
        """``wrong_baud`` for each garbled line: the rate named when one stands out."""
        wb = FINDINGS[WRONG_BAUD]
        read = guess.read
        measured: dict[str, Any] = {"misread_bits_per_byte": guess.rounded_score, "exchanges": self.exchanges}
        if guess.named is not None:
            if live:
                said = wb.phrase("rate", baud=guess.named, read=read)
            else:
                # a file does not say what its tap read at: the rate it is read at here
                # (--baud) may not be it, and the ratio holds all the same
                ratio = Fraction(guess.named, read)
                times = wb.phrase("times", n=str(ratio)) if ratio.numerator != 1 \
                    else wb.phrase("part", n=ratio.numerator, d=ratio.denominator)
                said = wb.phrase("rate_file", baud=guess.named, read=read, ratio=times)
            fix = rate_fix(guess.named, read) if rate_fix is not None else baud_fix
            measured |= {"baud": guess.named, "read": read}
        else:
            said = wb.phrase("misread") if wrong_rate else ""
            fix = baud_fix
        exchanges = wb.phrase("rhythm", exchanges=counted(self.exchanges, "time")) if self.rhythm else ""
        out = []
        for name, line in bad.items():
            f = wb.found(name, line.errors.evidence(), line=name, bytes=line.bytes, share=line.share,
                         noise_bytes=counted(line.noise_bytes, "byte"),
                         bad_frames=counted(line.bad_frames, "frame with a bad checksum", "frames with bad checksums"),
                         misread=said, rhythm=exchanges,
                         baud_fix=fix)
            f.measured = dict(measured)
            out.append(f)
        return out

    def no_frames(self) -> bool:
        """Not one frame whose checksum holds, on any line."""
        return all(line.frames == line.bad_frames for line in self.lines.values())


# what bytes look like, when they are not the protocol
TEXT, SAME, BINARY = "text", "same", "binary"


def _not_this_protocol(bad: dict[str, LineTally], guess: Misread, baud_fix: str) -> Finding:
    """One finding about the input: its garbled lines carry nothing of the protocol."""
    total = sum(line.bytes for line in bad.values())
    good = sum(line.good_bytes for line in bad.values())
    evidence = sorted(n for line in bad.values() for n in line.errors.evidence())
    nt = FINDINGS[NOT_THIS_PROTOCOL]
    look = guess.look
    if look == TEXT:
        looks = nt.phrase("text", excerpt=guess.excerpt)
    elif look == SAME:
        looks = nt.phrase("same", value=guess.value)
    else:
        looks = nt.phrase("binary")
    f = nt.found(",".join(bad), evidence, bytes=total, share=good / total, looks=looks, baud_fix=baud_fix)
    f.measured = {"looks": look, "misread_bits_per_byte": guess.rounded_score}
    return f


def looks_of(sample: bytes) -> tuple[str, str, str]:
    """(TEXT, SAME or BINARY; a short excerpt of the text; the value repeated, hex)."""
    if not sample:
        return BINARY, "", ""
    value, count = Counter(sample).most_common(1)[0]
    if count >= 0.9 * len(sample):
        return SAME, "", f"{value:02X}"
    if sum(b in PRINTABLE for b in sample) >= 0.9 * len(sample):
        text = " ".join(sample.decode("ascii", "replace").split())
        return TEXT, text if len(text) <= 40 else text[:40].rstrip() + "…", ""
    return BINARY, "", ""


@dataclass(frozen=True)
class Misread:
    """What bytes that do not decode say about the rate they were read at: how
    much likelier they are this protocol misread at the best standard rate than
    random bytes (bits per byte, analysis/rate.py), that rate when it stands out
    from the others, and what they look like otherwise."""
    read: int                 # the rate they were read at (ASSUMED_BAUD when not known)
    best: int | None          # the rate whose misread traffic they are most like
    score: float              # bits per byte (below 0: unlike any)
    named: int | None         # ``best``, when well ahead of the next rate
    look: str                 # TEXT, SAME or BINARY
    excerpt: str = ""
    value: str = ""

    @classmethod
    def of(cls, sample: bytes, read: int | None) -> Misread:
        look, excerpt, value = looks_of(sample)
        at = read if read is not None else ASSUMED_BAUD
        scores = rate_scores(sample, at) if look == BINARY else {}
        if not scores:
            # text is not misread traffic, nor is one byte over and over (a line held low reads 00)
            return cls(at, None, -math.inf, None, look, excerpt, value)
        ranked = sorted(scores.items(), key=lambda kv: -kv[1])
        (best, score), second = ranked[0], ranked[1][1] if len(ranked) > 1 else -math.inf
        named = best if score >= MISREAD and score - second >= NAME_MARGIN and len(sample) >= 64 else None
        return cls(at, best, score, named, look, excerpt, value)

    @property
    def rounded_score(self) -> float | None:
        return round(self.score, 2) if math.isfinite(self.score) else None

    def looks_misread(self, rhythm: bool) -> bool:
        """The bytes are this protocol read at a wrong rate: clearly, or somewhat and
        in the rhythm of commands and answers."""
        return self.score >= MISREAD or (rhythm and self.score >= MISREAD_WITH_RHYTHM)
