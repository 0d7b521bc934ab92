"""A serial port we talk on: what we write is line A, what comes back line B, both
timed by the host clock, so the tap's own capture, pairing, printers and recorder
read a conversation we take part in as they read one we overhear
(docs/talk.md).

This is the only source that writes to a port, and only when told to
(``write``); the taps (analyzer/sources/serialport.py) never do.

Time (docs/time.md): a write's first byte starts when the write is made; a read
of n bytes ended when its last byte arrived, so it started n byte times earlier,
as a tap's reads, but not before the last byte we wrote ended: a gimbal answers
a frame once it has all of it, and a port that delivers faster than the wire
(a pseudo-terminal, an adapter's buffering) must not put the answer inside its
command. One clock times both lines. When nothing arrives the source
yields idle ticks, so pairing's timeouts expire while the gimbal is silent.

Rate: the port follows the lines' settings, so a rate-set command that the gimbal
ACKs switches our side too, as the gimbal switches its own (docs/time.md,
"Rate changes"); ``set_rate`` switches it without a command (``probe``).
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable, Iterator

import serial

from dissectors.wire import LineSettings

from ..errors import CaptureError
from ..lines import LINE_A, LINE_B, Chunk
from ..sources import Source
from ..sources.serialport import READ_WAIT, TICK, open_port


class TalkLink(Source):
    """One port, both directions: line A what we wrote, line B what we read."""
    timed = True
    live = True
    clocks = 1
    time_origin = "host clock"

    def __init__(self, port: str, *, baud: int = 9600, data_bits: int = 8, parity: str = "N",
                 stop_bits: float = 1, clock: Callable[[], float] = time.time) -> None:
        super().__init__()
        self.port = port
        self.lines = (LINE_A, LINE_B)
        self.description = f"{port} (talking: A sent, B received)"
        self.clock = clock
        self.state: dict[str, str] = {LINE_A: "open", LINE_B: "open"}
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._stop = threading.Event()
        self._write_lock = threading.Lock()
        self._watched: list[LineSettings] = []
        self._sent_until = 0.0    # when the last byte written ends on the wire (capture time)
        self.read_with({line: LineSettings(baud, data_bits, parity, stop_bits) for line in self.lines})
        self._serial = open_port(port, baud, data_bits, parity, stop_bits)
        self.start_time: float = clock()
        self._reader = threading.Thread(target=self._read, daemon=True, name="talk-B")
        self._reader.start()

    # ------------------------------------------------------------ settings
    def read_with(self, settings: dict[str, LineSettings]) -> None:
        """The port follows line B's settings (what the gimbal speaks) from now on."""
        super().read_with(settings)
        own = self.settings_of(LINE_B)
        if not any(own is seen for seen in self._watched):
            self._watched.append(own)
            own.watch(self._rate_changed)

    def _rate_changed(self, settings: LineSettings) -> None:
        if settings.baud is not None:
            self._set_port_rate(settings.baud)

    def set_rate(self, baud: int) -> None:
        """Both lines at ``baud`` from now on, the port too (it follows line B's
        settings: ``read_with``); no command sent."""
        for line in self.lines:
            self.settings_of(line).set_rate(baud)

    def _set_port_rate(self, baud: int) -> None:
        try:
            self._serial.baudrate = baud
        except (serial.SerialException, ValueError, OSError) as e:
            raise CaptureError(f"{self.port}: cannot change to {baud} bps ({e})") from None

    # ------------------------------------------------------------ writing
    def write(self, data: bytes) -> None:
        """Send ``data``; it is line A's next chunk, timed from the write's start."""
        with self._write_lock:
            # queued before it is written: an answer read at once (a pseudo-terminal
            # answers within the write) must come after it
            self._queue.put((LINE_A, data, self.clock(), False))
            try:
                self._serial.write(data)
                self._serial.flush()
            except (serial.SerialException, OSError) as e:
                raise CaptureError(f"{self.port}: cannot write ({e})") from None

    # ------------------------------------------------------------ reading
    def _read(self) -> None:
        ser = self._serial
        while not self._stop.is_set():
            try:
                data = ser.read(ser.in_waiting or 1)
                if data and ser.in_waiting:
                    data += ser.read(ser.in_waiting)
            except (serial.SerialException, OSError, TypeError) as e:
                self.state[LINE_B] = "lost"
                self._queue.put(("lost", f"{self.port}: lost ({e})", self.clock(), True))
                return
            if data:
                self._queue.put((LINE_B, data, self.clock(), True))

    def chunks(self) -> Iterator[Chunk]:
        get = self._queue.get
        while not self._stop.is_set():
            try:
                item = get(timeout=TICK)
            except queue.Empty:
                yield Chunk(LINE_A, b"", self.clock() - self.start_time)   # idle tick
                continue
            yield from self._chunk(item)
        self._reader.join(timeout=READ_WAIT * 4)
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                return
            yield from self._chunk(item)

    def _chunk(self, item: tuple) -> Iterator[Chunk]:
        line, data, t, read = item
        if line == "lost":
            self.warn(data)
            self._stop.set()
            return
        t -= self.start_time
        byte_time = self.settings_of(line).byte_time
        if read:   # a read ends with its last byte: its first started that many byte times earlier
            t = max(t - len(data) * byte_time, self._sent_until)
        else:
            self._sent_until = t + len(data) * byte_time
        yield Chunk(line, data, t)

    def stop(self) -> None:
        self._stop.set()

    def close(self) -> None:
        self.stop()
        self._reader.join(timeout=READ_WAIT * 4)
        try:
            self._serial.close()
        except (serial.SerialException, OSError):
            pass
        super().close()
