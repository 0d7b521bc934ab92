"""Request/response pairing: links each command to its ACK/NAK, NIC and result,
with latency, timeouts and retransmissions (spec §1.4.2-1.4.3, Table 3;
docs/decoding.md "Pairing where the document says nothing").

A pure module: ``Pairer.push(event)`` takes events in wire order and returns the
events whose pairing is settled, in the same order. A command is held back until
its status is final, so every event leaves with its ``txn``/``status``/
``latency`` filled; the hold is bounded by the timeouts (timed input) or by a
count of later commands (untimed input), so memory stays flat.

Each command gets a ``Transaction``, the one record of which answers are its
own: the command and every answer linked to it reference it
(``Event.transaction``), and statistics, the wiring doctor, the TUI and
recordings read it rather than match answers to commands again. An ACK, NAK or
NIC has no address of its own: its device is its transaction's
(``Event.device``); an orphan has none.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from dissectors import apply_command, dissect_command, dissect_result, result_fits
from dissectors.commands import DUE, OPTIONAL
from dissectors.event import (
    ACK,
    COMMAND,
    FRAME,
    NAK,
    NIC,
    NO_ACK,
    NO_RESULT,
    OK,
    PENDING,
    RATE,
    RESULT,
    ST_NAK,
    ST_NIC,
    Event,
    format_address,
)
from dissectors.problems import (
    LATE,
    NO_RESULT_OVERFLOW,
    NO_RESULT_SENT_AGAIN,
    NO_RESULT_TIMEOUT,
    ORPHAN,
    RETRANSMISSION,
    UNANSWERED_NO_ACK,
    UNANSWERED_SUPERSEDED,
    UNANSWERED_TIMEOUT,
    ProblemInfo,
)
from dissectors.wire import WILDCARD


@dataclass
class Timeouts:
    """Seconds. ``result_by_command`` overrides per command id (IX takes seconds)."""
    ack: float = 0.5
    result: float = 2.0
    result_by_command: dict[str, float] = field(default_factory=dict)
    untimed_window: int = 32   # untimed input: a due result is given up after this many commands
    # untimed input: a command waits for its answers behind at most this many later
    # events (noise floods carry no commands to count, and every event after a
    # waiting command is held for order: without this, memory grew with the file)
    untimed_hold: int = 4096

    def result_for(self, ev: Event) -> float:
        command = ev.command
        t = self.result_by_command.get(command) if command is not None else None
        if t is not None:
            return t
        if ev.entry is not None and ev.entry.result_timeout is not None:
            return ev.entry.result_timeout
        return self.result


class Transaction:
    """A command and its answers, as pairing linked them (a request/response
    record, like Wireshark's ``mdb_transaction_t``).

    ``number`` is the events' ``txn``; ``request`` the command's event number
    (the answers' ``request``); ``command`` its id, ``device`` its
    "group.port.device", ``retransmission`` whether it repeats a failed one;
    ``status`` its final status, None until it settles. ``ack`` (the ACK or
    NAK), ``nic`` and ``result`` are the answers' event numbers, None until
    linked; ``ack_latency`` and ``result_latency`` their latencies (None
    without time).

    Complete when the command settles: pairing releases a command only once its
    status is final, so whoever reads the events finds the record complete. An
    answer that can still come later (an ACK after the ACK timeout, an optional
    result) is added when it is linked, as its event is.

    It holds numbers, not events: the events reference the record, and
    references both ways would make every command a reference cycle, which
    reference counting does not free (decoding relies on it freeing events at
    once: analyzer/capture/collector.py). ``deadline``, ``optional`` and ``age`` are
    pairing's own bookkeeping while answers are awaited: one object per command.
    """

    __slots__ = (
        "ack",
        "ack_latency",
        "age",
        "command",
        "deadline",
        "device",
        "nic",
        "number",
        "optional",
        "request",
        "result",
        "result_latency",
        "retransmission",
        "status",
    )

    def __init__(self, number: int, cmd: Event) -> None:
        dst = cmd.dst
        assert dst is not None   # a command is a frame
        self.number = number
        self.request: int = cmd.number
        self.command: str | None = cmd.command
        self.device: str = format_address(dst)
        self.status: str | None = None
        self.retransmission: bool = cmd.retransmission
        self.ack: int | None = None
        self.nic: int | None = None
        self.result: int | None = None
        self.ack_latency: float | None = None
        self.result_latency: float | None = None
        self.deadline: float | None = None   # when the awaited answer is overdue
        self.optional = False                # the awaited result may not come
        self.age = 0                         # commands seen since this one (untimed expiry)

    @property
    def settled(self) -> bool:
        return self.status is not None

    @property
    def answers(self) -> list[int]:
        """The linked answers' event numbers, in wire order (a result can come
        before the place of an ACK that was lost)."""
        return sorted(n for n in (self.ack, self.nic, self.result) if n is not None)

    def __repr__(self) -> str:
        return (f"Transaction(txn {self.number}: #{self.request} {self.command} {self.device} "
                f"{self.status}, answers {self.answers})")


def _record(cmd: Event) -> Transaction:
    """The record pairing gave a command it numbered, checked (it gives every
    one a ``Transaction``). What runs per event or per answer reads
    ``cmd.transaction`` unchecked instead, narrowed for the type checker only
    (``if TYPE_CHECKING: assert isinstance(...)``): a call and an isinstance
    there cost a fair part of pairing's own work; the commands awaiting a result
    are kept with their records (``Pairer._awaiting_result``)."""
    txn = cmd.transaction
    assert isinstance(txn, Transaction)
    return txn


def address_fits(cmd: Event, res: Event) -> bool:
    """Does a result frame come back from the command's destination (Table 3)?

    Groups are swapped, port and device are kept; a wildcard (255) in the command
    matches any value; device 0 (the MCU/GCU as destination, §1.4.1.1) is accepted.
    """
    if cmd.dst is None or res.dst is None:   # not frames: no address
        return False
    cg, cp, cd = cmd.dst
    rg, rp, rd = res.dst
    if rg != cmd.src:
        return False
    if res.src != cg and cg != WILDCARD:
        return False
    if rp != cp and cp != WILDCARD:
        return False
    return rd == cd or cd == WILDCARD or rd == 0


def _repeats(prev: Event, ev: Event) -> bool:
    """Does ``ev`` resend ``prev``? The same bytes; or, when the earlier copy was
    corrupted on the wire (bad checksum), the same length with at most two bytes
    different (bit errors the tap saw too)."""
    if prev.raw == ev.raw:
        return True
    if prev.checksum_ok is False and len(prev.raw) == len(ev.raw):
        return sum(a != b for a, b in zip(prev.raw, ev.raw)) <= 2
    return False


class Pairer:
    def __init__(self, timeouts: Timeouts | None = None) -> None:
        self.timeouts = timeouts or Timeouts()
        self._number = 0
        self._txn_no = 0
        self._held: deque[Event] = deque()
        # commands (their state is their ``transaction``'s)
        self._awaiting_ack: Event | None = None
        # the commands awaiting a result, with their records, oldest ACK first
        self._awaiting_result: dict[Event, Transaction] = {}
        self._last_cmd: Event | None = None     # for retransmissions
        self._timed_out: Event | None = None    # no_ack by timeout: a late ACK may still come
        self._controller_groups: set[int] = set()
        # An ACKed command not due a result is ok unless a NIC follows the ACK:
        # its status waits for the next event (or the end, or the ACK timeout).
        self._provisional: Event | None = None
        self._provisional_since: float | None = None
        self._prev: Event | None = None        # the event pushed before this one
        # the latest ACK and its command: a NIC must follow that ACK directly (§1.4.2)
        self._last_ack: tuple[Event, Event] | None = None

    # ----------------------------------------------------------------- API
    def push(self, ev: Event) -> list[Event]:
        """Take the next event in wire order; return the events now settled."""
        return self.push_many([ev])

    def push_many(self, events: list[Event]) -> list[Event]:
        """Take a batch of events in wire order; return the events now settled.
        (The loop is written for speed: it runs once per event of a capture.)"""
        out: list[Event] = []
        append = out.append
        held = self._held
        number = self._number
        hold = self.timeouts.untimed_hold
        command, handshake, result, nic = self._command, self._handshake, self._result, self._nic
        for ev in events:
            number += 1
            ev.number = number
            kind = ev.kind
            # a rate event (analyzer.analysis.rate) must not settle an ACK whose NIC may follow it
            if self._provisional is not None and kind != NIC and kind != RATE:
                self._settle()
            t = ev.t
            if t is not None and (self._awaiting_ack is not None or self._awaiting_result):
                self._expire(t)
            if kind == FRAME:
                kind = ev.kind = self._classify(ev)
            if kind == COMMAND:
                command(ev)
                held.append(ev)   # its status is never final yet
                self._prev = ev
                continue
            if kind == ACK or kind == NAK:
                handshake(ev)
            elif kind == RESULT:
                result(ev)
            elif kind == NIC:
                nic(ev)
            elif kind == RATE:
                # the link's rate changed after an ACK: it answers nothing, and is not
                # the event before the next one (retransmissions are told by that)
                self._rate(ev)
                if held:
                    held.append(ev)
                else:
                    append(ev)
                continue
            self._prev = ev
            if not held:
                append(ev)
                continue
            held.append(ev)
            if t is None and len(held) > hold:
                self._give_up(held[0])
            while held:
                head = held[0]
                if head.kind == COMMAND:
                    if head.status is None:
                        break
                    txn = head.transaction
                    if TYPE_CHECKING:   # unchecked at run time: see _record
                        assert isinstance(txn, Transaction)
                    txn.status = head.status   # final: the record takes it
                append(held.popleft())
        self._number = number
        return out

    def _rate(self, ev: Event) -> None:
        """A rate event belongs to the rate-set command whose ACK came just before it."""
        prev = self._prev
        if prev is not None and prev.kind in (ACK, NIC) and prev.transaction is not None:
            ev.transaction = prev.transaction
            ev.request = prev.request
            ev.txn = prev.txn

    def _give_up(self, cmd: Event) -> None:
        """Untimed input: ``cmd`` has waited behind ``untimed_hold`` events; its
        ACK or result is not coming (the count stands in for the timeout)."""
        why = f"none within the next {self.timeouts.untimed_hold} events"
        if self._awaiting_ack is cmd:
            self._no_ack(cmd, UNANSWERED_TIMEOUT, why)
            return
        if cmd in self._awaiting_result:
            del self._awaiting_result[cmd]
            self._no_result(cmd, NO_RESULT_TIMEOUT, why)
            if cmd.status is None:   # an optional result: the ACK settled it
                cmd.status = OK

    def advance(self, now: float) -> list[Event]:
        """Live input: time passed with no events; expire what is overdue."""
        if self._provisional is not None and self._provisional_since is not None \
                and now - self._provisional_since > self.timeouts.ack:
            self._settle()
        self._expire(now)
        return self._release()

    def held(self) -> list[Event]:
        """The events not released yet (a command whose status is not final, and
        what came after it), numbered and linked so far: a live view shows them."""
        return list(self._held)

    def finish(self) -> list[Event]:
        """End of capture: whatever still waits is ``pending``."""
        if self._provisional is not None:
            self._settle()
        for cmd in ([self._awaiting_ack] if self._awaiting_ack else []) + list(self._awaiting_result):
            if not _record(cmd).optional:
                cmd.status = PENDING
        self._awaiting_ack = None
        self._awaiting_result = {}
        out = list(self._held)
        self._held.clear()
        for ev in out:
            if ev.kind == COMMAND:
                _record(ev).status = ev.status
        return out

    # ------------------------------------------------------------ internals
    def _settle(self) -> None:
        cmd = self._provisional
        self._provisional = None
        if cmd is not None and cmd.status is None:
            cmd.status = OK

    def _release(self) -> list[Event]:
        held = self._held
        out = []
        while held:
            head = held[0]
            if head.kind == COMMAND:
                if head.status is None:
                    break
                txn = head.transaction
                if TYPE_CHECKING:   # unchecked at run time: see _record
                    assert isinstance(txn, Transaction)
                txn.status = head.status
            out.append(held.popleft())
        return out

    def _expire(self, t: float) -> None:
        cmd = self._awaiting_ack
        if cmd is not None:
            txn = cmd.transaction
            if TYPE_CHECKING:   # unchecked at run time: see _record
                assert isinstance(txn, Transaction)
            deadline = txn.deadline
            if deadline is not None and t > deadline:
                self._no_ack(cmd, UNANSWERED_TIMEOUT, f"no ACK/NAK within {self.timeouts.ack * 1000:g} ms")
                self._timed_out = cmd
        awaiting = self._awaiting_result
        if awaiting:
            for txn in awaiting.values():
                deadline = txn.deadline
                if deadline is not None and t > deadline:
                    break
            else:
                return   # none overdue: the usual case, checked without building anything
            keep = {}
            for cmd, txn in awaiting.items():
                deadline = txn.deadline
                if deadline is not None and t > deadline:
                    self._no_result(cmd, NO_RESULT_TIMEOUT,
                                    f"none within {self.timeouts.result_for(cmd):g} s of the ACK")
                else:
                    keep[cmd] = txn
            self._awaiting_result = keep

    def _no_ack(self, cmd: Event, problem: ProblemInfo, why: str) -> None:
        cmd.status = NO_ACK
        cmd.add_problem(problem, why)
        if self._awaiting_ack is cmd:
            self._awaiting_ack = None

    def _no_result(self, cmd: Event, problem: ProblemInfo, why: str) -> None:
        if _record(cmd).optional:
            return
        cmd.status = NO_RESULT
        cmd.add_problem(problem, why)

    def _classify(self, ev: Event) -> str:
        """Single-line tap: is this frame a command or a result? (docs/decoding.md, "Pairing")

        A frame that fits a result someone is waiting for is that result. Otherwise
        the direction decides once it is known (commands travel from the
        controller's source group), and where it cannot (controller and devices in
        one group) a payload that parses as a command is one.
        """
        dst, src, payload = ev.dst, ev.src, ev.payload
        assert dst is not None and src is not None and payload is not None   # a frame
        for cmd in reversed(self._awaiting_result):
            if address_fits(cmd, ev) and result_fits(cmd.entry, payload):
                return RESULT
        waiting = self._awaiting_ack
        if waiting is not None and waiting.dst is not None and waiting.dst[0] != waiting.src \
                and address_fits(waiting, ev) and result_fits(waiting.entry, payload):
            return RESULT
        groups = self._controller_groups
        g = dst[0]
        if groups and src != g:
            if src in groups and g not in groups:
                return COMMAND
            if g in groups and src not in groups:
                return RESULT
        if dissect_command(payload).entry is None:
            return RESULT
        groups.add(src)
        return COMMAND

    def _command(self, ev: Event) -> None:
        if ev.command is None:
            apply_command(ev)
        if self._awaiting_ack is not None:
            self._no_ack(self._awaiting_ack, UNANSWERED_SUPERSEDED, "no ACK/NAK before the next command")
        self._timed_out = None
        if self._awaiting_result:
            keep = {}
            window = self.timeouts.untimed_window
            for cmd, txn in self._awaiting_result.items():
                txn.age += 1
                if cmd.command == ev.command and cmd.dst == ev.dst:
                    self._no_result(cmd, NO_RESULT_SENT_AGAIN, "the command was sent again before it came")
                elif ev.t is None and txn.age > window:
                    self._no_result(cmd, NO_RESULT_TIMEOUT, f"none within the next {window} commands")
                else:
                    keep[cmd] = txn
            self._awaiting_result = keep
        prev = self._last_cmd
        if prev is not None and prev.status in (ST_NAK, NO_ACK, NO_RESULT) and _repeats(prev, ev):
            ev.retransmission = True
            ev.add_problem(RETRANSMISSION, f"repeats #{prev.number} after {prev.status}")
        self._txn_no += 1
        ev.txn = self._txn_no
        txn = ev.transaction = Transaction(self._txn_no, ev)
        if ev.t_end is not None:
            txn.deadline = ev.t_end + self.timeouts.ack
        self._awaiting_ack = ev
        self._last_cmd = ev

    def _link(self, ev: Event, cmd: Event) -> None:
        """Make ``ev`` an answer to ``cmd``, in the event and in the record."""
        txn = cmd.transaction
        if TYPE_CHECKING:   # unchecked at run time: see _record
            assert isinstance(txn, Transaction)
        ev.txn = txn.number
        ev.request = cmd.number
        ev.transaction = txn
        latency = None
        if ev.t is not None and cmd.t_end is not None:
            latency = ev.latency = round(ev.t - cmd.t_end, 9)
        kind = ev.kind
        if kind == RESULT:
            txn.result = ev.number
            txn.result_latency = latency
        elif kind == NIC:
            txn.nic = ev.number
        else:   # the ACK or NAK (a late one too)
            txn.ack = ev.number
            txn.ack_latency = latency

    def _handshake(self, ev: Event) -> None:
        cmd = self._awaiting_ack
        if cmd is None:
            late = self._timed_out
            if late is not None:
                self._link(ev, late)
                ev.add_problem(LATE, f"after the {self.timeouts.ack * 1000:g} ms ACK timeout")
                self._timed_out = None
            else:
                ev.add_problem(ORPHAN, "no command awaits an ACK/NAK")
            return
        self._awaiting_ack = None
        self._link(ev, cmd)
        if ev.kind == NAK:
            cmd.status = ST_NAK
            return
        self._last_ack = (ev, cmd)
        due = cmd.entry.result_due if cmd.entry is not None else None
        if due == DUE or due == OPTIONAL:
            txn = cmd.transaction
            if TYPE_CHECKING:   # unchecked at run time: see _record
                assert isinstance(txn, Transaction)
            txn.optional = due == OPTIONAL
            if ev.t_end is not None:
                txn.deadline = ev.t_end + self.timeouts.result_for(cmd)
            awaiting = self._awaiting_result
            awaiting[cmd] = txn
            if len(awaiting) > 64:   # a runaway controller: keep memory flat
                old = next(iter(awaiting))
                del awaiting[old]
                self._no_result(old, NO_RESULT_OVERFLOW, "too many commands waiting for results")
                if old.status is None:
                    old.status = OK
        if due != DUE:
            self._provisional = cmd
            self._provisional_since = ev.t_end

    def _nic(self, ev: Event) -> None:
        last = self._last_ack
        if last is None or self._prev is not last[0] or last[1].status not in (None, OK):
            ev.add_problem(ORPHAN, "NIC not right after an ACK")
            return
        cmd = last[1]
        self._link(ev, cmd)
        cmd.status = ST_NIC
        if self._provisional is cmd:
            self._provisional = None
        self._awaiting_result.pop(cmd, None)
        self._last_ack = None

    def _result(self, ev: Event) -> None:
        # the latest command first: the one awaiting its ACK, then those awaiting
        # results, newest first. A result that fits one's layout is its answer;
        # else the newest from the right address that must have one.
        payload = ev.payload
        decoded = None
        fits: Event | None = None
        fallback = None
        ack_cmd = self._awaiting_ack
        awaiting = self._awaiting_result
        for cand in ((ack_cmd, *reversed(awaiting)) if ack_cmd is not None else reversed(awaiting)):
            if address_fits(cand, ev):
                entry = cand.entry
                if entry is not None and entry.result and payload is not None:   # result_fits, keeping the decode
                    decoded = dissect_result(entry, payload)
                    if decoded[0]:
                        fits = cand
                        break
                    decoded = None
                if fallback is None and not _record(cand).optional:
                    fallback = cand
        cmd = fits if fits is not None else fallback
        if cmd is None:
            ev.add_problem(ORPHAN, "no command awaits this result")
            return
        self._link(ev, cmd)
        ev.command = cmd.command
        ev.entry = cmd.entry
        if decoded is None:
            assert payload is not None   # a result from a command's address is a frame
            decoded = dissect_result(cmd.entry, payload)
        fields, problems = decoded
        ev.fields = fields
        if problems:
            ev.note(*problems)
        if cmd is self._awaiting_ack:   # the ACK was lost but the result came
            self._awaiting_ack = None
            cmd.add_problem(UNANSWERED_NO_ACK, "no ACK seen, but the result arrived")
        else:
            del self._awaiting_result[cmd]
        if cmd.status is None:
            cmd.status = OK
