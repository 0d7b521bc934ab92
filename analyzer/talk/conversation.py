"""A conversation with gimbals: requests sent one at a time on a ``TalkLink``, each
waiting for its answer as pairing judges it (ACK, NAK, NIC, the result when one is
due, or a timeout), resent as a controller would (``retries``), then the next.

It is a listener of the tap runner that reads the link, like the printer and the
recorder beside it: what it sends comes back to it as line A's command events,
paired with line B's answers by the same pairing every capture has, with the
same timeouts (``--ack-timeout``, ``--result-timeout``). It never reads the port
itself.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from dissectors.event import ACK, COMMAND, NAK, NIC, NO_ACK, NOISE, OK, RESULT, ST_NAK, Event

from ..runner import Listener, TapRunner
from .link import TalkLink

RESENT = (ST_NAK, NO_ACK)   # what a controller sends again (a NIC is an answer: the command is not implemented)


@dataclass(frozen=True)
class Step:
    """One request: ``frame`` sent (again up to ``retries`` times on a NAK or no
    answer), at ``baud`` when given (the link switched first, no command sent)."""
    frame: bytes
    retries: int = 0
    baud: int | None = None
    label: Any = None


@dataclass
class Outcome:
    """What came of a step: its last try's command event and the answers to it."""
    step: Step
    command: Event | None = None
    answers: list[Event] = field(default_factory=list)
    tries: int = 0
    garbled: int = 0     # line B events that were not answers: noise, frames with bad checksums

    @property
    def status(self) -> str:
        """The command's status as pairing ended it (``no_ack`` when it never came back)."""
        if self.command is None or self.command.status is None:
            return NO_ACK
        return self.command.status

    @property
    def handshake(self) -> Event | None:
        """The ACK, NAK or NIC, whichever answered last."""
        shakes = [ev for ev in self.answers if ev.kind in (ACK, NAK, NIC)]
        return shakes[-1] if shakes else None

    @property
    def result(self) -> Event | None:
        return next((ev for ev in self.answers if ev.kind == RESULT), None)

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def answered(self) -> bool:
        """Something answered this address: an ACK, NAK, NIC or result."""
        return bool(self.answers)


class Conversation(Listener):
    """Sends ``steps`` in order on ``link`` as the runner reads it; each outcome
    goes to ``on_outcome``; the runner is stopped after the last (or on ``stop``)."""

    def __init__(self, link: TalkLink, steps: Iterable[Step],
                 on_outcome: Callable[[Outcome], None] | None = None) -> None:
        self.link = link
        self._steps: Iterator[Step] = iter(steps)
        self._on_outcome = on_outcome
        self.outcomes: list[Outcome] = []
        self._runner: TapRunner | None = None
        self._current: Outcome | None = None
        self.finished = False       # every step had its outcome

    def on_start(self, runner: TapRunner) -> None:
        self._runner = runner
        self._next()

    def on_events(self, events: list[Event]) -> None:
        now = self._current
        if now is None:
            return
        # pairing releases a command once its status is final, its answers with it
        settled = False
        for ev in events:
            if ev.kind == COMMAND:
                now.command = ev
                settled = ev.status is not None
            elif now.command is not None and ev.request == now.command.number:
                now.answers.append(ev)
            elif ev.kind == NOISE or ev.checksum_ok is False:
                now.garbled += 1
        if settled:
            self._after_try(now)

    def _after_try(self, now: Outcome) -> None:
        if now.status in RESENT and now.tries <= now.step.retries:
            self._send(now)
            return
        self.outcomes.append(now)
        self._current = None
        if self._on_outcome is not None:
            self._on_outcome(now)
        self._next()

    def _next(self) -> None:
        step = next(self._steps, None)
        if step is None:
            self.finished = True
            self.stop()
            return
        if step.baud is not None:
            self.link.set_rate(step.baud)
        self._current = Outcome(step)
        self._send(self._current)

    def _send(self, now: Outcome) -> None:
        now.tries += 1
        now.answers = []
        self.link.write(now.step.frame)

    def stop(self) -> None:
        """End the conversation: the runner stops after this step."""
        if self._runner is not None:
            self._runner.stop()
