"""A link read at the wrong rate, and input that is not this protocol at all, as the
wiring doctor tells them apart (docs/doctor.md, "Wrong rate or not this protocol").

The traffic is made here, independently of the product: frames encoded from the
wire format of docs/decoding.md ("Wire format"), serialised to a line's levels at
the rate the link runs at, and read back by a UART written here that samples the
line 16 times a bit at the tap's rate (start bit on a falling edge, data and stop
bits in their middles, a character with a low stop bit passed on as a Linux tty in
raw mode does). Neither the simulator nor the product's own re-simulation
(analyzer/analysis/rate.py) makes the bytes the doctor is given."""

from __future__ import annotations

import random
import time

import pytest

import analyzer
from analyzer.analysis.doctor import Invocation, WiringDoctor
from analyzer.analysis.findings import NO_FRAMES, NOT_THIS_PROTOCOL, WRONG_BAUD
from analyzer.analysis.signs import MISREAD, SAMPLE, Misread

# ------------------------------------------------------------ frames, from the docs


def encode(dst: tuple[int, int, int], src: int, payload: str) -> bytes:
    """``F8 G P D S L payload… C`` (docs/decoding.md, "Wire format"): L is the payload
    length, C the sum of G through the last payload byte, modulo 256."""
    body = bytes([*dst, src, len(payload)]) + payload.encode("ascii")
    return b"\xf8" + body + bytes([sum(body) % 256])


def test_the_encoder_gives_the_bytes_worked_out_by_hand():
    # P? to 1.1.1 from group 0: 01+01+01+00+02 + 'P'(50) + '?'(3F) = 0x94
    assert encode((1, 1, 1), 0, "P?") == bytes.fromhex("f8 01 01 01 00 02 50 3f 94")
    # its result from 0.1.1 (groups swapped, Table 3), "03E8FE0C": 00+01+01+01+08 = 0B, the
    # payload 30+33+45+38+46+45+30+43 = 1DE; 0B + 1DE = 1E9 -> E9
    assert encode((0, 1, 1), 1, "03E8FE0C") == bytes.fromhex("f8 00 01 01 01 08 30 33 45 38 46 45 30 43 e9")


ACK = b"\x06"   # docs/decoding.md: simple responses are single bytes, ACK 06


def polling(exchanges: int = 60, seed: int = 5) -> list[tuple[str, float, bytes]]:
    """A controller polling three gimbals with a few commands, each answered with an
    ACK 4 ms after the command and, for queries, a result 1 ms after the ACK; 40 ms
    until the next command. (line, start time in bit times at the link's rate, bytes)."""
    rng = random.Random(seed)
    out = []
    t = 0.0
    for k in range(exchanges):
        dev = 1 + k % 3
        payload = rng.choice(["P?", "P?", "P0FA0FC18", "V?", "AW"])
        cmd = encode((1, 1, dev), 0, payload)
        out.append(("A", t, cmd))
        t += 10 * len(cmd) + 40                       # bit times: the frame, then about 4 ms at 9600
        out.append(("B", t, ACK))
        t += 10 + 10
        if payload.endswith("?"):
            res = encode((0, 1, dev), 1, rng.choice(["03E8FE0C", "0FA0FC18", "0A0123"]))
            out.append(("B", t, res))
            t += 10 * len(res)
        t += 400                                      # about 40 ms at 9600
    return out


# ------------------------------------------------------------ a UART, written here

OVERSAMPLE = 16


