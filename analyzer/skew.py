"""Clock skew between the two lines of a tap (two USB serial adapters deliver
with different delays: their latency timers differ). An answer cannot start
before its command ended (§1.4.2: the device answers a received command), so an
apparent negative latency measures how far line B reads ahead of line A.

Pure: fed commands (line A) and ACK/NAK bytes (line B) as the deframers give them,
in arrival order; it pairs each command with the next ACK/NAK near it in time,
keeps the most negative apparent latency among the last ``window`` pairs, and
says how much later line B's times should be to make every one of them causal
(plus a small guard for the device's own reaction time).
"""

from __future__ import annotations

from collections import deque

from dissectors.event import ACK, COMMAND, NAK, Event


class SkewEstimator:
    def __init__(self, window: int = 64, near: float = 0.05, guard: float = 0.0002) -> None:
        self.window = window
        # seconds: farther apart, they are not a command and its answer. Adapter
        # skew is milliseconds (USB latency timers are 1-16 ms); a wide window would
        # pair an answer with the next command and invent a skew.
        self.near = near
        self.guard = guard      # a device needs at least this long to answer
        self._samples: deque[float] = deque(maxlen=window)
        self._cmd_end: float | None = None   # when a command waiting for its ACK/NAK ended
        # when an ACK/NAK that came before its command started, as read: its event
        # is moved later by the correction of the moment (the capture shifts line
        # B), and a sample must measure the skew itself, not what the correction left
        self._answer_t: float | None = None
        self.skew = 0.0                      # seconds to add to line B's times

    def observe(self, ev: Event) -> bool:
        """Take one deframed event, before any correction; True when the estimate changed."""
        kind = ev.kind
        if kind == COMMAND and ev.t_end is not None:
            answer = self._answer_t
            if answer is not None and abs(answer - ev.t_end) < self.near:
                self._answer_t = None
                return self._sample(answer - ev.t_end)
            self._cmd_end = ev.t_end
        elif (kind == ACK or kind == NAK) and ev.t is not None:
            end = self._cmd_end
            if end is not None and abs(ev.t - end) < self.near:
                self._cmd_end = None
                return self._sample(ev.t - end)
            self._answer_t = ev.t
        return False

    def _sample(self, latency: float) -> bool:
        """``latency`` as measured, before any correction."""
        self._samples.append(latency)
        need = max(0.0, self.guard - min(self._samples))
        changed = abs(need - self.skew) > 1e-6
        self.skew = need
        return changed
