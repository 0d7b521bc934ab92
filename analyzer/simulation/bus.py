"""Gimbals on one serial port: reads the controller's frames with the project's
deframer, lets each addressed gimbal answer, and writes the replies on time.

The gimbals follow rate changes (spec Table 4; the product's model of them is in
docs/time.md, "Rate changes"): a gimbal ACKs ``C0``…``C7`` at the old rate and,
once the ACK has left, the port is reconfigured to the new one. A broadcast
rate-set is obeyed by every gimbal it addresses and confirmed by one ACK: the
rate belongs to the wire, and whoever follows the change at that ACK would misread
any further one. A gimbal left at another rate than the port's (not addressed, or
one that ACKs and keeps its rate, ``Faults.ignore_rate``) hears only garbage and
answers nothing. ``C8``…``CF`` are reserved: ACK then NIC, and nothing changes.
"""

from __future__ import annotations

import heapq
import threading
import time

import serial

from dissectors import Deframer
from dissectors.event import COMMAND, Event

from .gimbal import GimbalModel
from .uart import misread

# After the ACK of a rate-set has left, the firmware takes this long to reconfigure
# its UART. On a pseudo-terminal flush() does not wait for the far end to read, so
# this is also what keeps the ACK at the old rate until the link has taken it; a
# controller waits longer than this before it talks at the new rate.
RATE_SWITCH_DELAY = 0.03

# A gimbal's rate after a rate-set, per gimbal that answered it.
Switches = list[tuple[GimbalModel, int]]


class GimbalBus(threading.Thread):
    def __init__(self, port: str, gimbals: list[GimbalModel], baud: int = 9600,
                 wrong_baud: int | None = None) -> None:
        self.wrong_baud = wrong_baud   # fault: answer at this rate instead
        super().__init__(daemon=True, name="gimbal-bus")
        self.port = serial.serial_for_url(port, baudrate=baud, timeout=0.005)
        self.gimbals = gimbals
        for g in gimbals:
            g.baud = baud              # installed on this port: they listen at its rate
        self._halt = threading.Event()
        self.commands = 0

    @property
    def baud(self) -> int:
        """The port's rate now (it follows obeyed rate-set commands)."""
        return self.port.baudrate

    def stop(self) -> None:
        self._halt.set()

    def run(self) -> None:
        # timed, so a silence settles a broken frame at once (then it is NAKed)
        deframer = Deframer("A", byte_time=10 / self.baud, frame_gap=0.02)
        pending: list[tuple[float, int, bytes, Switches]] = []
        seq = 0
        start = time.monotonic()
        while not self._halt.is_set():
            try:
                data = self.port.read(self.port.in_waiting or 1)
            except (serial.SerialException, OSError):
                return
            now = time.monotonic()
            if data:
                events = deframer.feed(data, now - start - len(data) * 10 / self.baud)
            else:
                events = deframer.idle(now - start)
            for ev in events:
                if ev.kind != COMMAND:
                    continue
                self.commands += 1
                for at, out, switches in self._answers(ev, now - start):
                    seq += 1
                    heapq.heappush(pending, (start + at, seq, out, switches))
            try:
                written, switches = self._write_due(pending)
                if switches:
                    self._switch(switches, written, deframer)
            except (serial.SerialException, OSError):
                return
        self.port.close()

    def _answers(self, ev: Event, now: float) -> list[tuple[float, bytes, Switches]]:
        """What the gimbals that hear ``ev`` send back: (when, bytes, rate switches)."""
        out: list[tuple[float, bytes, Switches]] = []
        rate_ack: tuple[float, bytes, Switches] | None = None
        for g in self.gimbals:
            if g.baud != self.baud or not g.addressed(ev):
                continue   # a gimbal at another rate than the line's hears garbage, not this frame
            for reply in g.handle(ev, now):
                if reply.baud is None:
                    out.append((reply.at, reply.data, []))
                elif rate_ack is None:
                    rate_ack = (reply.at, reply.data, [(g, reply.baud)])
                    out.append(rate_ack)
                else:
                    rate_ack[2].append((g, reply.baud))   # one ACK confirms a broadcast rate-set
        return out

    def _write_due(self, pending: list[tuple[float, int, bytes, Switches]]) -> tuple[int, Switches]:
        """Write the replies that are due; (bytes written, rate switches they carry)."""
        written = 0
        switches: Switches = []
        while pending and pending[0][0] <= time.monotonic():
            _, _, out, then = heapq.heappop(pending)
            if self.wrong_baud:
                out = misread(out, self.wrong_baud, self.baud)
            self.port.write(out)
            written += len(out)
            switches += then
        return written, switches

    def _switch(self, switches: Switches, written: int, deframer: Deframer) -> None:
        """After the ACK of a rate-set: the gimbals that obeyed take the new rate,
        and so does the port once the ACK has left at the old one."""
        old = self.baud
        new = next((baud for _g, baud in switches if baud != old), old)
        if new != old:
            self.port.flush()
            time.sleep(written * 10 / old + RATE_SWITCH_DELAY)
            self.port.baudrate = new
            deframer.set_byte_time(10 / new)
        for g, baud in switches:
            g.baud = baud
