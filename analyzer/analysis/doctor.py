"""The wiring doctor: what is wrong with the link, from the traffic alone.

Pure: ``WiringDoctor.add(event)`` takes paired events in wire order (and
``echoed(command)`` for echoes the capture stripped); ``findings()`` says what
the traffic shows so far, each finding with a severity, its evidence (event
numbers) and the fix to try. Thresholds ask for several pieces of evidence, so a
clean link gives no warning (tested on clean demo runs).

The rules measure; the words are in the findings table (analyzer/analysis/findings.py):
each rule names its entry and fills its templates with what it measured, and the
table says which finding explains which (a root cause hides its consequences).

What each finding rests on (spec §1.4.2: a device answers a command on its own
line with ACK/NAK, then NIC or a result frame; Table 3 addresses):
- lines swapped: answer bytes (ACK/NAK/NIC) on line A, command frames on line B;
- wrong baud rate: bytes arrive but almost nothing decodes on a line, and they
  are this protocol misread (analysis/signs.py; the rate is named when one
  stands out, analysis/rate.py); not this protocol when they are not;
- no frames: not one valid frame, and what the capture holds instead;
- echo: line B repeats line A's frames byte for byte;
- silent device / dead link: commands to an address, no answer ever;
- noisy link: checksum errors, noise runs, NAKs per line and per minute, and
  whether long frames fail more often than short ones (a clock or baud mismatch);
- controller: commands before the previous ACK, retries sooner than the device
  answers, giving up on IX before it ends (it takes up to a minute);
- slow answers: a device's ACK latency drifting up;
- rate change: a device that stops answering once the link's rate was changed
  (Table 4; docs/time.md, "Rate changes"): it ACKed and did not switch, or
  cannot talk at the new rate;
- device map: who answers, what each NICs (its firmware), D? identity.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from statistics import median
from typing import Any

from dissectors.event import ACK, COMMAND, NAK, NIC, NO_ACK, NO_RESULT, NOISE, RATE, RESULT, ST_NAK, ST_NIC, Event
from dissectors.problems import NO_RESULT_SENT_AGAIN, UNANSWERED_SUPERSEDED

from ..physical.bitrate import STANDARD_RATES, nominal_rate
from ..physical.report import LineReport
from ..styles import ERROR, INFO, WARNING  # the severities every view colours
from ..words import counted
from .findings import (
    CLOCK_OFF,
    CONTROLLER_FAST_RETRY,
    CONTROLLER_IX_TIMEOUT,
    CONTROLLER_NO_RETRY,
    CONTROLLER_NO_WAIT,
    DEAD_LINK,
    DEVICE_MAP,
    ECHO,
    FINDINGS,
    FRAMING_ERRORS,
    GLITCHES,
    LINE_INVERTED,
    NAK_BURST,
    NO_FRAMES,
    NOISY_LINK,
    RATE_NONSTANDARD,
    SILENT_AFTER_RATE,
    SILENT_DEVICE,
    SLOW_ANSWERS,
    TWO_DRIVERS,
    Finding,
    unexplained,
)
from .signs import GARBLED, MIN_BYTES, SAME, TEXT, LineTally, WiringSigns, looks_of
from .signs import MAX_EVIDENCE as _MAX_EVIDENCE
from .signs import Tally as _Tally
from .stats import Latency

SEVERITY_ORDER = {ERROR: 0, WARNING: 1, INFO: 2}
# Without time (raw dumps) a failed command the controller has not sent again
# within this many later commands was never retried (with time: 3 ACK timeouts).
RETRY_WINDOW = 8
_MAX_FAILED = 1024       # failed first attempts watched at once; the oldest is decided first
_MAX_DEVICES = 256       # addresses tracked one by one; random bytes can name thousands
_MAX_NIC = 64            # NIC'd command ids kept per device
UNTIMED_CHECK_EVERY = 2000   # events between checks when the capture has no time
# A live tap opened mid-frame reads a little garbage before the first frame: "no
# frame" waits for this many bytes or seconds of them (a file is read whole).
NO_FRAME_BYTES = 300
NO_FRAME_SECONDS = 2.0


@dataclass(frozen=True)
class Invocation:
    """How the traffic is being read, so that a fix names what works there: the
    files or ports as given, whether they are live ports, the subcommand reading
    them, and whether a TUI (with its swap key) is on screen."""
    inputs: tuple[str, ...] = ()
    live: bool = False
    command: str | None = None    # "decode", "live", "demo", "doctor"...; None: not known
    tui: bool = False
    baud: int | None = None       # the rate the tap read at, as given (None: from the capture's byte times)

    def swap_fix(self) -> str:
        """How to read the two lines the other way round, here."""
        ins = self.inputs
        if self.live:
            fixes = []
            if self.command == "demo":
                # the demo picks its own ports and has no --swap-lines
                fixes.append("the tap's two ports are the other way round (line A must carry the "
                             "controller's commands)")
            elif len(ins) == 2:
                fixes.append(f"give the ports the other way round: gimbalscope live {ins[1]} {ins[0]} "
                             f"(or add --swap-lines)")
            else:
                fixes.append("give the two ports the other way round, or add --swap-lines")
            if self.tui:
                fixes.append("press x here to swap them now")
            return "; ".join(fixes)
        if len(ins) == 2:
            if self.command == "export":   # one input of two files: FILE+FILE
                return f"export them the other way round: gimbalscope export {ins[1]}+{ins[0]} (or add --swap-lines)"
            # the command that read them, where it takes the same inputs (the doctor's fix is to decode)
            cmd = self.command if self.command in ("stats", "convert") else "decode"
            out = " -o OUT" if cmd == "convert" else ""
            return (f"give the dumps the other way round: gimbalscope {cmd} {ins[1]} {ins[0]}{out} "
                    f"(or gimbalscope {cmd} {ins[0]} {ins[1]}{out} --swap-lines)")
        if len(ins) == 1:
            return f"read its lines the other way round: gimbalscope decode {ins[0]} --swap-lines"
        return "read the lines the other way round (--swap-lines; Options(swap_lines=True) in the API)"

    def baud_fix(self) -> str:
        """How to find the line's rate, here."""
        if self.live and self.command != "demo":
            port = " ".join(self.inputs) if self.inputs else "PORT"
            return (f"find the rate: stop the tap, then gimbalscope doctor --scan-baud {port} (listens at each "
                    f"standard rate); check the data bits, parity and stop bits too")
        if not self.live and self.inputs:
            return (f"decode it at the line's rate: gimbalscope decode {' '.join(self.inputs)} --baud RATE "
                    f"(the rates of §1.5.1: 1200 to 115200); check the data bits, parity and stop bits too")
        return ("find the rate: gimbalscope doctor --scan-baud PORT listens at each standard rate; "
                "check the data bits, parity and stop bits too")

    def rate_fix(self, rate: int, read: int, waveform: bool = False) -> str:
        """How to read, here, a line that runs at ``rate`` and was read at ``read``.
        A byte capture holds what the tap's UART made of the line: read at the wrong
        rate, its bytes cannot be decoded afterwards, only captured again; a
        waveform (a logic analyser's) is decoded again at the right rate."""
        if self.live and self.command != "demo":
            ports = " ".join(self.inputs) if self.inputs else "PORT"
            return (f"tap it at {rate} bps: gimbalscope live {ports} --baud {rate} (stop this tap first; "
                    f"gimbalscope doctor --scan-baud {ports} confirms the rate)")
        if self.live:
            return self.baud_fix()
        if waveform and self.inputs:
            return f"decode it at {rate} bps: gimbalscope decode {' '.join(self.inputs)} --baud {rate}"
        return (f"capture it again with the tap at the line's rate, {rate} bps if it read at {read} "
                f"(gimbalscope live PORT --baud {rate}): the bytes are what the tap's UART read, and no --baud "
                f"decodes them now")


