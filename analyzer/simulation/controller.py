"""A simulated controller that drives gimbals the way real ones do: it waits for
the ACK or NAK before the next command, retransmits on a NAK or a timeout, waits
for due results, polls positions, sweeps between go-to targets and queries
status (spec §1.4.2-1.4.3).

It follows rate changes (spec Table 4): once a ``C0``…``C7`` it sent is ACKed (and
no NIC takes it back), its port runs at the new rate, and it gives the gimbals
time to switch before it talks again (the product's model of rate changes:
docs/time.md, "Rate changes"). ``rate_change`` switches the link in the middle of
a script: a broadcast rate-set once that many seconds have passed."""

from __future__ import annotations

import random
import threading
import time
from collections.abc import Iterable, Iterator

import serial

from dissectors import Deframer, dissect_command
from dissectors.commands import BAUD_CODES, DUE
from dissectors.event import ACK, NAK, NIC, NO_RESULT, OK, RESULT, ST_NIC, Event
from dissectors.wire import WILDCARD, build_frame

RATE_CODES = {baud: code for code, baud in BAUD_CODES.items()}   # Table 4: 9600 -> C3
BROADCAST = (WILDCARD, WILDCARD, WILDCARD)
# After switching its own port, the controller waits this long before talking at
# the new rate: longer than a gimbal takes to switch (bus.RATE_SWITCH_DELAY).
RATE_SETTLE = 0.15

Step = tuple[tuple[int, int, int], str, float]   # a script's step: (device, payload, result timeout)


def rate_set_payload(baud: int) -> str:
    """The rate-set command for ``baud`` (``C0``…``C7``, Table 4)."""
    if baud not in RATE_CODES:
        raise ValueError(f"{baud} bit/s is not a rate of Table 4 (one of: {', '.join(map(str, RATE_CODES))})")
    return f"C{RATE_CODES[baud]}"


