"""The simulator follows rate changes (spec Table 4) on real ptys: the controller
sets the rate with C0..C7, the gimbals ACK at the old rate and switch, and a tap
that switches at that ACK reads everything after it, one that does not reads
garbage. Frames are built here by the checksum rule (sum of G..payload mod 256);
nothing is mocked: the link, the gimbals and the controller talk through pyserial."""

import contextlib
import select
import threading

import serial

from analyzer.simulation.bus import GimbalBus
from analyzer.simulation.controller import SimController
from analyzer.simulation.gimbal import Faults, GimbalModel
from analyzer.simulation.link import VirtualLink
from dissectors import Deframer
from dissectors.event import ACK, COMMAND, NIC, RESULT
from tests.child import PATIENCE, wait_for
from tests.conftest import frame

ACK_B = (ACK, b"\x06")
NIC_B = (NIC, b"?")
# C7 to 1.1.1 from group 0: F8, G P D S L = 01 01 01 00 02, "C7" = 43 37,
# checksum 01+01+01+00+02+43+37 = 7F
C7_TO_1_1_1 = bytes.fromhex("f8 01 01 01 00 02 43 37 7f")


class TapReader(threading.Thread):
    """A tap with an adapter per line, listening at 9600. With ``follow`` it sets
    both ports to 115200 right after the ACK that answers a C7 it saw on line A,
    as a tap that follows rate changes does; without, it only marks that ACK."""

    def __init__(self, ports: tuple[str, str], follow: bool) -> None:
        super().__init__(daemon=True, name="test-tap")
        self.ports = {line: serial.Serial(path, 9600, timeout=0) for line, path in zip("AB", ports)}
        self.deframers = {line: Deframer(line) for line in "AB"}
        self.events: dict[str, list[tuple[str, bytes]]] = {"A": [], "B": []}
        self.raw = {"A": bytearray(), "B": bytearray()}
        self.follow = follow
        self.mark: dict[str, tuple[int, int]] | None = None   # per line: (events, bytes) before the change
        self._c7_seen = False
        self._halt = threading.Event()

    def run(self) -> None:
        fds = {p.fileno(): line for line, p in self.ports.items()}
        while not self._halt.is_set():
            ready, _, _ = select.select(list(fds), [], [], 0.02)
            for line in sorted(fds[fd] for fd in ready):   # line A first: the C7 before its ACK
                self._take(line)

    def _take(self, line: str) -> None:
        port = self.ports[line]
        data = port.read(port.in_waiting or 1)
        if data:
            self.raw[line] += data
            self._decoded(line, self.deframers[line].feed(data))

    def _decoded(self, line: str, events) -> None:
        for ev in events:
            self.events[line].append((ev.kind, bytes(ev.raw)))
            if line == "A" and ev.kind == COMMAND and ev.payload == b"C7":
                self._c7_seen = True
            elif line == "B" and ev.kind == ACK and self._c7_seen and self.mark is None:
                self.mark = {k: (len(self.events[k]), len(self.raw[k])) for k in "AB"}
                if self.follow:
                    for p in self.ports.values():
                        p.baudrate = 115200

    def stop(self) -> None:
        """Stop, and read what is left."""
        self._halt.set()
        self.join(timeout=5)
        for line in "AB":
            self._take(line)
            self._decoded(line, self.deframers[line].finish())
        for p in self.ports.values():
            p.close()

    def before(self, line: str) -> list[tuple[str, bytes]]:
        return self.events[line][: self.mark[line][0]]

    def after(self, line: str) -> list[tuple[str, bytes]]:
        return self.events[line][self.mark[line][0]:]

    def raw_after(self, line: str) -> bytes:
        return bytes(self.raw[line][self.mark[line][1]:])


@contextlib.contextmanager
def installation(gimbals: list[GimbalModel], follow: bool = True):
    """Link, tap, gimbals and a controller at 9600; the test drives the controller."""
    link = VirtualLink(baud=9600)
    tap = TapReader(link.tap_ports, follow)
    bus = GimbalBus(link.device_port, gimbals, baud=9600)
    ctl = SimController(link.controller_port, [g.address for g in gimbals], baud=9600, ack_timeout=5.0)
    tap.start()
    bus.start()
    try:
        yield bus, ctl, tap
    finally:
        bus.stop()
        bus.join(timeout=5)
        ctl.port.close()
        if tap.is_alive():
            tap.stop()
        link.close()


def cmd(payload: str, dst=(1, 1, 1)) -> tuple[str, bytes]:
    return COMMAND, frame(dst, 0, payload)


def result(payload: str, device: int = 1) -> tuple[str, bytes]:
    # Table 3: back to group 0, port and device kept, source is the gimbal's group 1
    return RESULT, frame((0, 1, device), 1, payload)


def send_all(ctl: SimController, payloads, dst=(1, 1, 1)) -> list[str]:
    return [ctl.send(dst, p, result_timeout=PATIENCE) for p in payloads]


def switch_to_115200(ctl: SimController, bus: GimbalBus, tap: TapReader, dst=(1, 1, 1)) -> None:
    assert ctl.set_rate(dst, 115200) == "ok"
    assert ctl.baud == 115200
    wait_for(lambda: bus.baud == 115200, "the gimbals' port to switch")
    wait_for(lambda: tap.mark is not None, "the tap to see the ACK of C7")


