"""Finding who answers on a port (``gimbalscope probe``, docs/talk.md): a harmless
query (``D?``, which every device must answer: §1.5.3) sent to the wildcard and
then to each address of a range, at each rate of §1.5.1, and what came back.

The plan is a list of conversation steps; what each answer says is read here
from its events (an identification's fields are the table's, as ``decode``
names them). A wildcard's result names its sender: groups swapped, port and
device kept (Table 3), so the answering address is the result frame's own.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from dissectors.encode import encode
from dissectors.event import NO_ACK, OK, ST_NAK, ST_NIC, format_address
from dissectors.wire import WILDCARD

from .conversation import Outcome, Step

QUERY = "D?"    # Request ID information: only asks, and every device must answer it (§1.5.3)
# §1.5.1's rates, the default first, then faster ones (a gimbal left after a rate
# change), then slower
RATES = (9600, 19200, 38400, 57600, 115200, 4800, 2400, 1200)
WILDCARD_ADDRESS = (WILDCARD, WILDCARD, WILDCARD)


@dataclass(frozen=True)
class Target:
    """What a step asks: an address at a rate."""
    address: tuple[int, int, int]
    baud: int


def plan(addresses: list[tuple[int, int, int]], rates: tuple[int, ...], retries: int = 0) -> Iterator[Step]:
    """The wildcard, then each address, at each rate in turn."""
    request = encode(QUERY, {})
    for baud in rates:
        for k, address in enumerate([WILDCARD_ADDRESS, *addresses]):
            yield Step(request.frame(address), retries=retries, baud=baud if k == 0 else None,
                       label=Target(address, baud))


@dataclass
class Found:
    """A device that answered (or something garbled that came back)."""
    address: str
    baud: int
    answer: str                    # result, ack, nak, nic, garbled
    latency_ms: float | None = None
    identity: dict[str, Any] = field(default_factory=dict)
    asked: str = ""                # the address asked: the wildcard, or the device's own

    def json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"address": self.address, "baud": self.baud, "answer": self.answer,
                               "latency_ms": self.latency_ms, "identity": self.identity}
        if self.asked != self.address:
            out["asked"] = self.asked
        return out


def found_in(outcome: Outcome) -> Found | None:
    """What one step found: an answer, something garbled, or None (silence)."""
    target = outcome.step.label
    assert isinstance(target, Target)
    asked = format_address(target.address)
    shake = outcome.handshake
    latency = round(shake.latency * 1000, 1) if shake is not None and shake.latency is not None else None
    result = outcome.result
    if result is not None and outcome.status == OK:
        address = asked
        if result.dst is not None and result.src is not None:   # groups swapped, port and device kept
            address = format_address((result.src, result.dst[1], result.dst[2]))
        return Found(address, target.baud, "result", latency, dict(result.fields), asked)
    answer = {ST_NAK: "nak", ST_NIC: "nic"}.get(outcome.status)
    if answer is None and outcome.status != NO_ACK and shake is not None:
        answer = "ack"     # ACKed, but the result never came (or did not fit)
    if answer is not None:
        return Found(asked, target.baud, answer, latency, {}, asked)
    if outcome.garbled:
        return Found(asked, target.baud, "garbled", None, {}, asked)
    return None


def merged(found: list[Found]) -> list[Found]:
    """One entry per device and rate: its own address's answer over the wildcard's
    (a wildcard answer from a device also found by its address adds nothing)."""
    own = {(f.address, f.baud) for f in found if f.asked == f.address and f.answer != "garbled"}
    out = []
    for f in found:
        if f.asked != f.address and (f.address, f.baud) in own:
            continue
        out.append(f)
    return out
