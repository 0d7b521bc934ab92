"""Request/response pairing: links each command to its ACK/NAK, NIC and result,
with latency, timeouts and retransmissions (spec §1.4.2-1.4.3, Table 3;
docs/decoding.md "Pairing where the document says nothing").

A pure module: ``Pairer.push(event)`` takes events in wire order and returns the
events whose pairing is settled, in the same order. A command is held back until
its status is final, so every event leaves with its ``txn``/``status``/
``latency`` filled; the hold is bounded by the timeouts (timed input) or by a
count of later commands (untimed input), so memory stays flat.

Answers also get their device here: an ACK, NAK or NIC has no address of its
own, so a linked one takes its command's (``Event.device``); an orphan has none.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

from dissectors import apply_command, dissect_command, dissect_result, result_fits
from dissectors.commands import DUE, OPTIONAL
from dissectors.event import (
    ACK, COMMAND, FRAME, NAK, NIC, RESULT, Event,
    NO_ACK, NO_RESULT, OK, PENDING, ST_NAK, ST_NIC,
    P_LATE, P_NO_RESULT, P_ORPHAN, P_RETRANSMISSION, P_UNANSWERED,
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
        t = self.result_by_command.get(ev.command)
        if t is not None:
            return t
        if ev.entry is not None and ev.entry.result_timeout is not None:
            return ev.entry.result_timeout
        return self.result


class _Txn:
    __slots__ = ("cmd", "no", "deadline", "optional", "age")

    def __init__(self, cmd: Event, no: int) -> None:
        self.cmd = cmd
        self.no = no
        self.deadline: float | None = None
        self.optional = False
        self.age = 0  # commands seen since this one (untimed expiry)


def address_fits(cmd: Event, res: Event) -> bool:
    """Does a result frame come back from the command's destination (Table 3)?

    Groups are swapped, port and device are kept; a wildcard (255) in the command
    matches any value; device 0 (the MCU/GCU as destination, §1.4.1.1) is accepted.
    """
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
        self._awaiting_ack: _Txn | None = None
        self._awaiting_result: list[_Txn] = []
        self._last_cmd: _Txn | None = None     # for retransmissions
        self._timed_out: _Txn | None = None    # no_ack by timeout: a late ACK may still come
        self._controller_groups: set[int] = set()
        # An ACKed command not due a result is ok unless a NIC follows the ACK:
        # its status waits for the next event (or the end, or the ACK timeout).
        self._provisional: _Txn | None = None
        self._provisional_since: float | None = None
        self._prev: Event | None = None        # the event pushed before this one
        # the latest ACK and its transaction: a NIC must follow that ACK directly (§1.4.2)
        self._last_ack: tuple[Event, _Txn] | None = None

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
        command, handshake, result, nic = self._command, self._handshake, self._result, self._nic
        for ev in events:
            number += 1
            ev.number = number
            kind = ev.kind
            if self._provisional is not None and kind != NIC:
                self._settle()
            if ev.t is not None:
                self._expire(ev.t)
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
            self._prev = ev
            if not held:
                append(ev)
                continue
            held.append(ev)
            if ev.t is None and len(held) > self.timeouts.untimed_hold:
                self._give_up(held[0])
            while held:
                head = held[0]
                if head.kind == COMMAND and head.status is None:
                    break
                append(held.popleft())
        self._number = number
        return out

    def _give_up(self, cmd: Event) -> None:
        """Untimed input: ``cmd`` has waited behind ``untimed_hold`` events; its
        ACK or result is not coming (the count stands in for the timeout)."""
        why = f"none within the next {self.timeouts.untimed_hold} events"
        txn = self._awaiting_ack
        if txn is not None and txn.cmd is cmd:
            self._no_ack(txn, why)
            return
        for txn in self._awaiting_result:
            if txn.cmd is cmd:
                self._awaiting_result.remove(txn)
                self._no_result(txn, why)
                if cmd.status is None:   # an optional result: the ACK settled it
                    cmd.status = OK
                return

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
        for txn in ([self._awaiting_ack] if self._awaiting_ack else []) + self._awaiting_result:
            if not txn.optional:
                txn.cmd.status = PENDING
        self._awaiting_ack = None
        self._awaiting_result = []
        out = list(self._held)
        self._held.clear()
        return out

    # ------------------------------------------------------------ internals
    def _settle(self) -> None:
        txn = self._provisional
        self._provisional = None
        if txn.cmd.status is None:
            txn.cmd.status = OK

    def _release(self) -> list[Event]:
        held = self._held
        out = []
        while held:
            head = held[0]
            if head.kind == COMMAND and head.status is None:
                break
            out.append(held.popleft())
        return out

    def _expire(self, t: float) -> None:
        txn = self._awaiting_ack
        if txn is not None and txn.deadline is not None and t > txn.deadline:
            self._no_ack(txn, f"no ACK/NAK within {self.timeouts.ack * 1000:g} ms")
            self._timed_out = txn
        if self._awaiting_result:
            keep = []
            for txn in self._awaiting_result:
                if txn.deadline is not None and t > txn.deadline:
                    self._no_result(txn, f"none within {self.timeouts.result_for(txn.cmd):g} s of the ACK")
                else:
                    keep.append(txn)
            self._awaiting_result = keep

    def _no_ack(self, txn: _Txn, why: str) -> None:
        txn.cmd.status = NO_ACK
        txn.cmd.note(f"{P_UNANSWERED}: {why}")
        if self._awaiting_ack is txn:
            self._awaiting_ack = None

    def _no_result(self, txn: _Txn, why: str) -> None:
        if txn.optional:
            return
        txn.cmd.status = NO_RESULT
        txn.cmd.note(f"{P_NO_RESULT}: {why}")

    def _classify(self, ev: Event) -> str:
        """Single-line tap: is this frame a command or a result? (docs/decoding.md, "Pairing")

        A frame that fits a result someone is waiting for is that result. Otherwise
        the direction decides once it is known (commands travel from the
        controller's source group), and where it cannot (controller and devices in
        one group) a payload that parses as a command is one.
        """
        for txn in reversed(self._awaiting_result):
            if address_fits(txn.cmd, ev) and result_fits(txn.cmd.entry, ev.payload):
                return RESULT
        txn = self._awaiting_ack
        if txn is not None and txn.cmd.dst[0] != txn.cmd.src and address_fits(txn.cmd, ev) \
                and result_fits(txn.cmd.entry, ev.payload):
            return RESULT
        groups = self._controller_groups
        g = ev.dst[0]
        if groups and ev.src != g:
            if ev.src in groups and g not in groups:
                return COMMAND
            if g in groups and ev.src not in groups:
                return RESULT
        if dissect_command(ev.payload).entry is None:
            return RESULT
        groups.add(ev.src)
        return COMMAND

    def _command(self, ev: Event) -> None:
        if ev.command is None:
            apply_command(ev)
        if self._awaiting_ack is not None:
            self._no_ack(self._awaiting_ack, "no ACK/NAK before the next command")
        self._timed_out = None
        if self._awaiting_result:
            keep = []
            window = self.timeouts.untimed_window
            for txn in self._awaiting_result:
                txn.age += 1
                if txn.cmd.command == ev.command and txn.cmd.dst == ev.dst:
                    self._no_result(txn, "the command was sent again before it came")
                elif ev.t is None and txn.age > window:
                    self._no_result(txn, f"none within the next {window} commands")
                else:
                    keep.append(txn)
            self._awaiting_result = keep
        prev = self._last_cmd
        if prev is not None and prev.cmd.status in (ST_NAK, NO_ACK, NO_RESULT) and _repeats(prev.cmd, ev):
            ev.retransmission = True
            ev.note(f"{P_RETRANSMISSION}: repeats #{prev.cmd.number} after {prev.cmd.status}")
        self._txn_no += 1
        txn = _Txn(ev, self._txn_no)
        ev.txn = self._txn_no
        if ev.t_end is not None:
            txn.deadline = ev.t_end + self.timeouts.ack
        self._awaiting_ack = txn
        self._last_cmd = txn

    def _link(self, ev: Event, txn: _Txn) -> None:
        cmd = txn.cmd
        ev.txn = txn.no
        ev.request = cmd.number
        if ev.dst is None:   # an ACK/NAK/NIC names no device: it is its command's
            ev.device = cmd.device
        if ev.t is not None and cmd.t_end is not None:
            ev.latency = round(ev.t - cmd.t_end, 9)

    def _handshake(self, ev: Event) -> None:
        txn = self._awaiting_ack
        if txn is None:
            late = self._timed_out
            if late is not None:
                self._link(ev, late)
                ev.note(f"{P_LATE}: after the {self.timeouts.ack * 1000:g} ms ACK timeout")
                self._timed_out = None
            else:
                ev.note(f"{P_ORPHAN}: no command awaits an ACK/NAK")
            return
        self._awaiting_ack = None
        self._link(ev, txn)
        cmd = txn.cmd
        if ev.kind == NAK:
            cmd.status = ST_NAK
            return
        self._last_ack = (ev, txn)
        due = cmd.entry.result_due if cmd.entry is not None else None
        if due == DUE or due == OPTIONAL:
            txn.optional = due == OPTIONAL
            if ev.t_end is not None:
                txn.deadline = ev.t_end + self.timeouts.result_for(cmd)
            self._awaiting_result.append(txn)
            if len(self._awaiting_result) > 64:   # a runaway controller: keep memory flat
                old = self._awaiting_result.pop(0)
                self._no_result(old, "too many commands waiting for results")
                if old.cmd.status is None:
                    old.cmd.status = OK
        if due != DUE:
            self._provisional = txn
            self._provisional_since = ev.t_end

    def _nic(self, ev: Event) -> None:
        last = self._last_ack
        if last is None or self._prev is not last[0] or last[1].cmd.status not in (None, OK):
            ev.note(f"{P_ORPHAN}: NIC not right after an ACK")
            return
        txn = last[1]
        self._link(ev, txn)
        txn.cmd.status = ST_NIC
        if self._provisional is txn:
            self._provisional = None
        if txn in self._awaiting_result:
            self._awaiting_result.remove(txn)
        self._last_ack = None

    def _result(self, ev: Event) -> None:
        match = None
        fallback = None
        candidates = list(self._awaiting_result)
        if self._awaiting_ack is not None:
            candidates.append(self._awaiting_ack)
        for txn in reversed(candidates):
            if address_fits(txn.cmd, ev):
                if result_fits(txn.cmd.entry, ev.payload):
                    match = txn
                    break
                if fallback is None and not txn.optional:
                    fallback = txn
        txn = match or fallback
        if txn is None:
            ev.note(f"{P_ORPHAN}: no command awaits this result")
            return
        cmd = txn.cmd
        self._link(ev, txn)
        ev.command = cmd.command
        ev.entry = cmd.entry
        fields, problems = dissect_result(cmd.entry, ev.payload)
        ev.fields = fields
        if problems:
            ev.note(*problems)
        if txn is self._awaiting_ack:   # the ACK was lost but the result came
            self._awaiting_ack = None
            cmd.note(f"{P_UNANSWERED}: no ACK seen, but the result arrived")
        else:
            self._awaiting_result.remove(txn)
        if cmd.status is None:
            cmd.status = OK