def uart_read(messages: list[tuple[float, bytes]], sent: int, read: int) -> list[tuple[float, bytes]]:
    """What a UART at ``read`` bit/s reads of ``messages`` (start in the sender's bit
    times, bytes sent back to back) sent at ``sent`` bit/s, 8N1: the line is sampled
    OVERSAMPLE times per reader's bit; a character starts at a falling edge, its
    data bits are the samples in the middle of each of its bits, LSB first; a low
    stop bit is a framing error: the character is passed on all the same and the
    reader waits for the line to go high before it looks for the next start bit.
    Returns, per burst of the line, (the time its last character was read, seconds;
    its bytes)."""
    # the line's level over time: a list of (start s, end s, bits) per message, idle high between
    spans = []
    for at, data in messages:
        bits = []
        for b in data:
            bits += [0] + [(b >> k) & 1 for k in range(8)] + [1]
        spans.append((at / sent, (at + len(bits)) / sent, bits))
    # bursts: messages closer than 24 of the reader's bits are read as one
    bursts: list[list] = []
    for span in spans:
        if bursts and span[0] < bursts[-1][-1][1] + 24 / read:
            bursts[-1].append(span)
        else:
            bursts.append([span])

    def level(burst: list, t: float) -> int:
        for start, end, bits in burst:
            if start <= t < end:
                return bits[int((t - start) * sent)]
        return 1

    out = []
    step = 1 / (read * OVERSAMPLE)
    for burst in bursts:
        t0, t1 = burst[0][0] - 2 / read, burst[-1][1] + 24 / read
        samples = [level(burst, t0 + i * step) for i in range(int((t1 - t0) / step))]
        got = bytearray()
        last = t0
        i, n = 1, len(samples)
        while i < n:
            if not (samples[i - 1] == 1 and samples[i] == 0):
                i += 1
                continue
            mid = i + OVERSAMPLE // 2                 # the middle of the start bit
            if mid + 9 * OVERSAMPLE >= n:
                break
            value = sum(samples[mid + (k + 1) * OVERSAMPLE] << k for k in range(8))
            stop = mid + 9 * OVERSAMPLE
            got.append(value)                         # framing error or not
            last = t0 + stop * step
            i = stop
            while i < n and samples[i] == 0:          # a low stop bit: wait for the line to rise
                i += 1
        if got:
            out.append((last, bytes(got)))
    return out


def test_the_uart_reads_its_own_rate_back_and_misreads_others_as_worked_out_by_hand():
    cmd = encode((1, 1, 1), 0, "P?")
    assert uart_read([(0, cmd)], 9600, 9600) == [(pytest.approx(len(cmd) * 10 / 9600 - 0.5 / 9600,
                                                                abs=2 / 9600 / OVERSAMPLE), cmd)]
    # ACK 06 at 9600 is, on the wire, 0 | 0 1 1 0 0 0 0 0 | 1 (start, LSB first, stop).
    # Read at 19200 each bit lasts two of the reader's: its data bits fall on the
    # sender's bits 0.75, 1.25 ... 4.25: start, d0, d0, d1, d1, d2, d2, d3 = 0 0 0 1 1 1 1 0,
    # LSB first 0x78; its stop bit falls on d3 = 0 (a framing error, passed on).
    assert uart_read([(0, ACK)], 9600, 19200)[0][1] == b"\x78"
    # Read at 4800 each of the reader's bits spans two of the sender's: data bits on the
    # sender's bits 3, 5 ... 17: d2, d4, d6, stop, then idle = 1 0 0 1 1 1 1 1 -> 0xF9
    assert uart_read([(0, ACK)], 9600, 4800)[0][1] == b"\xf9"


# ------------------------------------------------------------ captures of it


def socat_log(chunks: list[tuple[str, float, bytes]]) -> str:
    """A log as ``socat -x -v`` (Debian 1.7.4) writes it: per read, direction, time of
    the read (a 9-digit fraction holding microseconds: docs/decoding.md, "Time"),
    length and offsets, then the bytes in hex."""
    out = []
    offsets = {"A": 0, "B": 0}
    start = 1_795_000_000
    for line, t, data in sorted(chunks, key=lambda c: c[1]):
        sec = int(start + t)
        usec = round((start + t - sec) * 1e6)
        if usec == 1_000_000:
            sec, usec = sec + 1, 0
        first = offsets[line]
        offsets[line] += len(data)
        stamp = time.strftime("%Y/%m/%d %H:%M:%S", time.localtime(sec))
        out.append(f"{'>' if line == 'A' else '<'} {stamp}.{usec:09d}  length={len(data)} from={first} "
                   f"to={offsets[line] - 1}\n")
        for k in range(0, len(data), 16):
            part = data[k:k + 16]
            hexes = " " + " ".join(f"{b:02x}" for b in part)
            out.append(f"{hexes:<49} {''.join(chr(b) if 32 <= b < 127 else '.' for b in part)}\n")
        out.append("--\n")
    return "".join(out)


def tapped(traffic: list[tuple[str, float, bytes]], sent: int, read: int) -> list[tuple[str, float, bytes]]:
    """What a tap at ``read`` bit/s reads of each line of ``traffic`` sent at ``sent``."""
    out = []
    for line in ("A", "B"):
        messages = [(at, data) for ln, at, data in traffic if ln == line]
        out += [(line, t, data) for t, data in uart_read(messages, sent, read)]
    return out


