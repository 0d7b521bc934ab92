"""Logic waveforms of known traffic, made sample by sample, for the logic
analyser inputs' tests (docs/instruments.md): what a UART puts on a wire,
with the faults a waveform shows (a fast clock, glitches, inversion, a break).

A line is described as characters at times; ``uart_levels`` renders one line
as an array of 0/1 levels at a sample rate, and ``pack`` puts channels side by
side in sample words (channel i at bit i), as sigrok's binary format has them.
"""

from __future__ import annotations

import subprocess

import numpy as np


def frame_bits(value: int, data_bits: int = 8, parity: str = "N", stop_bits: int = 1) -> list[int]:
    """The logical bits of one character: start (0), data LSB first, parity, stop (1)."""
    data = [(value >> i) & 1 for i in range(data_bits)]
    bits = [0] + data
    if parity in ("E", "O"):
        ones = sum(data)
        bits.append(ones % 2 if parity == "E" else 1 - ones % 2)
    return bits + [1] * stop_bits


def uart_levels(chars: list[tuple[float, int]], samplerate: float, baud: float, duration: float,
                data_bits: int = 8, parity: str = "N", stop_bits: int = 1, inverted: bool = False,
                breaks: list[tuple[float, float]] = (), glitches: list[float] = (),
                glitch_len: float = 0.1) -> np.ndarray:
    """One line's levels (uint8 0/1) over ``duration`` seconds: each (time, value)
    of ``chars`` sent from its start time at ``baud`` (a sender whose clock is off
    is a baud that is not the nominal one); ``breaks``: (from, seconds) held at
    the active level; ``glitches``: times of pulses ``glitch_len`` bits long."""
    n = round(duration * samplerate)
    level = np.ones(n, dtype=np.uint8)
    bit = samplerate / baud
    for t, value in chars:
        s = t * samplerate
        for k, b in enumerate(frame_bits(value, data_bits, parity, stop_bits)):
            a, z = round(s + k * bit), round(s + (k + 1) * bit)
            level[a:z] = b
    for t, secs in breaks:
        level[int(t * samplerate):int((t + secs) * samplerate)] = 0
    for t in glitches:
        a = int(t * samplerate)
        level[a:a + max(1, int(glitch_len * bit))] ^= 1
    if inverted:
        level ^= 1
    return level


def back_to_back(data: bytes, t: float, baud: float, data_bits: int = 8, parity: str = "N",
                 stop_bits: int = 1) -> list[tuple[float, int]]:
    """The characters of ``data`` sent one after another from ``t``."""
    per = (1 + data_bits + (parity in ("E", "O")) + stop_bits) / baud
    return [(t + i * per, b) for i, b in enumerate(data)]


def pack(*channels: np.ndarray) -> bytes:
    """Channels side by side, channel i at bit i of a byte a sample."""
    word = np.zeros(max(len(c) for c in channels), dtype=np.uint8)
    for i, c in enumerate(channels):
        word[:len(c)] |= (c.astype(np.uint8) & 1) << i
    return word.tobytes()


def sigrok_session(folder, *channels: np.ndarray, samplerate: float, name: str = "cap") -> str:
    """A .sr written by sigrok-cli (its binary input) from the channels' levels,
    in ``folder``: channel i is named "i", as sigrok-cli names them."""
    raw = folder / f"{name}.bin"
    raw.write_bytes(pack(*channels))
    out = folder / f"{name}.sr"
    subprocess.run(["sigrok-cli", "-I", f"binary:numchannels={max(len(channels), 1)}:samplerate={samplerate}",
                    "-i", str(raw), "-o", str(out)], check=True, capture_output=True, timeout=120)
    return str(out)
