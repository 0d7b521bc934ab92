"""Live taps: one or two serial ports read through pyserial (device names or
pyserial URLs: ``socket://`` for ser2net and terminal servers, ``rfc2217://``,
``loop://``). A tap only reads; it never writes to the line it watches.

Time (docs/time.md): the host clock at each read; a read of n bytes ended when
its last byte arrived, so its first byte started n byte times earlier (the
deframer spaces the rest by the byte time). Each port is its own clock as far as
timing goes (its adapter's delays), so a two-port tap is a two-clock capture,
whose skew between the lines is estimated. When nothing arrives the source
yields idle ticks (empty chunks), so silences cut frames and timeouts expire
while the line is quiet.

Rate changes (docs/time.md, "Rate changes"): each port follows its line's
``LineSettings`` (given by the capture, ``read_with``). When the controller's
rate-set command is ACKed the capture changes them, and the port listens at the
new rate from then on (pyserial reconfigures an open port in place), as does a
port reopened later; reads are back-dated with the line's byte time of the moment.

A port that vanishes (USB unplugged) is reported, the gap is marked (a warning
and a silence), and the port is reopened when it returns.

Floods: what the readers took and decoding has not yet is bounded (``QUEUE_BYTES``;
a reader waits when it is full). When more than ``BEHIND_BYTES`` wait, decoding has
fallen behind the line: the waiting chunks are handed on marked ``undecoded`` (the
capture records them, tells the deframer of the gap and counts them) until the
backlog is down to ``CAUGHT_UP_BYTES``. After ``stop`` whatever still waits is
decoded when it is that small, and otherwise handed on undecoded, so a tap ends
promptly at any input rate.
"""

from __future__ import annotations

import os
import queue
import threading
import time
from collections.abc import Callable, Iterator
from functools import partial

import serial

from dissectors.wire import LineSettings

from ..errors import CaptureError
from ..lines import LINE_A, LINE_AB, LINE_B, Chunk
from .base import Source

PARITIES = {"N": serial.PARITY_NONE, "E": serial.PARITY_EVEN, "O": serial.PARITY_ODD,
            "M": serial.PARITY_MARK, "S": serial.PARITY_SPACE}
TICK = 0.05          # seconds between idle ticks
READ_WAIT = 0.25     # seconds a port's read waits for a byte before its reader looks for stop (a read
                     # returns at its first byte: this is only how long a quiet port's reader sleeps)
REOPEN_EVERY = 0.5   # seconds between attempts to reopen a vanished port
QUEUE_BYTES = 1 << 20          # read and not yet taken by the capture: the most held
BEHIND_BYTES = 256 << 10       # more waiting than decoding clears in a fraction of a second
CAUGHT_UP_BYTES = 16 << 10     # back to decoding once the backlog is this small
JOIN_SECONDS = 1.0             # a reader ends within one read timeout (READ_WAIT) of stop


class UndecodedChunk(Chunk):
    """Bytes read while decoding was behind the line (``undecoded == "behind"``) or
    still waiting when the tap stopped (``"stopped"``): for the recording only."""
    __slots__ = ()
    undecoded = "behind"


class StoppedChunk(UndecodedChunk):
    __slots__ = ()
    undecoded = "stopped"


_ITEM_COST = 128   # bytes a queued read costs beside its data (tuple, bytes object, time)


def _weight(item: tuple) -> int:
    """What a queued item costs in memory: its data plus the item itself, so that
    many one-byte reads are bounded as surely as a few big ones."""
    data = item[1]
    return _ITEM_COST + (len(data) if isinstance(data, bytes) else 0)


class _ByteQueue(queue.Queue):
    """A queue bounded by the bytes it holds rather than by its items (a read can
    be one byte or thousands)."""

    def _init(self, maxsize: int) -> None:
        super()._init(maxsize)
        self.bytes = 0

    def _qsize(self) -> int:
        return self.bytes

    def _put(self, item: tuple) -> None:
        self.queue.append(item)
        self.bytes += _weight(item)

    def _get(self) -> tuple:
        item = self.queue.popleft()
        self.bytes -= _weight(item)
        return item


