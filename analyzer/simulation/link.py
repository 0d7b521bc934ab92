"""A virtual RS-232 link made of pseudo-terminals: the controller's port, the
gimbals' port, and a tap port per direction (line A controller→device, line B
device→controller), plus optional wire faults per direction.

Pseudo-terminals move bytes instantly; a wire does not. The link paces each
direction at its sender's rate: bytes are delivered (to the far end and to the
tap) when their last bit would have arrived, so answers cannot overtake commands.
Taps are written without blocking: a tap that stops reading never stalls the link.

Every port's rate is what its user set on its pty (termios, which both ends of a
pty share): a rate-set command (spec Table 4) that the controller and the gimbals
obey moves each direction to the new rate when they reconfigure their ports (the
product's model of rate changes: docs/time.md, "Rate changes"). A listener whose
port runs at another rate than the sender's reads what a UART at its rate makes of
the bits (``uart.misread``), be it a tap left at the old rate or a gimbal that did
not switch.
"""

from __future__ import annotations

import errno
import fcntl
import heapq
import os
import random
import select
import termios
import threading
import time
import tty
from dataclasses import dataclass, field

from .uart import misread


@dataclass
class WireFaults:
    bit_error: float = 0.0     # probability a byte has one bit flipped
    noise: float = 0.0         # probability a write is followed by a noise burst
    seed: int = 7
    rng: random.Random = field(init=False)

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)

    def apply(self, data: bytes) -> bytes:
        if self.bit_error:
            out = bytearray(data)
            for k in range(len(out)):
                if self.rng.random() < self.bit_error:
                    out[k] ^= 1 << self.rng.randrange(8)
            data = bytes(out)
        if self.noise and self.rng.random() < self.noise:
            data += bytes(self.rng.choice((0x00, 0xFF, 0x80, 0xE0, 0x7E)) for _ in range(self.rng.randint(1, 6)))
        return data


_SPEEDS = {getattr(termios, f"B{r}"): r for r in (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)}
_SPEED_CODES = {r: code for code, r in _SPEEDS.items()}


class _Pty:
    def __init__(self, baud: int) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        _set_pty_baud(self.slave, baud)   # the rate of a port its user never configures
        self.path = os.ttyname(self.slave)

    def shut(self) -> None:
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


@dataclass
class Wiring:
    """How the tap is wired to the link (faults of the installation, not the wire)."""
    swapped: bool = False      # the tap's A port is on the device→controller wire, B on the other
    echo: bool = False         # the device-side adapter echoes: line B repeats line A
    dead_b: bool = False       # the device→controller wire is cut: nothing comes back
    wire_baud: int | None = None   # the link really runs at this rate; taps at another rate misread


def _pty_baud(fd: int) -> int | None:
    """The rate the user of a pty set on its end (termios is shared by both ends)."""
    try:
        speed = termios.tcgetattr(fd)[5]
    except termios.error:
        return None
    return _SPEEDS.get(speed)


def _set_pty_baud(fd: int, baud: int) -> None:
    attrs = termios.tcgetattr(fd)
    attrs[4] = attrs[5] = _SPEED_CODES.get(baud, termios.B9600)
    termios.tcsetattr(fd, termios.TCSANOW, attrs)


@dataclass
class _Route:
    """One direction: who hears what the sender's pty carries."""
    peer: int            # the far end's pty
    tap: int             # the tap port of this direction
    faults: WireFaults


@dataclass(order=True)
class _Due:
    at: float            # when the last bit arrives
    seq: int
    sender: int = field(compare=False)
    data: bytes = field(compare=False)
    baud: int = field(compare=False)   # the rate it was sent at