BEFORE = ("P?", "RP03E8", "AW")
AFTER = ("P?", "RP07D0", "R?", "AW")
# what the gimbal at 1.1.1 answers to AFTER: position 0, pan rate 20.00 deg/s
# (0x07D0 = 2000 hundredths) and tilt still 10.00 (0x03E8), all fine (AW 0)
AFTER_ANSWERS = [ACK_B, result("00000000"), ACK_B, ACK_B, result("07D003E8"), ACK_B, result("0")]


def test_a_tap_that_follows_the_change_decodes_everything_after_it():
    with installation([GimbalModel((1, 1, 1))], follow=True) as (bus, ctl, tap):
        assert send_all(ctl, BEFORE) == ["ok"] * 3
        switch_to_115200(ctl, bus, tap)
        assert send_all(ctl, AFTER) == ["ok"] * 4
        wait_for(lambda: len(tap.after("A")) >= 4 and len(tap.after("B")) >= 7, "the tap to read the answers")
        tap.stop()
    assert frame((1, 1, 1), 0, "C7") == C7_TO_1_1_1
    assert tap.before("A") == [cmd("P?"), cmd("RP03E8"), cmd("AW"), (COMMAND, C7_TO_1_1_1)]
    # the ACK of C7 is the last thing at 9600; everything after it is at 115200
    assert tap.before("B") == [ACK_B, result("00000000"), ACK_B, ACK_B, result("0"), ACK_B]
    assert tap.after("A") == [cmd(p) for p in AFTER]
    assert tap.after("B") == AFTER_ANSWERS


def test_a_tap_left_at_the_old_rate_reads_garbage_after_the_change():
    with installation([GimbalModel((1, 1, 1))], follow=False) as (bus, ctl, tap):
        assert send_all(ctl, BEFORE) == ["ok"] * 3
        switch_to_115200(ctl, bus, tap)
        assert send_all(ctl, AFTER) == ["ok"] * 4       # the link works: only the tap is wrong
        wait_for(lambda: tap.raw_after("A") and len(tap.raw_after("B")) > 1, "the tap to read something")
        tap.stop()
    assert tap.before("A")[:3] == [cmd(p) for p in BEFORE]
    sent = [frame((1, 1, 1), 0, p) for p in AFTER]
    assert not any(f in tap.raw_after("A") for f in sent)
    assert not [e for e in tap.after("A") if e[0] == COMMAND]
    assert not [e for e in tap.after("B") if e[0] == RESULT]


def test_a_gimbal_that_ignores_the_change_answers_nothing_after_it():
    gimbal = GimbalModel((1, 1, 1), faults=Faults(ignore_rate=True))
    with installation([gimbal]) as (bus, ctl, _tap):
        assert send_all(ctl, ("P?",)) == ["ok"]
        assert ctl.set_rate((1, 1, 1), 115200) == "ok"      # ACKed ...
        assert ctl.baud == 115200
        ctl.ack_timeout, ctl.retries = 1.0, 1
        commands = bus.commands
        assert send_all(ctl, ("P?", "AW")) == ["gave up"] * 2   # ... but it still listens at 9600
        assert bus.baud == gimbal.baud == 9600
        assert bus.commands == commands                      # what it heard was no frame


def test_a_reserved_rate_code_is_nic_and_changes_nothing():
    with installation([GimbalModel((1, 1, 1))]) as (bus, ctl, tap):
        assert ctl.send((1, 1, 1), "C8") == "nic"
        assert ctl.baud == bus.baud == 9600
        assert send_all(ctl, ("P?",)) == ["ok"]
        wait_for(lambda: len(tap.events["B"]) >= 4, "the tap to read the answers")
        tap.stop()
    assert tap.events["A"] == [cmd("C8"), cmd("P?")]
    assert tap.events["B"] == [ACK_B, NIC_B, ACK_B, result("00000000")]


def test_a_broadcast_change_switches_every_gimbal_with_one_ack():
    gimbals = [GimbalModel((1, 1, d)) for d in (1, 2, 3)]
    with installation(gimbals) as (bus, ctl, tap):
        switch_to_115200(ctl, bus, tap, dst=(255, 255, 255))
        assert [g.baud for g in gimbals] == [115200] * 3
        for d in (1, 2, 3):
            assert ctl.send((1, 1, d), "P?", result_timeout=PATIENCE) == "ok"
        wait_for(lambda: len(tap.after("B")) >= 6, "the tap to read the answers")
        tap.stop()
    assert tap.before("A") == [cmd("C7", dst=(255, 255, 255))]
    assert tap.before("B") == [ACK_B]                       # one ACK confirms the broadcast
    assert tap.after("A") == [cmd("P?", dst=(1, 1, d)) for d in (1, 2, 3)]
    assert tap.after("B") == [ACK_B, result("00000000", 1), ACK_B, result("00000000", 2),
                              ACK_B, result("00000000", 3)]


def test_a_gimbal_the_change_does_not_address_is_left_behind():
    gimbals = [GimbalModel(a) for a in ((1, 1, 1), (1, 1, 2), (1, 2, 1))]
    with installation(gimbals) as (bus, ctl, tap):
        switch_to_115200(ctl, bus, tap, dst=(1, 1, 255))        # port 1's devices only
        assert [g.baud for g in gimbals] == [115200, 115200, 9600]
        assert ctl.send((1, 1, 2), "P?", result_timeout=PATIENCE) == "ok"
        ctl.ack_timeout, ctl.retries = 1.0, 0
        assert ctl.send((1, 2, 1), "P?") == "gave up"         # it hears the line at 9600: garbage