# the rules whose findings depend on how the traffic is read, not on its events alone
READING_RULES = ("waveform", "wiring", "no_frames")
# what a finding's state keeps: all but when it was first found (``findings`` dates it)
_UNDATED = ("first_seen", "first_seen_event")


def _finding_state(f: Finding) -> dict[str, Any]:
    return {k: v for k, v in dataclasses.asdict(f).items() if k not in _UNDATED}


def _densest(times: list[float], window: float) -> int:
    """The most of ``times`` (ascending) within any ``window`` seconds: one pass."""
    best = lo = 0
    for hi, t in enumerate(times):
        while times[lo] <= t - window:
            lo += 1
        best = max(best, hi - lo + 1)
    return best


def _length_note(line: LineTally) -> tuple[str, str]:
    """Do long frames fail more often than short ones (a clock or baud mismatch)?
    The note on it, and the fix to try first."""
    noisy = FINDINGS[NOISY_LINK]
    bl = line.by_length
    long_n, short_n = bl[(True, False)] + bl[(True, True)], bl[(False, False)] + bl[(False, True)]
    if long_n >= 10 and short_n >= 10:
        long_rate, short_rate = bl[(True, True)] / long_n, bl[(False, True)] / short_n
        if bl[(True, True)] >= 3 and long_rate > 2 * max(short_rate, 0.005):
            return noisy.phrase("length", long=long_rate, short=short_rate), noisy.phrase("check_clock")
    return "", noisy.phrase("check_cable")


