"""Synthetic bus traffic: a scripted controller and gimbals talking at a baud rate,
with faults, written as raw dumps or as a socat-style log. Used for the sample
captures and the benchmarks; tests take their expectations from the spec, not
from here.

The controller behaves like a real one: it waits for the ACK/NAK, retransmits on
a NAK or a timeout, waits for results, polls positions. Devices answer after a
few milliseconds; faults corrupt bytes, drop ACKs and inject noise.
"""

from __future__ import annotations

import random
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from dissectors.wire import ACK, NAK, NIC, build_frame, byte_time


@dataclass
class Write:
    line: str        # "A" or "B"
    data: bytes
    t: float         # wire time the first byte starts


@dataclass
class Traffic:
    baud: int = 9600
    writes: list[Write] = field(default_factory=list)

    @property
    def bt(self) -> float:
        return byte_time(self.baud)

    def line_bytes(self, line: str) -> bytes:
        return b"".join(w.data for w in self.writes if w.line == line)

    def single_line(self) -> bytes:
        return b"".join(w.data for w in sorted(self.writes, key=lambda w: w.t))

    def socat_log(self, start_epoch: float = 1_795_000_000.0, nanoseconds: bool = False) -> str:
        """A log as ``socat -x -v`` (Debian 1.7.4) writes it: timestamp when the last
        byte arrived, 9-digit fraction holding microseconds."""
        out = []
        offsets = {"A": 0, "B": 0}
        for w in sorted(self.writes, key=lambda w: w.t + len(w.data) * self.bt):
            t_last = start_epoch + w.t + len(w.data) * self.bt
            sec = int(t_last)
            usec = round((t_last - sec) * 1e6)
            if usec == 1_000_000:
                sec, usec = sec + 1, 0
            stamp = time.strftime("%Y/%m/%d %H:%M:%S", time.localtime(sec))
            frac = f"{usec * 1000:09d}" if nanoseconds else f"{usec:09d}"
            arrow = ">" if w.line == "A" else "<"
            frm = offsets[w.line]
            offsets[w.line] += len(w.data)
            out.append(f"{arrow} {stamp}.{frac}  length={len(w.data)} from={frm} to={offsets[w.line] - 1}\n")
            for k in range(0, len(w.data), 16):
                part = w.data[k:k + 16]
                hexes = " " + " ".join(f"{b:02x}" for b in part)
                text = "".join(chr(b) if 0x20 <= b < 0x7F else "." for b in part)
                out.append(f"{hexes:<49} {text}\n")
            out.append("--\n")
        return "".join(out)


POLL_MIX = [
    ("P?", 30), ("GOTO", 15), ("RP", 4), ("RT", 4), ("AP", 2), ("GRP", 2), ("V?", 4), ("VGOTO", 3),
    ("AW", 4), ("G?", 2), ("D?", 2), ("HO", 2), ("PL", 2), ("PS", 2), ("R?", 2), ("I?", 2),
    ("E?", 2), ("LR", 1), ("L?", 1), ("SP", 1), ("Pnn", 2), ("P?nn", 2), ("UNKNOWN", 1), ("LA", 1),
]


def _payload_for(kind: str, rng: random.Random) -> tuple[str, str | None]:
    """(command payload, result payload or None)"""
    def h4(v: int) -> str:
        return f"{v & 0xFFFF:04X}"
    az, el = rng.randint(-18000, 18000), rng.randint(-9000, 9000)
    if kind == "P?":
        return "P?", h4(az) + h4(el)
    if kind == "GOTO":
        return "P" + h4(az) + h4(el), None
    if kind in ("RP", "RT", "AP"):
        return kind + h4(rng.randint(100, 9000)), None
    if kind == "GRP":
        return f"GRP{rng.randint(3, 30):02X}", None
    if kind == "V?":
        return "V?", f"{rng.randint(0, 4095):03X}{rng.randint(0, 4095):03X}"
    if kind == "VGOTO":
        return f"V{rng.randint(0, 4095):03X}{rng.randint(0, 4095):03X}", None
    if kind == "AW":
        return "AW", "0"
    if kind == "G?":
        return "G?", "G?0F0F0000"
    if kind == "D?":
        return "D?", "01 9" + "PTG-200".ljust(20) + "SN000123".ljust(20)
    if kind == "R?":
        return "R?", h4(rng.randint(100, 9000)) + h4(rng.randint(100, 9000))
    if kind == "I?":
        return "I?", "0000"
    if kind == "E?":
        return "E?", "0000"
    if kind == "LR":
        return "LR", "L3"
    if kind == "L?":
        return "L?", "000FFF000FFF"
    if kind == "SP":
        return f"SP{rng.randint(0, 15):X}", None
    if kind == "Pnn":
        return f"P{rng.randint(0, 255):02X}", None
    if kind == "P?nn":
        return f"P?{rng.randint(0, 255):02X}", h4(az) + h4(el)
    if kind == "UNKNOWN":
        return "QZ", None
    return kind, None


def generate(commands: int, *, baud: int = 9600, seed: int = 1,
             devices: Sequence[tuple[int, int, int]] = ((1, 1, 1), (1, 1, 2), (1, 2, 1)),
             controller_group: int = 0, bit_error_rate: float = 0.0, drop_ack_rate: float = 0.0,
             noise_rate: float = 0.0, ack_timeout: float = 0.2,
             think: tuple[float, float] = (0.005, 0.02),
             answer_delay: tuple[float, float] = (0.002, 0.008)) -> Traffic:
    """A conversation of ``commands`` commands (retransmissions included)."""
    rng = random.Random(seed)
    traffic = Traffic(baud)
    bt = traffic.bt
    kinds = [k for k, _ in POLL_MIX]
    weights = [w for _, w in POLL_MIX]
    t = 0.0
    sent = 0
    while sent < commands:
        dev = rng.choice(devices)
        kind = rng.choices(kinds, weights)[0]
        payload, result = _payload_for(kind, rng)
        frame = build_frame(dev, controller_group, payload)
        for _attempt in range(3):
            sent += 1
            wire = bytearray(frame)
            corrupted = bit_error_rate and rng.random() < bit_error_rate
            if corrupted:
                k = rng.randrange(1, len(wire))
                wire[k] ^= 1 << rng.randrange(8)
            traffic.writes.append(Write("A", bytes(wire), t))
            t += len(wire) * bt
            t_answer = t + rng.uniform(*answer_delay)
            if drop_ack_rate and rng.random() < drop_ack_rate:
                t += ack_timeout + rng.uniform(0.001, 0.01)
                continue   # the controller times out and retransmits
            if corrupted:
                traffic.writes.append(Write("B", bytes([NAK]), t_answer))
                t = t_answer + bt + rng.uniform(0.002, 0.01)
                continue
            answer = bytes([ACK, NIC]) if kind == "UNKNOWN" else bytes([ACK])
            traffic.writes.append(Write("B", answer, t_answer))
            t = t_answer + len(answer) * bt
            if result is not None:
                g, p, d = dev
                res = build_frame((controller_group, p, d), g, result)
                t_res = t + rng.uniform(answer_delay[0] / 2, answer_delay[1] / 2)
                traffic.writes.append(Write("B", res, t_res))
                t = t_res + len(res) * bt
            break
        if noise_rate and rng.random() < noise_rate:
            junk = bytes(rng.choice([0x00, 0xFF, 0x80, 0x7E, 0xE0]) for _ in range(rng.randint(1, 6)))
            traffic.writes.append(Write("B", junk, t + 0.001))
            t += 0.001 + len(junk) * bt
        t += rng.uniform(*think)   # controller think time
    return traffic
