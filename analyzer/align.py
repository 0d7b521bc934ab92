"""Ordering two untimed lines (raw dumps): which answers on line B belong to which
command on line A (spec/READING.md, "A capture without time … still pairs").

Without time the interleaving of the two lines is unknown. Line B is cut into
answer groups (an ACK or NAK with the NIC, results and noise after it); the
commands of line A and these groups are then aligned like two sequences: a
command either takes the next group, or went unanswered, or the group answers
nothing. A group that fits the command (a NAK, an ACK+NIC, an ACK with the due
result from the right address) is taken at once; otherwise a short look-ahead
(a small edit-distance alignment) picks the cheapest first move, judged by addresses and result layouts.
The output is one event sequence in plausible wire order, fed to pairing.
"""

from __future__ import annotations

from collections import deque
from typing import Iterator

from dissectors import apply_command, result_fits
from dissectors.commands import DUE
from dissectors.event import ACK, COMMAND, NAK, NIC, RESULT, Event

from .pairing import address_fits

WINDOW = 8   # commands and groups considered when a choice is not obvious
SKIP = 2  # cost of leaving a command unanswered, or a group unclaimed


class _Stream:
    """Pull-based buffer over an event iterator, grouped into units."""

    def __init__(self, it: Iterator[Event], is_head) -> None:
        self._it = it
        self._is_head = is_head
        self._pending: list[Event] = []
        self.units: deque[list[Event]] = deque()
        self.done = False

    def fill(self, n: int) -> None:
        while len(self.units) < n and not self.done:
            ev = next(self._it, None)
            if ev is None:
                self.done = True
                if self._pending:
                    self.units.append(self._pending)
                    self._pending = []
                return
            self._add(ev)

    def _add(self, ev: Event) -> None:
        raise NotImplementedError


class _Commands(_Stream):
    """Units of line A: any noise, then one command (noise at the end stands alone)."""

    def _add(self, ev: Event) -> None:
        self._pending.append(ev)
        if ev.kind == COMMAND:
            apply_command(ev)
            self.units.append(self._pending)
            self._pending = []


class _Groups(_Stream):
    """Units of line B: an ACK or NAK and what follows it until the next one."""

    def __init__(self, it: Iterator[Event]) -> None:
        super().__init__(it, None)
        self.lead: list[Event] = []   # before the first ACK/NAK: nothing can claim it

    def _add(self, ev: Event) -> None:
        if ev.kind in (ACK, NAK):
            if self._pending:
                if self._pending[0].kind in (ACK, NAK):
                    self.units.append(self._pending)
                else:
                    self.lead.extend(self._pending)
            self._pending = [ev]
        else:
            self._pending.append(ev)


def _command_of(unit: list[Event]) -> Event | None:
    last = unit[-1]
    return last if last.kind == COMMAND else None


def _fit(cmd: Event, group: list[Event], late: deque) -> float:
    """0: the group answers the command as the protocol says; 1: plausibly; 2: badly."""
    head = group[0]
    kind = head.kind
    if kind != ACK and kind != NAK:
        return SKIP
    if len(group) == 1:   # the common case: a lone ACK or NAK
        return 1 if kind == ACK and cmd.entry is not None and cmd.entry.result_due == DUE else 0
    results = [e for e in group if e.kind == RESULT]
    if kind == NAK:
        return 0 if not results else 1
    for e in group:
        if e.kind == NIC:
            # a device NICs what it does not know: certain for an unknown command,
            # a weaker fit for one the document defines
            base = 0 if cmd.entry is None else 0.5
            return base if not results else base + 1
    entry = cmd.entry
    due = entry is not None and entry.result_due == DUE
    own = False
    stray = False
    for r in results:
        if address_fits(cmd, r) and result_fits(entry, r.payload):
            own = True
        elif not any(address_fits(c, r) and result_fits(c.entry, r.payload) for c in late):
            stray = True
    if due and not own:
        return 2 if stray else 1
    return 1 if stray else 0


