"""Gimbals on one serial port: reads the controller's frames with the project's
deframer, lets each addressed gimbal answer, and writes the replies on time."""

from __future__ import annotations

import heapq
import threading
import time

import serial

from dissectors import Deframer
from dissectors.event import COMMAND

from .gimbal import GimbalModel


class GimbalBus(threading.Thread):
    def __init__(self, port: str, gimbals: list[GimbalModel], baud: int = 9600,
                 wrong_baud: int | None = None) -> None:
        self.wrong_baud = wrong_baud   # fault: answer at this rate instead
        super().__init__(daemon=True, name="gimbal-bus")
        self.port = serial.serial_for_url(port, baudrate=baud, timeout=0.005)
        self.gimbals = gimbals
        self._halt = threading.Event()
        self.commands = 0

    def stop(self) -> None:
        self._halt.set()

    def run(self) -> None:
        # timed, so a silence settles a broken frame at once (then it is NAKed)
        bt = 10 / self.port.baudrate
        deframer = Deframer("A", byte_time=bt, frame_gap=0.02)
        pending: list[tuple[float, int, bytes]] = []
        seq = 0
        start = time.monotonic()
        while not self._halt.is_set():
            try:
                data = self.port.read(self.port.in_waiting or 1)
            except (serial.SerialException, OSError):
                return
            now = time.monotonic()
            if data:
                events = deframer.feed(data, now - start - len(data) * bt)
            else:
                events = deframer.idle(now - start)
            for ev in events:
                if ev.kind != COMMAND:
                    continue
                self.commands += 1
                for g in self.gimbals:
                    if g.addressed(ev):
                        for reply in g.handle(ev, now - start):
                            seq += 1
                            heapq.heappush(pending, (start + reply.at, seq, reply.data))
            while pending and pending[0][0] <= time.monotonic():
                _, _, out = heapq.heappop(pending)
                if self.wrong_baud:
                    from .uart import misread
                    out = misread(out, self.wrong_baud, self.port.baudrate)
                try:
                    self.port.write(out)
                except (serial.SerialException, OSError):
                    return
        self.port.close()