class SimController(threading.Thread):
    def __init__(self, port: str, devices: list[tuple[int, int, int]], *, group: int = 0, seed: int = 3,
                 ack_timeout: float = 0.25, retries: int = 2, baud: int = 9600, script: list[Step] | None = None,
                 wait_for_ack: bool = True, ix_patience: float = 3.0, retry_pause: float = 0.01,
                 rate_change: tuple[int, float] | None = None) -> None:
        super().__init__(daemon=True, name="sim-controller")
        self.port = serial.serial_for_url(port, baudrate=baud, timeout=0.005)
        self.devices = devices
        self.group = group
        self.rng = random.Random(seed)
        self.ack_timeout = ack_timeout
        self.retries = retries
        self.script = script
        self.wait_for_ack = wait_for_ack    # fault when False: the next command goes out at once
        self.ix_patience = ix_patience      # seconds it waits for IX's result before sending IX again
        self.retry_pause = retry_pause      # seconds between a timeout or NAK and the retransmission
        if rate_change is not None:
            rate_set_payload(rate_change[0])   # a rate Table 4 has, or say so now
        self.rate_change = rate_change      # (rate, seconds): switch the link to it that long into the script
        self._halt = threading.Event()
        # timed, so a silence settles a broken frame at once instead of holding
        # back the answers after it
        self._bt = 10 / baud
        self._deframer = Deframer("B", byte_time=self._bt, frame_gap=0.02)
        self._t0 = time.monotonic()
        self._inbox: list = []
        self.sent = 0

    @property
    def baud(self) -> int:
        """The port's rate now (it follows ACKed rate-set commands)."""
        return self.port.baudrate

    def stop(self) -> None:
        self._halt.set()

    # ------------------------------------------------------------------ I/O
    def _read(self, until: float) -> None:
        while time.monotonic() < until and not self._halt.is_set():
            data = self.port.read(self.port.in_waiting or 1)
            now = time.monotonic() - self._t0
            if data:
                self._inbox += self._deframer.feed(data, now - len(data) * self._bt)
                return
            self._inbox += self._deframer.idle(now)

    def _next(self, until: float, kinds: tuple[str, ...]) -> Event | None:
        """The next answer of one of ``kinds``, or None by ``until``; events before
        it are consumed, events after it are kept."""
        seen = 0
        while not self._halt.is_set():
            for k in range(seen, len(self._inbox)):
                if self._inbox[k].kind in kinds:
                    ev = self._inbox[k]
                    del self._inbox[: k + 1]
                    return ev
            seen = len(self._inbox)
            if time.monotonic() >= until:
                return None
            self._read(until)
        return None

    def _peek_nic(self, until: float) -> bool:
        """Is the answer right after the ACK a NIC?"""
        while not self._inbox and time.monotonic() < until and not self._halt.is_set():
            self._read(until)
        if self._inbox and self._inbox[0].kind == NIC:
            del self._inbox[0]
            return True
        return False

    def send(self, dst: tuple[int, int, int], payload: str, result_timeout: float = 1.0) -> str:
        """Send one command like a controller does; returns what happened."""
        frame = build_frame(dst, self.group, payload)
        decoded = dissect_command(payload.encode())
        entry = decoded.entry
        new_rate = decoded.fields.get("baud") if decoded.command == "C" else None
        for _attempt in range(self.retries + 1):
            self._inbox.clear()
            self.port.write(frame)
            self.sent += 1
            if not self.wait_for_ack:
                time.sleep(len(frame) * self._bt + 0.001)   # on the wire, then straight on
                if new_rate:
                    self._switch(new_rate)   # it does not wait for the ACK for this one either
                return "sent"
            ans = self._next(time.monotonic() + self.ack_timeout + len(frame) * self._bt, (ACK, NAK))
            if ans is None or ans.kind == NAK:
                time.sleep(self.retry_pause)
                continue   # retransmit after a timeout or a NAK
            if self._peek_nic(time.monotonic() + 0.02):
                return ST_NIC   # a NIC takes back the rate change the ACK started
            if new_rate:
                self._switch(new_rate)
            if entry is not None and entry.result_due == DUE:
                res = self._next(time.monotonic() + result_timeout, (RESULT,))
                return OK if res is not None else NO_RESULT
            return OK
        return "gave up"

    def set_rate(self, dst: tuple[int, int, int], baud: int) -> str:
        """Set the link's rate (``C0``…``C7``, Table 4); once the ACK comes, this
        port runs at ``baud``. Returns what happened, as ``send`` does."""
        return self.send(dst, rate_set_payload(baud))

    def _switch(self, baud: int) -> None:
        """The rate-set was ACKed at the old rate: from now on this port runs at
        ``baud``; the gimbals switch once the ACK has left, so give them time."""
        self.port.baudrate = baud
        self._bt = 10 / baud
        self._deframer.set_byte_time(self._bt)
        time.sleep(RATE_SETTLE)

    # --------------------------------------------------------------- script
    def default_script(self) -> Iterator[Step]:
        """An endless mix: poll, sweep, set rates, query, and now and then a
        command the gimbal does not implement; one IX (initialisation) early on."""
        targets = [(40.0, -10.0), (-40.0, 10.0), (0.0, 0.0)]
        k = 0
        while True:
            for dev in self.devices:
                yield (dev, "P?", 1.0)
                if k % 3 == 0:
                    az, el = targets[(k // 3) % len(targets)]
                    yield (dev, "P" + f"{int(az * 100) & 0xFFFF:04X}{int(el * 100) & 0xFFFF:04X}", 1.0)
                if k % 5 == 1:
                    yield (dev, self.rng.choice(["AW", "V?", "G?", "R?", "LR", "I?"]), 1.0)
                if k % 7 == 2:
                    yield (dev, f"RP{self.rng.randint(500, 2000):04X}", 1.0)
                if k % 11 == 5:
                    yield (dev, "FA", 1.0)   # auto-focus: not implemented -> NIC
            if k % 13 == 3:
                yield (self.devices[0], "D?", 1.0)
            if k == 4:
                yield (self.devices[-1], "IX", self.ix_patience)
                if self.ix_patience < 1.0:   # an impatient controller tries again
                    yield (self.devices[-1], "IX", self.ix_patience)
            k += 1

    def _with_rate_change(self, steps: Iterable[Step], rate_change: tuple[int, float]) -> Iterator[Step]:
        """``steps``, with a broadcast rate-set to ``rate_change``'s rate once its
        seconds have passed (every gimbal on the link must follow it)."""
        baud, after = rate_change
        due: float | None = time.monotonic() + after
        for step in steps:
            if due is not None and time.monotonic() >= due:
                due = None
                yield (BROADCAST, rate_set_payload(baud), 1.0)
            yield step

    def run(self) -> None:
        steps = iter(self.script) if self.script is not None else self.default_script()
        if self.rate_change is not None:
            steps = self._with_rate_change(steps, self.rate_change)
        try:
            for dev, payload, result_timeout in steps:
                if self._halt.is_set():
                    break
                self.send(dev, payload, result_timeout)
                time.sleep(self.rng.uniform(0.01, 0.03))   # think time
        except (serial.SerialException, OSError):
            pass
        finally:
            self.port.close()
