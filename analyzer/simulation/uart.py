"""What a UART listening at one rate reads from bytes sent at another: the 8N1 bit
stream is built at the sender's rate and sampled mid-bit at the listener's, as a
receiver does (start bit on a falling edge, 8 data bits LSB first, stop bit).
Used to inject the "wrong baud rate" fault."""

from __future__ import annotations


def misread(data: bytes, sent_baud: int, listen_baud: int) -> bytes:
    """The bytes a ``listen_baud`` receiver makes of ``data`` sent at ``sent_baud``
    (frames whose stop bit is wrong are dropped, as framing errors are)."""
    if sent_baud == listen_baud or not data:
        return bytes(data)
    bits = []                                   # line level per sender bit time; idle high
    for b in data:
        bits.append(0)
        bits.extend((b >> k) & 1 for k in range(8))
        bits.append(1)
    bits.extend([1] * 10)
    ratio = sent_baud / listen_baud             # sender bits per listener bit

    def level(t: float) -> int:                 # t in sender bit times
        k = int(t)
        return bits[k] if 0 <= k < len(bits) else 1

    out = bytearray()
    t = 0.0
    step = 0.25                                 # look for the falling edge in quarter bits
    end = len(bits)
    while t < end:
        if level(t) == 1:
            t += step
            continue
        # start bit found: sample data bits in the middle of each listener bit
        value = 0
        for k in range(8):
            value |= level(t + (1.5 + k) * ratio) << k
        if level(t + 9.5 * ratio) == 1:         # stop bit: a good frame
            out.append(value)
        t += 10 * ratio
    return bytes(out)
