"""The wrong-baud fault: what a receiver at one rate reads from bytes sent at another."""

from analyzer.simulation.uart import misread


def test_same_rate_is_exact():
    data = bytes(range(256))
    assert misread(data, 9600, 9600) == data


def test_sent_twice_as_fast_reads_as_garbage():
    # 0x06 = start 0, bits 0 1 1 0 0 0 0 0 (LSB first), stop 1, at 19200 into a 9600
    # receiver: each listener bit spans two sender bits; sampling mid-bit at
    # sender bit times 3, 5, 7, 9, ... (1.5 + k listener bits × 2)
    # -> data bits: level(3)=1 (bit 2 of 0x06), level(5)=0, level(7)=0, level(9)=1 (stop),
    #    then idle 1s: 1 0 0 1 1 1 1 1 -> 0b11111001 = 0xF9; its stop sample is idle 1
    assert misread(b"\x06", 19200, 9600) == b"\xf9"


def test_wrong_rate_never_reproduces_a_frame():
    frame = bytes.fromhex("f80101010002503f94")
    for rate in (1200, 2400, 4800, 19200, 38400, 57600, 115200):
        assert misread(frame, rate, 9600) != frame
