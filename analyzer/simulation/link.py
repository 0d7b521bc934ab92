"""A virtual RS-232 link made of pseudo-terminals: the controller's port, the
gimbals' port, and a tap port per direction (line A controller→device, line B
device→controller), plus optional wire faults per direction.

Pseudo-terminals move bytes instantly; a wire does not. The link paces each
direction at the baud rate: bytes are delivered (to the far end and to the tap)
when their last bit would have arrived, so answers cannot overtake commands.
Taps are written without blocking: a tap that stops reading never stalls the link.
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


class _Pty:
    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
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


def _tap_baud(fd: int) -> int | None:
    """The rate the tap opened its end of a pty at (termios is shared by both ends)."""
    try:
        speed = termios.tcgetattr(fd)[5]
    except termios.error:
        return None
    return _SPEEDS.get(speed)


_SPEEDS = {getattr(termios, f"B{r}"): r for r in (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)}


class VirtualLink:
    def __init__(self, a_faults: WireFaults | None = None, b_faults: WireFaults | None = None,
                 baud: int = 9600, wiring: Wiring | None = None) -> None:
        self.wiring = wiring or Wiring()
        if self.wiring.wire_baud:
            baud = self.wiring.wire_baud
        self.baud = baud
        self.byte_time = 10 / baud
        self.ctl, self.dev, self.tap_a, self.tap_b = _Pty(), _Pty(), _Pty(), _Pty()
        for p in (self.tap_a, self.tap_b):
            fl = fcntl.fcntl(p.master, fcntl.F_GETFL)
            fcntl.fcntl(p.master, fcntl.F_SETFL, fl | os.O_NONBLOCK)
        self.a_faults = a_faults or WireFaults()
        self.b_faults = b_faults or WireFaults()
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

    def _forward(self) -> None:
        routes = {self.ctl.master: (self.dev.master, self.tap_a.master, self.a_faults),
                  self.dev.master: (self.ctl.master, self.tap_b.master, self.b_faults)}
        busy_until = {fd: 0.0 for fd in routes}       # each direction's wire is busy until then
        due: list[tuple[float, int, int, bytes]] = []  # (delivery time, seq, from fd, data)
        seq = 0
        while not self._halt.is_set():
            wait = 0.05 if not due else max(0.0, min(0.05, due[0][0] - time.monotonic()))
            ready, _, _ = select.select(list(routes), [], [], wait)
            now = time.monotonic()
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue
                data = routes[fd][2].apply(data)
                done = max(now, busy_until[fd]) + len(data) * self.byte_time
                busy_until[fd] = done
                seq += 1
                heapq.heappush(due, (done, seq, fd, data))
            while due and due[0][0] <= time.monotonic():
                _, _, fd, data = heapq.heappop(due)
                peer, tap, _faults = routes[fd]
                from_device = fd == self.dev.master
                if from_device and self.wiring.dead_b:
                    continue   # the wire back is cut: neither the controller nor the tap hear it
                try:
                    os.write(peer, data)
                except OSError:
                    continue
                self._to_tap(tap, data)
                if not from_device and self.wiring.echo:
                    self._to_tap(self.tap_b.master, data)   # the device side hears itself

    def _to_tap(self, tap: int, data: bytes) -> None:
        if self.wiring.wire_baud:
            listen = _tap_baud(tap)
            if listen and listen != self.baud:
                from .uart import misread
                data = misread(data, self.baud, listen)
        try:
            os.write(tap, data)
        except OSError as e:   # a tap that does not read: drop, never stall the link
            if e.errno not in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EIO):
                raise

    def close(self) -> None:
        self._halt.set()
        self._thread.join(timeout=1.0)
        for p in (self.ctl, self.dev, self.tap_a, self.tap_b):
            p.shut()