class VirtualLink:
    def __init__(self, a_faults: WireFaults | None = None, b_faults: WireFaults | None = None,
                 baud: int = 9600, wiring: Wiring | None = None) -> None:
        self.wiring = wiring or Wiring()
        if self.wiring.wire_baud:
            baud = self.wiring.wire_baud
        self.baud = baud                 # the rate every port starts at
        self.byte_time = 10 / baud
        self.ctl, self.dev, self.tap_a, self.tap_b = (_Pty(baud) for _ in range(4))
        for p in (self.tap_a, self.tap_b):
            fl = fcntl.fcntl(p.master, fcntl.F_GETFL)
            fcntl.fcntl(p.master, fcntl.F_SETFL, fl | os.O_NONBLOCK)
        self.a_faults = a_faults or WireFaults()
        self.b_faults = b_faults or WireFaults()
        self._rates: dict[int, int] = {}   # each pty's last known rate (read from termios)
        self._halt = threading.Event()
        self._thread = threading.Thread(target=self._forward, daemon=True, name="virtual-link")
        self._thread.start()

    @property
    def controller_port(self) -> str:
        return self.ctl.path

    @property
    def device_port(self) -> str:
        return self.dev.path

    @property
    def tap_ports(self) -> tuple[str, str]:
        if self.wiring.swapped:
            return self.tap_b.path, self.tap_a.path
        return self.tap_a.path, self.tap_b.path

    def _rate_now(self, fd: int) -> int:
        """A pty's rate, read again from termios (once per read or delivery, never per byte)."""
        rate = _pty_baud(fd) or self._rates.get(fd, self.baud)
        self._rates[fd] = rate
        return rate

    def _forward(self) -> None:
        routes = {self.ctl.master: _Route(self.dev.master, self.tap_a.master, self.a_faults),
                  self.dev.master: _Route(self.ctl.master, self.tap_b.master, self.b_faults)}
        busy_until = {fd: 0.0 for fd in routes}       # each direction's wire is busy until then
        due: list[_Due] = []
        seq = 0
        while not self._halt.is_set():
            wait = 0.05 if not due else max(0.0, min(0.05, due[0].at - time.monotonic()))
            ready, _, _ = select.select(list(routes), [], [], wait)
            now = time.monotonic()
            for fd in ready:
                # the rate before the bytes: a sender that switches does so after its
                # last bytes at the old rate have left, and talks at the new one after
                baud = self._rate_now(fd)
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue
                data = routes[fd].faults.apply(data)
                done = max(now, busy_until[fd]) + len(data) * 10 / baud
                busy_until[fd] = done
                seq += 1
                heapq.heappush(due, _Due(done, seq, fd, data, baud))
            if due and due[0].at <= time.monotonic():
                self._deliver(due, routes)

    def _deliver(self, due: list[_Due], routes: dict[int, _Route]) -> None:
        """Everything whose last bit has arrived, as each listener's UART reads it;
        listeners' rates are read once per batch (a gimbal may switch without sending)."""
        listening: dict[int, int] = {}

        def rate_of(fd: int) -> int:
            if fd not in listening:
                listening[fd] = self._rate_now(fd)
            return listening[fd]

        while due and due[0].at <= time.monotonic():
            item = heapq.heappop(due)
            route = routes[item.sender]
            from_device = item.sender == self.dev.master
            if from_device and self.wiring.dead_b:
                continue   # the wire back is cut: neither the controller nor the tap hear it
            try:
                os.write(route.peer, misread(item.data, item.baud, rate_of(route.peer)))
            except OSError:
                continue
            self._to_tap(route.tap, item, rate_of(route.tap))
            if not from_device and self.wiring.echo:
                # the device side hears itself
                self._to_tap(self.tap_b.master, item, rate_of(self.tap_b.master))

    @staticmethod
    def _to_tap(tap: int, item: _Due, listen: int) -> None:
        try:
            os.write(tap, misread(item.data, item.baud, listen))
        except OSError as e:   # a tap that does not read: drop, never stall the link
            if e.errno not in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EIO):
                raise

    def close(self) -> None:
        self._halt.set()
        self._thread.join(timeout=1.0)
        for p in (self.ctl, self.dev, self.tap_a, self.tap_b):
            p.shut()
