"""Clock skew between the two lines of a tap (two USB serial adapters deliver
with different delays: their latency timers differ). An answer cannot start
before its command ended (§1.4.2: the device answers a received command), so an
apparent negative latency measures how far line B reads ahead of line A.

Pure: fed commands (line A) and ACK/NAK bytes (line B) as the deframers give them,
in arrival order; it pairs each ACK/NAK with a command near it in time, keeps the
most negative apparent latency among the last ``window`` pairs, and says how much
later line B's times should be to make every one of them causal (plus a small
guard for the device's own reaction time).

Which command an ACK/NAK answers: the latest command not yet answered that ended
before it (an ordinary answer, however late its line's reads arrived: a reader
that lags delivers several answers after several commands, and pairing each with
the last command would invent a skew of a whole poll cycle); else the first one
that ended after it (line B reads ahead); else, when no command is waiting for
an answer (a late answer to one that is, up to ``LATE``, measures nothing), the
next command to arrive (line B's adapter delivered the answer before line A's
delivered the command). Which of these holds is decided by the times, whichever
line's reader lagged: an answer that arrives before the commands around it is
judged when they arrive, by the same rules.

An answer read ahead of a command may instead answer a command the tap saw only
as noise on line A (bit errors in its start byte: the device read it whole): the
answer that then comes before the next command is no measure of skew. Line A's
noise is kept for that, and the nearer explanation wins: a garbled frame that
ended shortly before the answer, or the command that ended after it.
"""

from __future__ import annotations

from collections import deque

from dissectors.event import ACK, COMMAND, NAK, NOISE, Event

# seconds: an answer this long after a command can still be its (slow devices,
# lost bytes); beyond it, a command left unanswered is not waiting any more
LATE = 1.0


class SkewEstimator:
    def __init__(self, window: int = 64, near: float = 0.05, guard: float = 0.0002) -> None:
        self.window = window
        # seconds: farther apart, they are not a command and its answer. Adapter
        # skew is milliseconds (USB latency timers are 1-16 ms); a wide window would
        # pair an answer with the next command and invent a skew.
        self.near = near
        self.guard = guard      # a device needs at least this long to answer
        self._samples: deque[float] = deque(maxlen=window)
        # when each command not yet answered ended, in arrival order: enough for a
        # line B reader that lags by seconds (a busy screen) behind line A's
        self._unanswered: deque[float] = deque(maxlen=64)
        # when each ACK/NAK that came before its command started, as read (oldest
        # first: line A's reader may lag by several commands). Its event is moved
        # later by the correction of the moment (the capture shifts line B), and a
        # sample must measure the skew itself, not what the correction left
        self._early: deque[float] = deque(maxlen=64)
        # when line A's latest noise ended: frames garbled on the tap's wire that
        # the device may have read whole and answered
        self._garbled: deque[float] = deque(maxlen=16)
        self.skew = 0.0                      # seconds to add to line B's times

    def observe(self, ev: Event) -> bool:
        """Take one deframed event, before any correction; True when the estimate changed."""
        kind = ev.kind
        if kind == COMMAND and ev.t_end is not None:
            return self._command(ev.t_end)
        if (kind == ACK or kind == NAK) and ev.t is not None:
            return self._answer(ev.t)
        if kind == NOISE and ev.line == "A" and ev.t_end is not None:
            self._garbled.append(ev.t_end)
        return False

    def _command(self, end: float) -> bool:
        """A command that ended at ``end``: paired with an answer read before it, or
        left waiting for one."""
        early = self._early
        # answers read before it that started too long before it ended answer
        # neither it nor a later command (a late answer, or one to a command the
        # tap never saw)
        while early and early[0] <= end - self.near:
            early.popleft()
        if early and early[0] < end + self.near:
            answer = early.popleft()
            if answer >= end or self._read_ahead(answer, end):
                return self._sample(answer - end)
            # the answer was another's: this command still waits for its own
        self._unanswered.append(end)
        return False

    def _answer(self, t: float) -> bool:
        """An ACK/NAK starting at ``t``: paired with a command read before it (module
        doc), or kept for the command it may be read ahead of."""
        waiting, near = self._unanswered, self.near
        before = [k for k, end in enumerate(waiting) if t - near < end <= t]
        if before:
            return self._sample(t - self._take(before[-1]))
        after = next((k for k, end in enumerate(waiting) if t < end < t + near), None)
        if after is not None:
            # (_read_ahead takes no command off the waiting when it says yes)
            if self._read_ahead(t, waiting[after]):
                return self._sample(t - self._take(after))
            return False   # the answer was another's: that command still waits for its own
        if not self._late(t):
            self._early.append(t)
        return False

    def _read_ahead(self, t: float, end: float) -> bool:
        """Whether an answer starting at ``t``, before a command that ended at ``end``,
        is that command's answer read ahead of it (a measure of skew), whichever was
        read first; not when it can be a late answer to a command that was waiting
        (taken off the waiting then), or a garbled frame's."""
        return not (self._late(t) or self._garbled_nearer(t, end))

    def _garbled_nearer(self, t: float, end: float) -> bool:
        """Whether an answer at ``t``, read ahead of a command that ended at ``end``,
        is better explained as the answer to a frame garbled on line A that ended
        before it, nearer than the command's end after it (module doc)."""
        ahead = end - t
        return ahead > 0 and any(0 <= t - g < ahead for g in self._garbled)

    def _late(self, t: float) -> bool:
        """Whether an answer at ``t`` that is near no command can be a late answer
        to a command still unanswered (one that ended before it, within ``LATE``);
        those are then taken as answered. Only an answer no command is waiting
        for can be one read ahead of its command."""
        waiting = self._unanswered
        late = any(t - LATE < end <= t for end in waiting)
        if late:
            while waiting and waiting[0] <= t:
                waiting.popleft()
        return late

    def _take(self, k: int) -> float:
        """The end of waiting command ``k``, taken with those before it off the waiting."""
        waiting = self._unanswered
        for _ in range(k):
            waiting.popleft()
        return waiting.popleft()

    def _sample(self, latency: float) -> bool:
        """``latency`` as measured, before any correction."""
        self._samples.append(latency)
        need = max(0.0, self.guard - min(self._samples))
        changed = abs(need - self.skew) > 1e-6
        self.skew = need
        return changed