def doctor_of(*paths, invocation: Invocation | None = None, **options) -> dict:
    """The doctor's findings on a capture, by id (a list where several lines have one)."""
    cap = analyzer.open(*map(str, paths), **options)
    doctor = WiringDoctor(cap.lines, invocation=invocation)
    for batch in cap.batches():
        for ev in batch:
            doctor.add(ev)
    found: dict = {}
    for f in doctor.findings():
        found.setdefault(f.code, []).append(f)
    return {code: fs[0] if len(fs) == 1 else fs for code, fs in found.items()}


def each(found: dict, code: str) -> list:
    """Every finding with that id."""
    f = found.get(code, [])
    return f if isinstance(f, list) else [f]


@pytest.fixture(scope="module")
def traffic():
    return polling()


@pytest.mark.parametrize("read", [19200, 4800])
def test_9600_traffic_read_at_another_rate_is_a_wrong_rate_named_9600(tmp_path, traffic, read):
    log = tmp_path / "tap.log"
    log.write_text(socat_log(tapped(traffic, 9600, read)))
    # a socat log does not say the tap's rate: --baud (here the API's baud) does
    found = doctor_of(log, baud=read)
    assert NOT_THIS_PROTOCOL not in found and NO_FRAMES not in found
    wrong = each(found, WRONG_BAUD)
    assert {f.subject for f in wrong} == {"A", "B"}, found
    for f in wrong:
        assert f.severity == "error"
        assert (f.measured.get("baud"), f.measured.get("read")) == (9600, read), f.measured


def test_the_same_capture_read_at_the_right_rate_raises_nothing_of_the_sort(tmp_path, traffic):
    log = tmp_path / "tap.log"
    log.write_text(socat_log(tapped(traffic, 9600, 9600)))
    found = doctor_of(log, baud=9600)
    assert not {WRONG_BAUD, NOT_THIS_PROTOCOL, NO_FRAMES} & set(found), list(found)
    assert [f.severity for f in found.values()] == ["info"]      # the device map only


def test_raw_dumps_name_the_rate_from_the_rate_the_tap_read_at(tmp_path, traffic):
    chunks = tapped(traffic, 9600, 19200)
    for line in ("A", "B"):
        (tmp_path / f"{line}.bin").write_bytes(b"".join(d for ln, _t, d in chunks if ln == line))
    dumps = (tmp_path / "A.bin", tmp_path / "B.bin")
    told = doctor_of(*dumps, invocation=Invocation(tuple(map(str, dumps)), baud=19200))
    assert {(f.measured.get("baud"), f.measured.get("read")) for f in each(told, WRONG_BAUD)} == {(9600, 19200)}
    # untold, a raw dump has no time to show the tap's rate: it is read at 9600 (§1.5.1's
    # default), and the line's rate follows from the ratio, half the tap's: 4800
    untold = doctor_of(*dumps)
    assert {(f.measured.get("baud"), f.measured.get("read")) for f in each(untold, WRONG_BAUD)} == {(4800, 9600)}
    assert NOT_THIS_PROTOCOL not in untold


def text_traffic(lines: list[str]) -> list[tuple[str, float, bytes]]:
    """A console's text on line A, a line every 100 ms."""
    return [("A", 0.1 * k, (s + "\r\n").encode("ascii")) for k, s in enumerate(lines)]


def test_56_bytes_of_text_say_what_they_are_not_no_problems(tmp_path):
    text = "Hello from the bench PC, this is not gimbal traffic.\r\n"
    assert len(text) == 54
    log = tmp_path / "console.log"
    log.write_text(socat_log([("A", 0.0, text.encode("ascii")), ("A", 0.5, b"OK")]))   # 56 bytes
    found = doctor_of(log)
    assert set(found) == {NO_FRAMES}, list(found)
    f = found[NO_FRAMES]
    assert f.severity == "warning" and f.subject == "A"
    assert f.measured == {"looks": "text", "bytes": 56}
    assert f.title.startswith("56 bytes on line A")     # what it saw, for people


def test_more_text_is_not_this_protocol(tmp_path):
    lines = [f"temperature {20 + k % 7} C, fan {1200 + 10 * k} rpm" for k in range(12)]
    log = tmp_path / "console.log"
    log.write_text(socat_log(text_traffic(lines)))
    found = doctor_of(log)
    assert set(found) == {NOT_THIS_PROTOCOL}, list(found)
    assert found[NOT_THIS_PROTOCOL].measured["looks"] == "text"