class DeviceTally:
    """What the doctor counts of one device address."""

    def __init__(self) -> None:
        self.commands = 0
        self.answers = 0
        self.lines: set[str] = set()
        self.nic: set[str] = set()             # up to _MAX_NIC command ids
        self.identity: str | None = None
        self.ack_count = 0
        self.first_acks: list[float] = []                  # the first ACK latencies (up to 200)
        self.last_acks: deque[float] = deque(maxlen=200)   # and the latest
        self.unanswered = _Tally()
        # since the link's latest rate change: commands to it, and its answers
        self.commands_since_rate = 0
        self.answers_since_rate = 0
        self.unanswered_since_rate = _Tally()


class ControllerWatch:
    """What the controller does, from its commands in wire order (``command``):
    whether it waits for answers, how soon it sends a failed command again,
    whether it does at all, and whether it gives IX the time it takes."""

    def __init__(self, ack_timeout: float = 0.5) -> None:
        self.ack_timeout = ack_timeout
        self.commands = 0
        self.next_gaps: deque[tuple[int, float]] = deque(maxlen=500)   # (unanswered command, s to the next)
        self._prev_cmd: Event | None = None
        self._prev_failed: Event | None = None     # the previous command, if it failed (retry gaps)
        self.retry_gaps: deque[tuple[int, float]] = deque(maxlen=500)  # (retransmission, s after the failure)
        # NAK'd / unanswered first attempts not yet retried, oldest first:
        # number -> (event, how many commands had come by then)
        self.failed: dict[int, tuple[Event, int]] = {}
        self.never_retried = _Tally()
        self.retried = 0                            # failed first attempts sent again
        self.ix_given_up = _Tally()

    def command(self, ev: Event) -> None:
        """The next command, paired (its status final)."""
        self.commands += 1
        prev, prev_failed = self._prev_cmd, self._prev_failed
        self._prev_cmd = ev
        self._prev_failed = ev if ev.status in (ST_NAK, NO_ACK) else None
        self._patience(ev, prev)
        if ev.command == "IX" and ev.status == NO_RESULT and ev.has_problem(NO_RESULT_SENT_AGAIN):
            self.ix_given_up.add(ev.number)
        self._retries(ev, prev, prev_failed)

    def _patience(self, ev: Event, prev: Event | None) -> None:
        """How long the controller waited for an ACK that did not come."""
        if prev is not None and prev.status == NO_ACK and prev.t_end is not None and ev.t is not None \
                and prev.has_problem(UNANSWERED_SUPERSEDED):
            self.next_gaps.append((prev.number, ev.t - prev.t_end))

    def _retries(self, ev: Event, prev: Event | None, prev_failed: Event | None) -> None:
        """A retransmission repeats a failed command (the gap says how patient the
        controller is); a failed first attempt is watched: will it be sent again?"""
        if ev.retransmission:
            if prev_failed is not None and prev_failed.t_end is not None and ev.t is not None \
                    and prev_failed.status == NO_ACK:
                self.retry_gaps.append((ev.number, ev.t - prev_failed.t_end))
            # pairing marks a retransmission of the command just before it (even
            # when a bit error had changed that one's address)
            if prev is not None and self.failed.pop(prev.number, None) is not None:
                self.retried += 1
        self._expire_failed(ev)
        if ev.status in (ST_NAK, NO_ACK) and not ev.retransmission:
            self._watch_failed(ev)

    def _watch_failed(self, ev: Event) -> None:
        self.failed[ev.number] = (ev, self.commands)
        if len(self.failed) > _MAX_FAILED:
            # so many failures in flight: the oldest has been passed over by a thousand
            # commands since, so it was not retried
            self._give_up_oldest_failed()

    def _expire_failed(self, ev: Event) -> None:
        """Failed commands the controller moved on from without resending: after 3
        ACK timeouts with time, after RETRY_WINDOW later commands without. Commands
        come in wire order, so the oldest expire first."""
        while self.failed:
            num = next(iter(self.failed))
            first, count = self.failed[num]
            if ev.t is not None and first.t is not None:
                expired = ev.t - first.t > 3 * self.ack_timeout
            else:
                expired = self.commands - count > RETRY_WINDOW
            if not expired:
                return
            self._give_up_oldest_failed()

    def _give_up_oldest_failed(self) -> None:
        """The oldest failed command was not sent again."""
        num = next(iter(self.failed))
        del self.failed[num]
        self.never_retried.add(num)

    def findings(self, p95: float) -> list[Finding]:
        """Its findings; ``p95``: the 95th percentile of the devices' ACK latency
        (0 when not known), what the controller should wait for."""
        out = []
        # the next command came sooner than devices answer: the controller did not wait
        hasty = [(n, g) for n, g in self.next_gaps if p95 and g < p95]
        if len(hasty) >= 3:
            out.append(FINDINGS[CONTROLLER_NO_WAIT].found(
                "controller", [n for n, _g in hasty], commands=len(hasty),
                gap_ms=median(g for _n, g in hasty) * 1000, p95_ms=p95 * 1000))
        # retransmissions sooner than devices answer
        fast = [(n, g) for n, g in self.retry_gaps if g < p95] if p95 else []
        if len(fast) >= 3:
            out.append(FINDINGS[CONTROLLER_FAST_RETRY].found(
                "controller", [n for n, _g in fast], retries=len(fast),
                gap_ms=median(g for _n, g in fast) * 1000, p95_ms=p95 * 1000))
        # most failures left alone: a controller that gives up after a few attempts
        # (or an untimed capture's alignment guessing which command went unanswered)
        # leaves some, but retries most
        given_up = len(self.never_retried)
        if given_up >= 3 and given_up > self.retried:
            no_retry = FINDINGS[CONTROLLER_NO_RETRY]
            retried = "" if not self.retried else no_retry.phrase("retried_one") if self.retried == 1 \
                else no_retry.phrase("retried", retried=self.retried)
            out.append(no_retry.found("controller", self.never_retried.evidence(), given_up=given_up,
                                      retried=retried))
        if self.ix_given_up:
            ix = FINDINGS[CONTROLLER_IX_TIMEOUT]
            resent = len(self.ix_given_up)
            out.append(ix.found("controller", self.ix_given_up.evidence(),
                                resent=ix.phrase("resent_one") if resent == 1 else ix.phrase("resent", resent=resent)))
        return out