def _plan(cmds: list[Event], groups: list[list[Event]], late: deque, prefer_skip: bool = False,
          cmds_end: bool = False, groups_end: bool = False) -> str:
    """First move of the cheapest alignment of a window of commands and groups.

    Edit distance with a free end: D[a][b] is the cost of aligning cmds[a:] with
    groups[b:], where a command may take a group (its fit), go unanswered (SKIP)
    or leave a group unclaimed (SKIP). A wrong early choice shifts every later
    pairing, and the shift shows as mismatched results further on. What lies past
    the window is free, unless that stream has ended: then every leftover item
    is certainly unanswered (or unclaimed) and costs SKIP.
    """
    n, m = len(cmds), len(groups)
    fits = [[_fit(c, g, late) for g in groups] for c in cmds]
    # row a = n: leftover groups
    nxt = [(m - b) * SKIP if cmds_end else 0.0 for b in range(m + 1)]
    first_moves = None
    for a in range(n - 1, -1, -1):
        row = [0.0] * (m + 1)
        row[m] = (n - a) * SKIP if groups_end else 0.0   # leftover commands
        for b in range(m - 1, -1, -1):
            take = fits[a][b] + nxt[b + 1]
            skip_cmd = SKIP + nxt[b]
            skip_group = SKIP + row[b + 1]
            row[b] = min(take, skip_cmd, skip_group)
            if a == 0 and b == 0:
                first_moves = (take, skip_cmd, skip_group)
        nxt = row
    if first_moves is None:
        return "take"
    take, skip_cmd, skip_group = first_moves
    if prefer_skip and skip_cmd <= take and skip_cmd <= skip_group:
        return "skip_cmd"
    if take <= skip_cmd and take <= skip_group:
        return "take"
    return "skip_cmd" if skip_cmd <= skip_group else "skip_group"


def align(a_events: Iterator[Event], b_events: Iterator[Event]) -> Iterator[Event]:
    cmds = _Commands(a_events, None)
    groups = _Groups(b_events)
    late: deque[Event] = deque(maxlen=8)   # commands whose due result has not come yet

    while True:
        cmds.fill(WINDOW)
        groups.fill(WINDOW)
        if groups.lead:
            yield from groups.lead
            groups.lead.clear()
        if not cmds.units:
            while groups.units:
                yield from groups.units.popleft()
                groups.fill(1)
            yield from groups.lead
            return
        unit = cmds.units[0]
        cmd = _command_of(unit)
        if cmd is None or not groups.units:
            yield from cmds.units.popleft()
            continue
        group = groups.units[0]
        move = "take"
        nxt = _command_of(cmds.units[1]) if len(cmds.units) > 1 else None
        # A perfect fit is taken at once, unless the next command repeats this
        # one's bytes: then the answer may belong to the retransmission.
        cost = _fit(cmd, group, late)
        # The next command repeats this one's bytes and would be left without a
        # fitting answer: the answer may belong to that retransmission instead.
        repeated = (nxt is not None and nxt.raw == cmd.raw and cost == 0 and (
            len(groups.units) < 2 or _fit(nxt, groups.units[1], late) > 0))
        if repeated or cost:
            window = [c for c in map(_command_of, cmds.units) if c is not None]
            # a controller repeats a command's bytes only after a failure
            move = _plan(window, list(groups.units), late, prefer_skip=repeated,
                         cmds_end=cmds.done, groups_end=groups.done)
        if move == "skip_cmd":
            yield from cmds.units.popleft()
            continue
        if move == "skip_group":
            yield from groups.units.popleft()
            continue
        yield from cmds.units.popleft()
        yield from groups.units.popleft()
        for r in group:
            if r.kind == RESULT:
                for c in late:
                    if address_fits(c, r) and result_fits(c.entry, r.payload):
                        late.remove(c)
                        break
        if cmd.entry is not None and cmd.entry.result_due == DUE and group[0].kind == ACK and not any(
                e.kind in (RESULT, NIC) for e in group):
            late.append(cmd)