def test_random_bytes_on_one_line_are_not_this_protocol(tmp_path):
    rng = random.Random(11)
    # bursts of random bytes on line A only, in 30-byte reads 50 ms apart
    chunks = [("A", 0.05 * k, bytes(rng.randrange(256) for _ in range(30))) for k in range(40)]
    log = tmp_path / "tap.log"
    log.write_text(socat_log(chunks))
    found = doctor_of(log)
    assert NOT_THIS_PROTOCOL in found and WRONG_BAUD not in found, found
    assert found[NOT_THIS_PROTOCOL].measured["looks"] == "binary"


def test_random_bytes_with_a_few_on_the_other_line_are_not_this_protocol(tmp_path):
    rng = random.Random(12)
    chunks = [("A", 0.05 * k, bytes(rng.randrange(256) for _ in range(30))) for k in range(40)]
    chunks.append(("B", 0.51, bytes(rng.randrange(256) for _ in range(20))))   # too few to judge, no frame
    log = tmp_path / "tap.log"
    log.write_text(socat_log(chunks))
    found = doctor_of(log)
    assert NOT_THIS_PROTOCOL in found and WRONG_BAUD not in found, found


def crc16_modbus(data: bytes) -> bytes:
    """Modbus RTU's CRC: reflected polynomial A001, start FFFF, low byte first."""
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return bytes([crc & 0xFF, crc >> 8])


def test_another_framed_protocol_in_a_request_answer_rhythm_is_not_this_protocol(tmp_path):
    # read 10 registers from slave 1: 01 03 0000 000A, CRC C5 CD (the usual example)
    assert crc16_modbus(bytes.fromhex("01 03 00 00 00 0a")) == bytes.fromhex("c5 cd")
    rng = random.Random(3)
    chunks = []
    for k in range(40):
        req = bytes([1, 3, 0, 2 * k % 32, 0, 10])
        answer = bytes([1, 3, 20]) + bytes(rng.randrange(256) for _ in range(20))
        chunks.append(("A", 0.1 * k, req + crc16_modbus(req)))
        chunks.append(("B", 0.1 * k + 0.03, answer + crc16_modbus(answer)))
    log = tmp_path / "modbus.log"
    log.write_text(socat_log(chunks))
    found = doctor_of(log)
    assert NOT_THIS_PROTOCOL in found and WRONG_BAUD not in found, found


def test_an_empty_capture_says_it_holds_nothing(tmp_path):
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    found = doctor_of(empty)
    assert set(found) == {NO_FRAMES}
    assert found[NO_FRAMES].measured == {"looks": None, "bytes": 0}


# ------------------------------------------------------------ the scores docs/doctor.md gives

@pytest.mark.parametrize("sent, read", [
    (9600, 19200), (9600, 4800), (9600, 38400), (4800, 9600), (19200, 9600), (2400, 9600), (38400, 9600),
    (57600, 9600), (115200, 9600), (1200, 9600),
])
def test_misread_traffic_scores_over_1_bit_a_byte_and_no_other_rate_is_named(sent, read):
    """docs/doctor.md, "Wrong rate or not this protocol": this protocol misread scores
    1.0 or more; the rate named, if any, is the line's (at 8 times the tap's rate the
    rates' bytes look alike: 1200 read at 9600 is not named)."""
    # the same exchanges in seconds whatever the rate: the silences stay silences
    traffic = [(line, at * sent / 9600, data) for line, at, data in polling(40)]
    sample = b"".join(data for _line, _t, data in tapped(traffic, sent, read))
    guess = Misread.of(sample[:2 * SAMPLE], read)
    assert guess.score >= MISREAD, guess
    assert guess.named in (sent, None), guess
    if sent / read != 1 / 8:
        assert guess.named == sent, guess


def test_text_random_bytes_and_another_protocol_score_below_0():
    rng = random.Random(2)
    text = b"".join(f"temperature {20 + k % 7} C, fan {1200 + 10 * k} rpm\r\n".encode() for k in range(40))
    modbus = b""
    for k in range(60):
        req = bytes([1, 3, 0, k % 32, 0, 10])
        answer = bytes([1, 3, 20]) + bytes(rng.randrange(256) for _ in range(20))
        modbus += req + crc16_modbus(req) + answer + crc16_modbus(answer)
    for sample in (bytes(rng.randrange(256) for _ in range(3000)), modbus):
        assert Misread.of(sample, 9600).score < 0
    # text is said as text, not scored
    assert Misread.of(text, 9600).look == "text" and not Misread.of(text, 9600).looks_misread(rhythm=True)