def open_port(url: str, baud: int, data_bits: int, parity: str, stop_bits: float) -> serial.Serial:
    """Open a port for reading, or raise CaptureError with one line saying why."""
    is_url = "://" in url
    if not is_url and not os.path.exists(url):
        raise CaptureError(f"{url}: no such serial port")
    try:
        return serial.serial_for_url(url, baudrate=baud, bytesize=data_bits, parity=PARITIES[parity.upper()],
                                     stopbits=stop_bits, timeout=READ_WAIT,
                                     # a device: refuse a port another program holds (None: pyserial's default)
                                     exclusive=None if is_url else True)
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
    input_per_line = True   # one file or port per line (CaptureInfo.line_names)
    live = True
    time_origin = "host clock"

    def __init__(self, ports: list[str], *, baud: int = 9600, data_bits: int = 8, parity: str = "N",
                 stop_bits: float = 1, clock: Callable[[], float] = time.time) -> None:
        super().__init__()
        if len(ports) not in (1, 2):
            raise CaptureError("a tap reads one port (single-line tap) or two (line A, line B)")
        self.ports = list(ports)
        self.lines = (LINE_AB,) if len(ports) == 1 else (LINE_A, LINE_B)
        self.clocks = len(ports)
        self._open: dict[str, serial.Serial] = {}        # each line's port now
        self._watched: list[LineSettings] = []           # the settings whose changes its ports follow
        self.read_with({line: LineSettings(baud, data_bits, parity, stop_bits) for line in self.lines})
        self.description = " + ".join(self.ports)
        self.clock = clock
        self.state: dict[str, str] = {line: "open" for line in self.lines}   # open, lost, reconnecting
        self._queue: queue.Queue = _ByteQueue(QUEUE_BYTES)
        self._leftover: list[tuple] = []   # a reader's last read when stop found the queue full
        self._stop = threading.Event()
        self._serials = [open_port(p, *self._port_settings(line))   # fail early, one line
                         for line, p in zip(self.lines, self.ports)]
        self._open.update(zip(self.lines, self._serials))
        self.start_time: float = clock()
        self._threads = [threading.Thread(target=self._reader, args=(line, port, ser), daemon=True,
                                          name=f"tap-{line}")
                         for line, port, ser in zip(self.lines, self.ports, self._serials)]
        for th in self._threads:
            th.start()

    def read_with(self, settings: dict[str, LineSettings]) -> None:
        """Each port follows its line's settings from now on (module doc)."""
        super().read_with(settings)
        for line in self.lines:
            own = self.settings_of(line)
            if not any(own is seen for seen in self._watched):
                self._watched.append(own)
                own.watch(partial(self._rate_changed, line))

    def _port_settings(self, line: str) -> tuple[int, int, str, float]:
        """What ``open_port`` takes, from the line's settings now."""
        s = self.settings_of(line)
        assert s.baud is not None   # a line's settings have a rate (only a deframer alone has none)
        return s.baud, s.data_bits, s.parity, s.stop_bits

    def _rate_changed(self, line: str, settings: LineSettings) -> None:
        """The line's port listens at the rate of its ``settings`` from now on (the
        link's rate changed). A port that refuses it is said, once, and keeps its old one."""
        ser = self._open.get(line)
        baud = settings.baud
        if ser is None or baud is None:
            return
        try:
            ser.baudrate = baud
        except (serial.SerialException, ValueError, OSError) as e:
            self.warn(f"{self.ports[self.lines.index(line)]}: cannot change to {baud} bps ({e}): "
                      f"it goes on at the old rate")

    def stop(self) -> None:
        """End the capture: chunks() returns once what was read is delivered (a
        bounded amount, so the end is prompt: see ``_rest``)."""
        self._stop.set()

    def close(self) -> None:
        self.stop()
        for th in self._threads:
            th.join(timeout=1.0)

    # -------------------------------------------------------------- readers
    def _put(self, item: tuple) -> None:
        """Queue what a reader read; wait while the queue is full (the port's own
        buffer holds the line meanwhile), and after stop leave it for chunks()."""
        while True:
            try:
                self._queue.put(item, timeout=TICK)
                return
            except queue.Full:
                if self._stop.is_set():
                    self._leftover.append(item)
                    return

    def _reader(self, line: str, port: str, ser: serial.Serial | None) -> None:
        put = self._put
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
                put(("lost", line, self.clock(), (f"{port}: lost ({e}); keeping what was captured, "
                                                  f"reopening when it returns")))
                self.state[line] = "lost"
                try:
                    ser.close()
                except Exception:   # noqa: BLE001, S110 - a lost port may fail to close in any way: it is gone
                    pass
                ser = None
                continue
            if data:
                put((line, data, self.clock()))
        if ser is not None:
            try:
                ser.close()
            except Exception:   # noqa: BLE001, S110 - closing at the end: nothing left to tell
                pass

    def _reopen(self, line: str, port: str) -> serial.Serial | None:
        self.state[line] = "reconnecting"
        if self._stop.wait(REOPEN_EVERY):
            return None
        try:
            ser = open_port(port, *self._port_settings(line))
        except CaptureError:
            return None
        self._open[line] = ser
        self.state[line] = "open"
        self._put(("back", line, self.clock(), f"{port}: back, capturing again"))
        return ser

    # ---------------------------------------------------------------- chunks
    def chunks(self) -> Iterator[Chunk]:
        start = self.start_time
        get = self._queue.get
        behind = False
        while not self._stop.is_set():
            try:
                item = get(timeout=TICK)
            except queue.Empty:
                yield Chunk(self.lines[0], b"", self.clock() - start)   # idle tick
                continue
            if item[0] in ("lost", "back"):
                self.warn(item[3])
                continue
            # decoding is behind when the backlog would take it long to clear; it
            # skips until the backlog is small again (hysteresis: not chunk by chunk)
            waiting = self._queue.qsize()
            behind = waiting > (CAUGHT_UP_BYTES if behind else BEHIND_BYTES)
            yield self._chunk(item, UndecodedChunk if behind else Chunk)
        yield from self._rest()

    def _rest(self) -> Iterator[Chunk]:
        """After stop: what the readers still hold or queued. A small remainder (the
        usual case: the last reads of a quiet line) is decoded as ever, so live
        output still equals decode of the recording; a flood's backlog goes on
        undecoded, so the tap ends promptly at any input rate."""
        for th in self._threads:
            th.join(timeout=JOIN_SECONDS)
        items = []
        while True:
            try:
                items.append(self._queue.get_nowait())
            except queue.Empty:
                break
        leftover, self._leftover = self._leftover, []
        items += leftover
        waiting = sum(_weight(item) for item in items if item[0] not in ("lost", "back"))
        kind = Chunk if waiting <= CAUGHT_UP_BYTES else StoppedChunk
        for item in items:
            if item[0] in ("lost", "back"):
                self.warn(item[3])
            else:
                yield self._chunk(item, kind)

    def _chunk(self, item: tuple, kind: type[Chunk]) -> Chunk:
        line, data, t_read = item
        return kind(line, data, (t_read - self.start_time) - len(data) * self.line_settings[line].byte_time)