class WiringDoctor:
    """Every structure is bounded (tallies, windows, capped maps) and each event
    costs the same however long the capture: time and memory stay linear and flat."""

    def __init__(self, lines: tuple[str, ...] = ("A", "B"), ack_timeout: float = 0.5,
                 invocation: Invocation | None = None) -> None:
        self.ack_timeout = ack_timeout
        self.invocation = invocation or Invocation()
        self.signs = WiringSigns(lines)   # per-line tallies, and the signs of swapped lines
        self.signs.read_baud = self.invocation.baud
        self.two_lines = self.signs.two_lines
        self.lines = self.signs.lines
        self.devices: dict[str, DeviceTally] = {}
        self.other_addresses = _Tally()   # commands to addresses beyond the first _MAX_DEVICES
        self.events = 0
        self.commands = 0
        self.answers = 0          # answers paired with a command
        self.first_t: float | None = None
        self.last_t: float | None = None
        # echo
        self.echoes = _Tally()
        self.controller = ControllerWatch(ack_timeout)
        self.nak_count = 0
        self.naks: deque[tuple[float, int]] = deque(maxlen=200)
        self.ack_latency = Latency()               # every device's ACKs: the 95th percentile
        self.trend_from = float("-inf")            # ACKs before this time are left out of the trend
        self._first_seen: dict[tuple[str, str], tuple[float | None, int]] = {}   # (time, events seen)
        # the link's latest rate change: (rate event, the rate-set command's number, its device)
        self.rate_change: tuple[Event, int | None, str | None] | None = None
        # a logic capture's lines as its software UART measured them (analyzer/physical/report.py),
        # kept up to date by the source: the waveform rules read them
        self.physical: dict | None = None
        # the findings of the event rules as a recording kept them (``of_kept``); None: worked out
        self.stored: dict[str, list[Finding]] | None = None

    # ------------------------------------------------------------------ input
    def add(self, ev: Event) -> None:
        self.events += 1
        t = ev.t
        if t is not None:
            if self.first_t is None:
                self.first_t = t
            self.last_t = ev.t_end if ev.t_end is not None else t
        misplaced = self.signs.add(ev)
        kind = ev.kind
        if kind == RATE:
            self._rate(ev)
            return
        if kind == NOISE or misplaced:
            return
        if kind == COMMAND:
            self._command(ev)
        elif kind in (ACK, NAK, NIC, RESULT):
            self._answer(ev)

    def _rate(self, ev: Event) -> None:
        """The link changed rate: every device starts over at the new rate."""
        txn = ev.transaction
        self.rate_change = (ev, ev.request, txn.device if txn is not None else None)
        for dev in self.devices.values():
            dev.commands_since_rate = dev.answers_since_rate = 0
            dev.unanswered_since_rate = _Tally()

    def echoed(self, command: Event) -> None:
        """The capture stripped line B's copy of this command (an echo)."""
        self.echoes.add(command.number)

    def _device(self, addr: str) -> DeviceTally | None:
        """The device at an address, tracked from its first command; past
        _MAX_DEVICES addresses (garbled input) new ones are only counted."""
        dev = self.devices.get(addr)
        if dev is None and len(self.devices) < _MAX_DEVICES:
            dev = self.devices[addr] = DeviceTally()
        return dev

    def _command(self, ev: Event) -> None:
        self.commands += 1
        txn = ev.transaction   # the command's record (pairing links every command)
        addr = txn.device if txn is not None else None
        dev = self._device(addr) if addr is not None else None
        if dev is None:
            self.other_addresses.add(ev.number)
        else:
            self._count(dev, ev)
        if ev.status == ST_NAK:
            self.nak_count += 1
            if ev.t is not None:     # bursts need time
                self.naks.append((ev.t, ev.number))
        self.controller.command(ev)

    def _count(self, dev: DeviceTally, ev: Event) -> None:
        dev.commands += 1
        dev.commands_since_rate += 1
        if ev.status == NO_ACK:
            dev.unanswered.add(ev.number)
            dev.unanswered_since_rate.add(ev.number)
        elif ev.status == ST_NIC and ev.command and len(dev.nic) < _MAX_NIC:
            dev.nic.add(ev.command)

    def _answer(self, ev: Event) -> None:
        txn = ev.transaction   # the command's record: its device is the answer's
        if txn is None:
            return
        addr = txn.device
        self.answers += 1
        dev = self.devices.get(addr) if addr is not None else None
        if dev is None:
            return     # an address past _MAX_DEVICES
        dev.answers += 1
        dev.answers_since_rate += 1
        dev.lines.add(ev.line)
        if ev.kind == ACK and ev.latency is not None and ev.t is not None:
            if ev.t >= self.trend_from:   # measured under the current skew correction
                dev.ack_count += 1
                if len(dev.first_acks) < 200:
                    dev.first_acks.append(ev.latency)
                dev.last_acks.append(ev.latency)
            self.ack_latency.add(ev.latency)
        if ev.kind == RESULT and ev.command == "D?" and ev.fields:
            f = ev.fields
            dev.identity = f"{f.get('name', '?')} rev {f.get('revision', '?')} s/n {f.get('serial', '?')}"

    # --------------------------------------------------------------- findings
    def rules(self) -> tuple[tuple[str, Callable[[], list[Finding]]], ...]:
        """The rules in the order they are asked: root causes first."""
        return (("waveform", self._waveform), ("wiring", self._wiring), ("no_frames", self._no_frames),
                ("echo", self._echo), ("silent_after_rate", self._silent_after_rate), ("silent", self._silent),
                ("noisy", self._noisy), ("controller", self._controller), ("slow", self._slow),
                ("device_map", self._device_map))

    def findings(self) -> list[Finding]:
        """What the traffic shows so far, most severe first."""
        kept = self.stored
        # root causes first: what they explain is not raised with them (the table's ``hides``)
        out = unexplained(kept[name] if kept is not None and name in kept else rule()
                          for name, rule in self.rules())
        for f in out:
            key = f.key
            if key not in self._first_seen:
                self._first_seen[key] = (self.last_t, self.events)
            f.first_seen, f.first_seen_event = self._first_seen[key]
            f.evidence = sorted(f.evidence)[:_MAX_EVIDENCE]
        out.sort(key=lambda f: (SEVERITY_ORDER[f.severity], f.code, f.subject))
        return out

    # ------------------------------------------------------- kept findings
    def kept(self) -> dict[str, Any]:
        """What the rules that read the events alone found so far, with the counts
        the findings are dated by, as JSON values: a recording keeps it with its
        stored columns (docs/mcap.md, "Stored columns"), so that its findings need
        no pass over its events (``of_kept``). The rules that name how the traffic
        is read (``READING_RULES``: the fixes name the command and its inputs) or
        what a logic analyser measured are left out: they are worked out when read,
        from the wiring signs the recording keeps beside this."""
        rules = {name: [_finding_state(f) for f in rule()] for name, rule in self.rules()
                 if name not in READING_RULES}
        return {"rules": rules, "events": self.events, "first_t": self.first_t, "last_t": self.last_t}

    @classmethod
    def of_kept(cls, signs: WiringSigns, ack_timeout: float, invocation: Invocation,
                state: dict[str, Any]) -> WiringDoctor:
        """A doctor whose findings are those ``kept()`` gave, with ``signs`` (the
        recording's wiring signs) and ``invocation`` for the reading rules; raises
        ``KeyError``, ``TypeError`` or ``ValueError`` for a state ``kept`` did not give."""
        doctor = cls(tuple(signs.lines), ack_timeout, invocation)
        signs.read_baud = invocation.baud
        doctor.signs, doctor.lines = signs, signs.lines
        doctor.events = int(state["events"])
        doctor.first_t = None if state["first_t"] is None else float(state["first_t"])
        doctor.last_t = None if state["last_t"] is None else float(state["last_t"])
        rules = state["rules"]
        doctor.stored = {name: [Finding(**f) for f in rules[name]] for name, _rule in doctor.rules()
                        if name not in READING_RULES}
        return doctor

    @property
    def timed(self) -> bool:
        """Whether the traffic carries time (raw dumps do not)."""
        return self.first_t is not None

    @property
    def span(self) -> float:
        """Seconds of traffic seen so far (0 without time: count ``events`` then)."""
        if self.first_t is None or self.last_t is None:
            return 0.0
        return max(0.0, self.last_t - self.first_t)

    def _wiring(self) -> list[Finding]:
        """Swapped lines, a garbled line, nothing of this protocol (analysis/signs.py)."""
        how = self.invocation
        waveform = bool(self.physical)

        def rate_fix(rate: int, read: int) -> str:
            return how.rate_fix(rate, read, waveform)

        return self.signs.findings(how.swap_fix(), how.baud_fix(), how.live, rate_fix)

    def _no_frames(self) -> list[Finding]:
        """Not one valid frame: say what the capture holds instead (``wrong_baud``
        and ``not_this_protocol``, which judge 100 bytes or more, hide this)."""
        if not self.signs.no_frames():
            return []
        how = self.invocation
        carrying = [(name, line) for name, line in self.lines.items() if line.bytes]
        total = sum(line.bytes for _name, line in carrying)
        if how.live and total and total < NO_FRAME_BYTES and self.span < NO_FRAME_SECONDS:
            return []     # a tap opened mid-frame: the first frame may be on its way
        kind = FINDINGS[NO_FRAMES]
        look = None
        if carrying:
            seen = ", ".join(kind.phrase("on_line", bytes=counted(line.bytes, "byte"), line=name)
                             for name, line in carrying)
            sample = b"".join(bytes(line.sample) for _name, line in carrying)
            look, excerpt, value = looks_of(sample)
            if look == TEXT:
                looks = kind.phrase("text", excerpt=excerpt)
            elif look == SAME:
                looks = kind.phrase("same", value=value)
            else:
                head = " ".join(f"{b:02X}" for b in sample[:16]) + (" …" if len(sample) > 16 else "")
                looks = kind.phrase("binary", head=head)
        else:
            seen, looks = kind.phrase("nothing"), kind.phrase("empty")
        check = kind.phrase("check_port", baud_fix=how.baud_fix()) if how.live else kind.phrase("check_file")
        evidence = sorted(n for _name, line in carrying for n in line.errors.evidence())
        subject = ",".join(name for name, _line in carrying) or ",".join(self.lines)
        f = kind.found(subject, evidence, seen=seen, looks=looks, check=check)
        f.measured = {"looks": look, "bytes": total}
        return [f]

    def _waveform(self) -> list[Finding]:
        """What a logic analyser's capture shows below the bytes, line by line."""
        out: list[Finding] = []
        for name, r in (self.physical or {}).items():
            out += waveform_findings(name, r)
        return out

    def _echo(self) -> list[Finding]:
        if len(self.echoes) < 3:
            return []
        return [FINDINGS[ECHO].found("B", self.echoes.evidence(), echoes=len(self.echoes))]

    def _silent(self) -> list[Finding]:
        if self.commands >= 5 and self.answers == 0:
            return [self._dead_link()]
        answering = [a for a, d in self.devices.items() if d.answers >= 3]
        if not answering:
            return []
        silent = FINDINGS[SILENT_DEVICE]
        return [silent.found(addr, d.unanswered.evidence(), addr=addr, commands=d.commands,
                             answering=", ".join(answering))
                for addr, d in sorted(self.devices.items())
                if d.commands >= 3 and d.answers == 0 and "255" not in addr.split(".")]

    def _dead_link(self) -> Finding:
        """Commands and no answer at all: is the device side silent, or garbled?"""
        dead = FINDINGS[DEAD_LINK]
        b = self.lines.get("B") if self.two_lines else self.lines.get("AB")
        if b is None or b.bytes == 0:
            where = dead.phrase("b_silent" if self.two_lines else "none_answered")
            check = dead.phrase("check_wire")
        else:
            where = dead.phrase("b_garbled" if self.two_lines else "line_garbled", bytes=counted(b.bytes, "byte"))
            check = dead.phrase("check_baud")
        cmds = sorted(n for d in self.devices.values() for n in d.unanswered)[:_MAX_EVIDENCE]
        return dead.found("B", cmds, commands=self.commands, where=where, check=check)

    def _silent_after_rate(self) -> list[Finding]:
        """Devices that answered before the link's rate changed and not since."""
        if self.rate_change is None:
            return []
        rate, number, target = self.rate_change
        baud, before = rate.fields.get("baud"), rate.fields.get("previous_baud")
        at = f"#{number}" if number is not None else f"#{rate.number}"
        kind = FINDINGS[SILENT_AFTER_RATE]
        out = []
        for addr, d in sorted(self.devices.items()):
            if d.commands_since_rate < 3 or d.answers_since_rate or d.answers == 0:
                continue
            # the device the rate-set command went to, or another on the link
            silence = kind.phrase("set_to" if addr == target else "link_set_to", addr=addr, baud=baud, at=at)
            out.append(kind.found(addr, d.unanswered_since_rate.evidence(), silence=silence, addr=addr,
                                  commands=d.commands_since_rate,
                                  answered=counted(d.answers - d.answers_since_rate, "time"),
                                  baud=baud, before=before))
        return out

    def _noisy(self) -> list[Finding]:
        out = [f for name, line in self.lines.items() if (f := self._noisy_line(name, line)) is not None]
        burst = self._nak_burst()
        return out + ([burst] if burst is not None else [])

    def _noisy_line(self, name: str, line: LineTally) -> Finding | None:
        errors = line.error_count
        if errors < 3 or line.bytes < MIN_BYTES or line.share < GARBLED:
            return None   # too little to say; garbled lines are wrong_baud
        if line.bad_frames / max(line.frames, 1) < 0.01 and line.noise_runs < 3:
            return None
        noisy = FINDINGS[NOISY_LINK]
        span = max(self.span, 1e-9)
        per_min = errors / span * 60 if self.timed else 0.0
        # the trend: the last minute against the whole capture
        recent = line.recent_errors((self.last_t or 0.0) - 60)
        recent_span = min(60.0, span)
        trend = ""
        if self.timed and span > 90 and recent_span:
            recent_rate = recent / recent_span * 60
            if recent_rate > 2 * per_min:
                trend = noisy.phrase("rising", per_min=recent_rate)
            elif recent_rate < per_min / 2:
                trend = noisy.phrase("falling", per_min=recent_rate)
        length, check = _length_note(line)
        if self.timed:
            span_words = noisy.phrase("timed", seconds=self.span, per_min=per_min)
        else:
            span_words = noisy.phrase("untimed", events=counted(self.events, "event"))
        return noisy.found(name, list(line.errors.last), line=name,
                           checksum_errors=counted(line.bad_frames, "checksum error"),
                           noise_runs=counted(line.noise_runs, "noise run"), span=span_words, trend=trend,
                           length=length, check=check)

    def _nak_burst(self) -> Finding | None:
        naks = list(self.naks)    # timed NAKs only: a burst is a matter of time
        if len(naks) < 5:
            return None
        # a burst: five NAKs within ten seconds
        burst = _densest([t for t, _n in naks], 10.0)
        # a burst stands out from the capture's usual rate (busy links NAK more often)
        usual = self.nak_count / max(self.span, 10.0) * 10
        if burst < max(5, 3 * usual):
            return None
        return FINDINGS[NAK_BURST].found("A", [n for _t, n in naks[-_MAX_EVIDENCE:]], naks=self.nak_count,
                                         burst=burst)

    def _controller(self) -> list[Finding]:
        return self.controller.findings(self._ack_p95())

    def _ack_p95(self) -> float:
        return self.ack_latency.quantile(0.95) or 0.0

    def restart_ack_trend(self, since: float) -> None:
        """The capture's skew correction changed for line B events from ``since`` on:
        latencies before and after it are not comparable (a correction switching on
        would look like every device slowing down), so the trend starts again."""
        self.trend_from = since
        for d in self.devices.values():
            d.ack_count = 0
            d.first_acks.clear()
            d.last_acks.clear()

    def _slow(self) -> list[Finding]:
        out = []
        for addr, d in sorted(self.devices.items()):
            n = d.ack_count
            if n < 12:
                continue
            k = min(n // 3, 200)
            before = median(d.first_acks[:k])
            after = median(list(d.last_acks)[-k:])
            if after > 2 * before and after - before > 0.005:
                out.append(FINDINGS[SLOW_ANSWERS].found(addr, [], addr=addr, before_ms=before * 1000,
                                                        after_ms=after * 1000, acks=n))
        return out

    def _device_map(self) -> list[Finding]:
        if not self.devices:
            return []
        kind = FINDINGS[DEVICE_MAP]
        parts = []
        for addr, d in sorted(self.devices.items()):
            state = kind.phrase("answers", lines=",".join(sorted(d.lines))) if d.answers \
                else kind.phrase("never_answered")
            nic = kind.phrase("nic", commands=", ".join(sorted(d.nic))) if d.nic else ""
            ident = kind.phrase("identity", identity=d.identity) if d.identity else ""
            parts.append(kind.phrase("device", addr=addr, commands=counted(d.commands, "command"), state=state,
                                     nic=nic, identity=ident))
        past = ""
        if self.other_addresses:
            # garbled input names many addresses: past the first ones, only counted
            past = kind.phrase("past", limit=_MAX_DEVICES)
            parts.append(kind.phrase("untracked", commands=counted(len(self.other_addresses), "command")))
        return [kind.found("map", [], devices=counted(len(self.devices), "device"),
                           past=past, per_device="\n".join(parts))]


CLOCK_WARNING, CLOCK_ERROR = 2.0, 4.0     # per cent off the nominal rate (findings table, clock_off)


def waveform_findings(name: str, r: LineReport) -> list[Finding]:
    """The waveform's findings about one line (``r``: a LineReport)."""
    out: list[Finding] = []
    chars = counted(r.characters, "character")
    if r.inverted and r.characters:
        out.append(FINDINGS[LINE_INVERTED].found(name, [], line=name, channel=f"channel {r.channel}",
                                                 characters=chars))
    pct = r.error_pct
    if pct is not None and not r.given and r.characters >= 4 and abs(pct) >= CLOCK_WARNING:
        f = FINDINGS[CLOCK_OFF].found(name, [], line=name, rate=r.measured, pct=abs(pct),
                                      way="fast" if pct > 0 else "slow", baud=r.nominal, characters=chars)
        if abs(pct) >= CLOCK_ERROR:
            f.severity = ERROR
        out.append(f)
    measured = r.measured
    if measured and not r.given and r.characters >= 4 and nominal_rate(measured) is None:
        nearest = min(STANDARD_RATES, key=lambda rate: abs(rate - measured) / rate)
        out.append(FINDINGS[RATE_NONSTANDARD].found(name, [], line=name, rate=measured, characters=chars,
                                                    nearest=nearest))
    errors = r.framing_errors + r.parity_errors + r.breaks
    if errors:
        kind = FINDINGS[FRAMING_ERRORS]
        # framing and parity errors are among the characters (they have a value);
        # a break has none, so it is counted beside them, never "in" them
        among = [counted(n, noun) for n, noun in ((r.framing_errors, "framing error"),
                                                  (r.parity_errors, "parity error")) if n]
        parts = [kind.phrase("in", errors=" and ".join(among), characters=chars)] if among else []
        if r.breaks:
            parts.append(counted(r.breaks, "break"))
        most = r.framing_errors + r.parity_errors > max(r.characters, 1) / 4
        first = f"{r.first_error:.6f} s" if r.first_error is not None else "a break"
        f = kind.found(name, [], line=name, errors=", and ".join(parts), first=first,
                       check=kind.phrase("check_rate", format=r.format) if most else kind.phrase("check_line"))
        if errors < 3 and not most:
            f.severity = WARNING
        out.append(f)
    if r.glitches >= 2:
        bit_us = 1e6 / r.measured if r.measured else 0.0
        out.append(FINDINGS[GLITCHES].found(name, [], line=name, glitches=counted(r.glitches, "glitch", "glitches"),
                                            pulses=counted(r.glitches, "pulse"), limit_us=bit_us / 4,
                                            edges=counted(r.edges, "edge")))
    if r.off_grid >= 3 and r.off_grid >= r.characters / 100:
        out.append(FINDINGS[TWO_DRIVERS].found(name, [], line=name, off_grid=r.off_grid, characters=chars))
    # on one line, a root cause explains its consequences (two senders give framing
    # errors), as the rules' order does between rules; other lines keep theirs
    hidden = {code for f in out for code in FINDINGS[f.code].hides}
    out = [f for f in out if f.code not in hidden]
    for f in out:   # for scripts: the line's numbers, not only its words
        f.measured = waveform_measures(r)
    return out


def waveform_measures(r: LineReport) -> dict[str, Any]:
    """What the software UART measured of a line (a LineReport), as the JSON
    report's ``measured`` of each waveform finding gives it."""
    return {"channel": r.channel, "rate": r.measured, "nominal": r.nominal, "rate_sure": r.rate_sure,
            "format": r.format, "inverted": r.inverted, "characters": r.characters, "edges": r.edges,
            "framing_errors": r.framing_errors, "parity_errors": r.parity_errors, "breaks": r.breaks,
            "glitches": r.glitches, "off_grid": r.off_grid, "first_error": r.first_error}


def one_line(f: Finding) -> str:
    """``doctor: warning: title: detail (try: fix)``: stderr and the /log topic."""
    return f"doctor: {f.severity}: {f.title}: {f.detail.splitlines()[0] if f.detail else ''}" + (
        f" (try: {f.fix})" if f.fix else "")
