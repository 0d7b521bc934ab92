"""A simulated gimbal: the protocol's answers from a state model (no I/O here).

``GimbalModel.handle(event, now)`` takes a decoded command frame and returns the
bytes to send back and when: ACK or NAK (§1.4.2), NIC after the ACK for what it
does not implement, and the result frame for queries (§1.4.3, groups swapped per
Table 3). Position moves toward go-to targets at the set rates (Tables 11-15);
presets, software limits, gains, lens, relays, device ID, and IX initialisation
that takes seconds (Table 9) are modelled. What each command does is one entry of
the table in ``answers``.

Rate-set commands (``C0``…``C7``, Table 4) are ACKed at the gimbal's rate and the
ACK says which rate it listens at once that ACK has left (``Reply.baud``); the
bus it is installed on reconfigures the port (docs/time.md, "Rate changes").
``C8``…``CF`` are reserved: ACK then NIC, and the rate stays.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

from dissectors import dissect_command
from dissectors.event import Event
from dissectors.problems import MALFORMED, RESERVED
from dissectors.wire import ACK, NAK, NIC, WILDCARD, build_frame

from .answers import ANSWERS

# What this firmware does not implement: answered with ACK then NIC.
NOT_IMPLEMENTED = {"FA", "FX", "ZA-ZF", "L0", "L1", "L8", "L9", "VS", "F?", "Z?", "C?", "*dA", "*di", "*do",
                   "*dl", "*dm", "*mr", "*me", "*mp", "*mu", "*sa", "*sgr", "*sgp", "*sl", "HP", "VP"}


@dataclass
class Faults:
    """Protocol faults injected by the gimbal (wire faults live on the link)."""
    drop_ack: float = 0.0      # probability of not answering at all
    late: float = 0.0          # probability of answering after ``late_by`` seconds
    late_by: float = 0.8
    silent: bool = False       # never answers (no power, wrong address setting, a cut drop)
    drift: float = 0.0         # seconds of extra answer delay per second of uptime (a device slowing down)
    ignore_rate: bool = False  # ACKs a rate-set but keeps its rate (firmware that does not switch)
    seed: int = 1
    rng: random.Random = field(init=False)

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)


@dataclass
class Reply:
    at: float        # when to send (host time)
    data: bytes
    baud: int | None = None   # the ACK of a rate-set: the rate the gimbal listens at once it has left


class GimbalModel:
    def __init__(self, address: tuple[int, int, int], *, name: str = "GS-SIM PT-200", serial: str = "SN0001",
                 init_seconds: float = 3.0, answer_delay: float = 0.003, faults: Faults | None = None) -> None:
        self.address = address
        self.baud = 9600                     # its UART's rate: the bus it is installed on sets its port's
        self.name, self.serial = name, serial
        self.init_seconds = init_seconds
        self.answer_delay = answer_delay
        self.faults = faults or Faults()
        self._born: float | None = None   # when the first command came (drift)
        self.az = self.el = 0.0              # degrees
        self.target: tuple[float, float] | None = None
        self.sweep = (0.0, 0.0)              # continuous motion direction per axis (-1, 0, 1)
        self.rate = [10.0, 10.0]             # deg/s pan, tilt (RP/RT)
        self.accel = [20.0, 20.0]            # deg/s² (AP/AT)
        self.gain = [1.5, 1.5]
        self.speed = [15, 15]
        self.vector = False
        self.presets: dict[int, tuple[float, float]] = {}
        self.limits = [0x000, 0xFFF, 0x000, 0xFFF]
        self.zoom = self.focus = 0
        self.relays = 0
        self.motors_on = True
        self.initialized = [True, True]
        self.initializing_until: float | None = None
        self.last_time = 0.0

    # ------------------------------------------------------------- motion
    def update(self, now: float) -> None:
        dt = max(0.0, now - self.last_time)
        self.last_time = now
        if not self.motors_on or dt == 0:
            return
        if self.target is not None:
            ta, te = self.target
            self.az = _approach(self.az, ta, self.rate[0] * dt)
            self.el = _approach(self.el, te, self.rate[1] * dt)
            if (self.az, self.el) == (ta, te):
                self.target = None
        else:
            self.az = max(-327.68, min(327.67, self.az + self.sweep[0] * self.rate[0] * dt))
            self.el = max(-327.68, min(327.67, self.el + self.sweep[1] * self.rate[1] * dt))

    # ------------------------------------------------------------ commands
    def addressed(self, ev: Event) -> bool:
        assert ev.dst is not None   # a command frame's
        g, p, d = ev.dst
        mg, mp, md = self.address
        return (g in (mg, WILDCARD)) and (p in (mp, WILDCARD)) and (d in (md, WILDCARD))

    def handle(self, ev: Event, now: float) -> list[Reply]:
        """The replies to one command frame addressed to this gimbal."""
        assert ev.payload is not None and ev.src is not None   # a command frame's
        self.update(now)
        f = self.faults
        if f.silent:
            return []
        at = now + self.answer_delay
        if f.drift:
            if self._born is None:
                self._born = now
            at += f.drift * (now - self._born)
        if not ev.checksum_ok:
            return [Reply(at, bytes([NAK]))]
        if f.drop_ack and f.rng.random() < f.drop_ack:
            return []
        if f.late and f.rng.random() < f.late:
            at += f.late_by
        decoded = dissect_command(ev.payload)
        cid = decoded.command
        if decoded.entry is None or cid in NOT_IMPLEMENTED or any(
                p.category is MALFORMED or p.category is RESERVED for p in decoded.problems):
            return [Reply(at, bytes([ACK, NIC]))]
        result = self._execute(cid, decoded.fields)
        replies = [Reply(at, bytes([ACK]), baud=self._rate_after(cid, decoded.fields))]
        if result is not None:
            delay, payload = result
            g, p, d = self.address
            replies.append(Reply(at + 0.001 + delay, build_frame((ev.src, p, d), g, payload)))
        return replies

    def _rate_after(self, cid: str, v: dict) -> int | None:
        """The rate this gimbal listens at once its ACK has left, for a rate-set
        (``C0``…``C7``; the reserved codes were NICed before); None for the rest."""
        if cid != "C":
            return None
        return self.baud if self.faults.ignore_rate else v["baud"]

    def _execute(self, cid: str, v: dict) -> tuple[float, str] | None:
        """Apply a command (``answers.ANSWERS``); return (extra delay, result
        payload) when one is due."""
        handler = ANSWERS.get(cid)
        answer = handler(self, v) if handler is not None else None
        if answer is None or isinstance(answer, tuple):
            return answer
        return 0.0, answer


def _approach(x: float, target: float, step: float) -> float:
    if abs(target - x) <= step:
        return target
    return x + step if target > x else x - step
