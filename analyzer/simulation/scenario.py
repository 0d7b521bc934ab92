"""The demo's simulated installation: a controller and three gimbals on virtual
lines, with faults a field engineer meets. ``gimbalscope demo --fault NAME`` and
the doctor's tests build it here.

``build(rate_change=(RATE, SECONDS))`` has the controller switch the link to RATE
that many seconds in (a broadcast rate-set, spec Table 4, that every gimbal
follows; docs/time.md, "Rate changes"); the ``rate-ignored`` fault makes the
gimbals ACK it and keep their rate.
"""

from __future__ import annotations

from dataclasses import dataclass

from dissectors.event import format_address

from .bus import GimbalBus
from .controller import SimController
from .gimbal import Faults, GimbalModel
from .link import VirtualLink, WireFaults, Wiring

DEVICES = [(1, 1, 1), (1, 1, 2), (1, 1, 3)]
SILENT_DEVICE = (1, 1, 3)
WIRE_BAUD = 19200          # the wrong-baud fault: the link runs here, the tap listens at 9600
RATE_CHANGE = (115200, 2.0)   # the rate-ignored fault's change when build() is given none

FAULTS = {
    "swapped": "the tap's two ports are on the other wires (line A carries the answers)",
    "echo": "the device-side adapter echoes: line B repeats line A",
    "silent": f"gimbal {format_address(SILENT_DEVICE)} never answers",
    "dead-line-b": "the device→controller wire is cut: nothing comes back",
    "wrong-baud": f"the link runs at {WIRE_BAUD} baud; the tap listens at --baud (9600)",
    "noisy": "bit errors (1%) and noise bursts on both wires",
    "impatient": "the controller sends the next command without waiting for the ACK",
    "fast-retry": "the controller retries 1 ms after a command, before devices can answer",
    "no-retry": "the controller never retries; gimbals drop 20% of their answers",
    "ix-timeout": "the controller gives up on IX after 0.3 s and sends it again",
    "slowing": "gimbal answers get 3 ms slower every second",
    "rate-ignored": f"the controller switches the link to {RATE_CHANGE[0]} baud after {RATE_CHANGE[1]:g} s; "
                    "the gimbals ACK it, keep their rate and answer nothing after",
}


@dataclass
class Installation:
    link: VirtualLink
    bus: GimbalBus
    controller: SimController

    def start(self) -> None:
        self.bus.start()
        self.controller.start()

    def stop(self) -> None:
        self.controller.stop()
        self.bus.stop()
        self.controller.join(timeout=1.0)
        self.bus.join(timeout=1.0)
        self.link.close()


def build(faults: set[str] | None = None, *, clean: bool = False, seed: int = 5,
          rate_change: tuple[int, float] | None = None) -> Installation:
    """The demo installation. Without ``faults``, the usual few (unless ``clean``);
    with them, a clean installation with just those. ``rate_change`` (rate,
    seconds): the controller switches the link to that rate that many seconds in."""
    faults = set(faults or ())
    unknown = faults - FAULTS.keys()
    if unknown:
        raise ValueError(f"unknown fault {', '.join(sorted(unknown))} (one of: {', '.join(FAULTS)})")
    clean = clean or bool(faults)
    bit = 0.01 if "noisy" in faults else 0.0 if clean else 0.002
    noise = 0.05 if "noisy" in faults else 0.0 if clean else 0.02
    wiring = Wiring(swapped="swapped" in faults, echo="echo" in faults, dead_b="dead-line-b" in faults,
                    wire_baud=WIRE_BAUD if "wrong-baud" in faults else None)
    link = VirtualLink(WireFaults(bit_error=bit, noise=noise if "noisy" in faults else 0.0, seed=seed),
                       WireFaults(bit_error=bit, noise=noise, seed=seed + 1), wiring=wiring)
    drop = 0.2 if "no-retry" in faults else 0.0 if clean else 0.02
    if "rate-ignored" in faults and rate_change is None:
        rate_change = RATE_CHANGE
    gimbals = []
    for k, a in enumerate(DEVICES, 1):
        f = Faults(drop_ack=drop, seed=seed + k, silent="silent" in faults and a == SILENT_DEVICE,
                   drift=0.003 if "slowing" in faults else 0.0, ignore_rate="rate-ignored" in faults)
        gimbals.append(GimbalModel(a, serial=f"SN{k:04d}", init_seconds=1.5, faults=f))
    bus = GimbalBus(link.device_port, gimbals, baud=link.baud)
    controller = SimController(
        link.controller_port, DEVICES, seed=seed, baud=link.baud,
        wait_for_ack="impatient" not in faults,
        retries=0 if "no-retry" in faults else 2,
        ack_timeout=0.001 if "fast-retry" in faults else 0.25,
        retry_pause=0.0 if "fast-retry" in faults else 0.01,
        ix_patience=0.3 if "ix-timeout" in faults else 3.0,
        rate_change=rate_change)
    return Installation(link, bus, controller)
