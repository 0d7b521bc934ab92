"""A scripted two-line conversation for the TUI tests, written as a socat log
(timed). Expected rows are listed by hand from the spec (Table 1 framing, §1.4.2
answers), not from the code.

  #1  A  P? to 1.1.1            -> #2 ACK, #3 result az +10.00 el -5.00 (Table 15)
  #4  A  P  to 1.1.2 (go to)    -> #5 NAK
  #6  A  P  to 1.1.2 again      -> #7 ACK                  (retransmission after NAK)
  #8  A  FA to 1.1.1            -> #9 ACK, #10 NIC
  #11 A  HO to 1.1.3 bad checksum, no answer (no_ack after the next command)
  #12 A  HO to 1.1.3            -> #13 ACK
"""

from __future__ import annotations

from analyzer.simulation.traffic import Traffic, Write
from tests.conftest import frame

BT = 10 / 9600


def hex4(value_hundredths: int) -> str:
    """A signed 16-bit position in hundredths of a degree as 4 hex digits (Table 15)."""
    return f"{value_hundredths & 0xFFFF:04X}"


def conversation() -> tuple[Traffic, dict]:
    tr = Traffic(baud=9600)
    t = 0.0

    def a(data: bytes, gap: float = 0.05) -> None:
        nonlocal t
        t += gap
        tr.writes.append(Write("A", data, t))
        t += len(data) * BT

    def b(data: bytes, gap: float = 0.005) -> None:
        nonlocal t
        t += gap
        tr.writes.append(Write("B", data, t))
        t += len(data) * BT

    a(frame((1, 1, 1), 0, "P?"))
    b(b"\x06")
    b(frame((0, 1, 1), 1, hex4(1000) + hex4(-500)), gap=0.002)
    goto = frame((1, 1, 2), 0, "P" + hex4(2000) + hex4(1500))
    a(goto)
    b(b"\x15")
    a(goto)
    b(b"\x06")
    a(frame((1, 1, 1), 0, "FA"))
    b(b"\x06")
    b(b"?", gap=0.001)
    bad = bytearray(frame((1, 1, 3), 0, "HO"))
    bad[-1] ^= 0xFF
    a(bytes(bad))
    a(frame((1, 1, 3), 0, "HO"), gap=0.3)
    b(b"\x06")
    expected = {
        "kinds": ["command", "ack", "result", "command", "nak", "command", "ack", "command", "ack", "nic",
                  "command", "command", "ack"],
        "status": {1: "ok", 4: "nak", 6: "ok", 8: "nic", 11: "no_ack", 12: "ok"},
        "answers": {1: [2, 3], 4: [5], 6: [7], 8: [9, 10], 12: [13]},
        # the NAK'd command, the NAK, the retransmission, the NIC'd command, the bad
        # checksum (also unanswered), and its resend (a retransmission); a NIC answer
        # itself is information, not an error
        "errors": [4, 5, 6, 8, 11, 12],
    }
    return tr, expected


def write_capture(path) -> dict:
    tr, expected = conversation()
    path.write_text(tr.socat_log())
    return expected
