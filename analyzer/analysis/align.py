"""Ordering two untimed lines (raw dumps): which answers on line B belong to which
command on line A (docs/decoding.md, "Pairing where the document says nothing").

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
from collections.abc import Iterator
from itertools import islice

from dissectors import apply_command, result_fits
from dissectors.commands import DUE
from dissectors.event import ACK, COMMAND, NAK, NIC, RESULT, Event

from .pairing import address_fits

WINDOW = 8   # commands and groups considered when a choice is not obvious
SKIP = 2  # cost of leaving a command unanswered, or a group unclaimed


class _Stream:
    """Pull-based buffer over batches of events (one list per deframer feed),
    grouped into units; batches keep the per-event cost of this layer low."""

    def __init__(self, batches: Iterator[list[Event]]) -> None:
        self._batches = batches
        self._pending: list[Event] = []
        self.units: deque[list[Event]] = deque()
        self.done = False

    def fill(self, n: int) -> None:
        while len(self.units) < n and not self.done:
            batch = next(self._batches, None)
            if batch is None:
                self.done = True
                if self._pending:
                    self._flush_pending()
                return
            self._add(batch)

    def _flush_pending(self) -> None:
        self.units.append(self._pending)
        self._pending = []

    def _add(self, batch: list[Event]) -> None:
        raise NotImplementedError


class _Commands(_Stream):
    """Units of line A: any noise, then one command (noise at the end stands alone)."""

    def _add(self, batch: list[Event]) -> None:
        pending = self._pending
        units = self.units
        for ev in batch:
            pending.append(ev)
            if ev.kind == COMMAND:
                apply_command(ev)
                units.append(pending)
                pending = []
        self._pending = pending


class _Groups(_Stream):
    """Units of line B: an ACK or NAK and what follows it until the next one."""

    def __init__(self, batches: Iterator[list[Event]]) -> None:
        super().__init__(batches)
        self.lead: list[Event] = []   # before the first ACK/NAK: nothing can claim it

    def _flush_pending(self) -> None:
        if self._pending[0].kind in (ACK, NAK):
            self.units.append(self._pending)
        else:
            self.lead.extend(self._pending)
        self._pending = []

    def _add(self, batch: list[Event]) -> None:
        pending = self._pending
        units = self.units
        for ev in batch:
            kind = ev.kind
            if kind == ACK or kind == NAK:
                if pending:
                    if pending[0].kind in (ACK, NAK):
                        units.append(pending)
                    else:
                        self.lead.extend(pending)
                pending = [ev]
            else:
                pending.append(ev)
        self._pending = pending


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
    if len(group) == 2 and kind == ACK and group[1].kind == RESULT:
        # the next most common: an ACK and one result (the general case below, for one result)
        r = group[1]
        entry = cmd.entry
        if address_fits(cmd, r) and result_fits(entry, r.payload):
            return 0
        stray = not any(address_fits(c, r) and result_fits(c.entry, r.payload) for c in late)
        if entry is not None and entry.result_due == DUE:
            return 2 if stray else 1
        return 1 if stray else 0
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


BATCH = 4096   # events per batch yielded: pairing takes them a batch at a time


def align(a_batches: Iterator[list[Event]], b_batches: Iterator[list[Event]]) -> Iterator[list[Event]]:
    """Interleave line A's and line B's events (given as batches, in line order);
    yields batches of events in plausible wire order.

    (Written for speed: the loop runs once per command, and units go straight
    into the batch rather than through a generator of their own.)"""
    cmds = _Commands(a_batches)
    groups = _Groups(b_batches)
    late: deque[Event] = deque(maxlen=8)   # commands whose due result has not come yet

    cunits, gunits = cmds.units, groups.units
    cpop, gpop = cunits.popleft, gunits.popleft
    out: list[Event] = []
    while True:
        if len(out) >= BATCH:
            yield out
            out = []
        if len(cunits) < WINDOW:
            cmds.fill(WINDOW)
        if len(gunits) < WINDOW:
            groups.fill(WINDOW)
        if groups.lead:
            out += groups.lead
            groups.lead.clear()
        if not cunits:
            out += _rest(groups)
            if out:
                yield out
            return
        unit = cunits[0]
        cmd = unit[-1]
        if cmd.kind != COMMAND or not gunits:
            out += cpop()
            continue
        group = gunits[0]
        cost = _fit(cmd, group, late)
        nxt = cunits[1][-1] if len(cunits) > 1 else None
        # The next command repeats this one's bytes and would be left without a
        # fitting answer: the answer may belong to that retransmission instead.
        repeated = (cost == 0 and nxt is not None and nxt.raw == cmd.raw and nxt.kind == COMMAND and (
            len(gunits) < 2 or _fit(nxt, gunits[1], late) > 0))
        if repeated or cost:
            move = _first_move(cmds, groups, late, repeated)
            if move == "skip_cmd":
                out += cpop()
                continue
            if move == "skip_group":
                out += gpop()
                continue
        out += cpop()
        out += gpop()
        if late and len(group) > 1:
            _claim_late(group, late)
        entry = cmd.entry
        if entry is not None and entry.result_due == DUE and group[0].kind == ACK and (
                len(group) == 1 or not any(e.kind in (RESULT, NIC) for e in group)):
            late.append(cmd)


def _first_move(cmds: _Commands, groups: _Groups, late: deque, repeated: bool) -> str:
    """The first move of the cheapest alignment of the next commands and groups
    (``_plan``), when the next group does not plainly answer the next command."""
    cunits, gunits = cmds.units, groups.units
    window = [c for c in map(_command_of, islice(cunits, WINDOW)) if c is not None]
    # a controller repeats a command's bytes only after a failure
    return _plan(window, list(islice(gunits, WINDOW)), late, prefer_skip=repeated,
                 cmds_end=cmds.done and len(cunits) <= WINDOW,
                 groups_end=groups.done and len(gunits) <= WINDOW)


def _claim_late(group: list[Event], late: deque) -> None:
    """The results in ``group`` that a late command was waiting for: it waits no more."""
    for r in group:
        if r.kind == RESULT:
            for c in late:
                if address_fits(c, r) and result_fits(c.entry, r.payload):
                    late.remove(c)
                    break


def _rest(groups: _Groups) -> list[Event]:
    """Line A has ended: every group left, in order, and what came before the
    first of them."""
    out: list[Event] = []
    units = groups.units
    while units:
        out += units.popleft()
        groups.fill(1)
    out += groups.lead
    return out
