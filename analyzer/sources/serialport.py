"""Live taps: one or two serial ports read through pyserial (device names or
pyserial URLs: ``socket://`` for ser2net and terminal servers, ``rfc2217://``,
``loop://``). A tap only reads; it never writes to the line it watches.

Time: the host clock at each read; a read of n bytes ended when its last byte
arrived, so its first byte started n byte times earlier (the deframer spaces the
rest by the byte time). When nothing arrives the source yields idle ticks (empty
chunks), so silences cut frames and timeouts expire while the line is quiet.

A port that vanishes (USB unplugged) is reported, the gap is marked (a warning
and a silence), and the port is reopened when it returns.
"""

from __future__ import annotations

import os
import queue
import threading
import time
from typing import Callable, Iterator

import serial

from .base import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Source

PARITIES = {"N": serial.PARITY_NONE, "E": serial.PARITY_EVEN, "O": serial.PARITY_ODD,
            "M": serial.PARITY_MARK, "S": serial.PARITY_SPACE}
TICK = 0.05          # seconds between idle ticks
REOPEN_EVERY = 0.5   # seconds between attempts to reopen a vanished port


def _open(url: str, baud: int, data_bits: int, parity: str, stop_bits: float) -> serial.SerialBase:
    """Open a port for reading, or raise CaptureError with one line saying why."""
    is_url = "://" in url
    if not is_url and not os.path.exists(url):
        raise CaptureError(f"{url}: no such serial port")
    try:
        kw = dict(baudrate=baud, bytesize=data_bits, parity=PARITIES[parity.upper()], stopbits=stop_bits,
                  timeout=TICK)
        if not is_url:
            kw["exclusive"] = True   # refuse a port another program holds
        return serial.serial_for_url(url, **kw)
    except serial.SerialException as e:
        text = str(e)
        if "lock" in text.lower() or "busy" in text.lower() or "Errno 16" in text:
            raise CaptureError(f"{url}: busy (another program holds the port)") from None
        if "Inappropriate ioctl" in text or "Errno 25" in text:
            raise CaptureError(f"{url}: not a serial port") from None
        raise CaptureError(f"{url}: cannot open: {text}") from None
    except (ValueError, OSError) as e:
        raise CaptureError(f"{url}: cannot open: {e}") from None


class SerialTap(Source):
    timed = True
    live = True

    def __init__(self, ports: list[str], *, baud: int = 9600, data_bits: int = 8, parity: str = "N",
                 stop_bits: float = 1, clock: Callable[[], float] = time.time) -> None:
        super().__init__()
        if len(ports) not in (1, 2):
            raise CaptureError("a tap reads one port (single-line tap) or two (line A, line B)")
        self.ports = list(ports)
        self.lines = (LINE_AB,) if len(ports) == 1 else (LINE_A, LINE_B)
        self.settings = (baud, data_bits, parity, stop_bits)
        self.description = " + ".join(self.ports)
        self.clock = clock
        self.state = {line: "open" for line in self.lines}   # open, lost, reconnecting
        self._queue: queue.Queue = queue.Queue()
        self._stop = threading.Event()
        self._serials = [_open(p, *self.settings) for p in self.ports]   # fail early, one line
        self.start_time = clock()
        self._threads = [threading.Thread(target=self._reader, args=(line, port, ser), daemon=True,
                                          name=f"tap-{line}")
                         for line, port, ser in zip(self.lines, self.ports, self._serials)]
        for th in self._threads:
            th.start()

    def stop(self) -> None:
        """End the capture: chunks() returns once what was read is delivered."""
        self._stop.set()

    def close(self) -> None:
        self.stop()
        for th in self._threads:
            th.join(timeout=1.0)

    # -------------------------------------------------------------- readers
    def _reader(self, line: str, port: str, ser: serial.SerialBase | None) -> None:
        put = self._queue.put
        while not self._stop.is_set():
            if ser is None:
                ser = self._reopen(line, port)
                continue
            try:
                data = ser.read(ser.in_waiting or 1)
                # a blocking read returns the first byte alone: take what came with it
                if data and ser.in_waiting:
                    data += ser.read(ser.in_waiting)
            except (serial.SerialException, OSError, TypeError) as e:
                put(("lost", line, self.clock(), f"{port}: lost ({e}); keeping what was captured, "
                                                 f"reopening when it returns"))
                self.state[line] = "lost"
                try:
                    ser.close()
                except Exception:
                    pass
                ser = None
                continue
            if data:
                put((line, data, self.clock()))
        if ser is not None:
            try:
                ser.close()
            except Exception:
                pass

    def _reopen(self, line: str, port: str) -> serial.SerialBase | None:
        self.state[line] = "reconnecting"
        if self._stop.wait(REOPEN_EVERY):
            return None
        try:
            ser = _open(port, *self.settings)
        except CaptureError:
            return None
        self.state[line] = "open"
        self._queue.put(("back", line, self.clock(), f"{port}: back, capturing again"))
        return ser

    # ---------------------------------------------------------------- chunks
    def chunks(self) -> Iterator[Chunk]:
        bt = self.byte_time
        start = self.start_time
        get = self._queue.get
        while True:
            try:
                item = get(timeout=TICK)
            except queue.Empty:
                if self._stop.is_set():
                    return
                yield Chunk(self.lines[0], b"", self.clock() - start)   # idle tick
                continue
            if item[0] in ("lost", "back"):
                self.warn(item[3])
                continue
            line, data, t_read = item
            yield Chunk(line, data, (t_read - start) - len(data) * bt)

    byte_time: float = 10 / 9600   # set by the capture from its options
