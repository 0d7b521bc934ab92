"""socat logs made for real: socat -x -v between two ptys, a scripted controller
on one side and a scripted gimbal on the other, both through pyserial. The gimbal
answers 50 ms after the command's last byte; the decoded latency must say 50 ms,
or as much more as a loaded machine made the exchange take (``Clock``)."""

import os
import subprocess
import time

import pytest
import serial

import analyzer
from tests.conftest import frame, run_cli

BT = 10 / 9600


def wait_for(path, timeout=5.0):
    end = time.monotonic() + timeout
    while not os.path.exists(path):
        if time.monotonic() > end:
            raise TimeoutError(path)
        time.sleep(0.01)


@pytest.fixture
def socat_tap(tmp_path, socat_bin):
    a, b, log = tmp_path / "ctl", tmp_path / "dev", tmp_path / "tap.log"
    with open(log, "wb") as err:
        proc = subprocess.Popen([socat_bin, "-x", "-v", f"PTY,link={a},raw,echo=0",
                                 f"PTY,link={b},raw,echo=0"], stderr=err)
    try:
        wait_for(a)
        wait_for(b)
        ctl = serial.Serial(str(a), 9600, timeout=2)
        dev = serial.Serial(str(b), 9600, timeout=2)
        yield ctl, dev, log
        ctl.close()
        dev.close()
    finally:
        proc.terminate()
        proc.wait(5)


class Clock:
    """When each step of an exchange happened (``time.time()``, socat's clock).
    socat stamps bytes when it reads them: a command's stamp lies between our
    writing it and the gimbal reading it, an answer's between our writing it and
    the controller reading it. So a decoded latency has bounds that hold however
    late a loaded machine runs a sleep or a read."""

    def __init__(self) -> None:
        self.sent = self.received = self.answered = self.result_sent = self.done = 0.0

    def latency(self, until: float, nbytes: int, slack: float = 0.0005) -> tuple[float, float]:
        """Bounds of the latency from the command's end to an answer of ``nbytes``
        bytes written at ``until``: its start is its stamp less its byte times
        (``slack``: socat prints microseconds)."""
        return until - self.received - nbytes * BT - slack, self.done - self.sent - nbytes * BT + slack


def exchange(ctl, dev, command: bytes, answer: bytes, delay: float, result: bytes = b"", result_delay=0.0) -> Clock:
    """The controller sends; the gimbal reads it and answers like a 9600-baud wire:
    its ACK starts ``delay`` after the command's end, so its last byte arrives one
    byte time later. Returns when each step happened."""
    clock = Clock()
    clock.sent = time.time()
    ctl.write(command)
    ctl.flush()
    got = dev.read(len(command))
    clock.received = time.time()
    assert got == command
    time.sleep(delay + len(answer) * BT)
    clock.answered = time.time()
    dev.write(answer)
    dev.flush()
    if result:
        time.sleep(result_delay + len(result) * BT)
        clock.result_sent = time.time()
        dev.write(result)
        dev.flush()
    ctl.read(len(answer) + len(result))
    clock.done = time.time()
    return clock


def test_50ms_answer_decodes_as_50ms(socat_tap, tmp_path):
    ctl, dev, log = socat_tap
    first = exchange(ctl, dev, frame((1, 1, 1), 0, "P?"), b"\x06", 0.050,
                     result=frame((0, 1, 1), 1, "0FA0FC18"), result_delay=0.020)
    time.sleep(0.2)
    second = exchange(ctl, dev, frame((1, 1, 1), 0, "HO"), b"\x15", 0.010)
    time.sleep(0.2)
    text = log.read_text()
    assert text.startswith("> ") and "length=9 from=0 to=8" in text
    events = list(analyzer.open(str(log)))
    kinds = [(e.line, e.kind, e.command) for e in events]
    assert kinds == [("A", "command", "P?"), ("B", "ack", None), ("B", "result", "P?"),
                     ("A", "command", "HO"), ("B", "nak", None)]
    cmd, ack, res, ho, nak = events
    result_bytes = len(frame((0, 1, 1), 1, "0FA0FC18"))

    def within(latency: float, bounds: tuple[float, float]) -> bool:
        return bounds[0] <= latency <= bounds[1]

    # 50 ms as the wire had it: never less than the gimbal waited, never more than
    # the exchange took (on a quiet machine both bounds are within a millisecond of 50)
    assert ack.latency >= 0.050 - 0.0005 and within(ack.latency, first.latency(first.answered, 1))
    # the result starts 20 ms after the ACK's one byte ended
    assert res.latency >= 0.050 + BT + 0.020 - 0.0005
    assert within(res.latency, first.latency(first.result_sent, result_bytes))
    assert res.fields == {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    assert nak.latency >= 0.010 - 0.0005 and within(nak.latency, second.latency(second.answered, 1))
    assert (cmd.status, ho.status) == ("ok", "nak")
    # the gap between the two commands is real time too (0.2 s sleeps and more)
    assert ho.t - cmd.t > 0.2

    # the same through the CLI, as JSON Lines
    out = run_cli("decode", log, "--format", "jsonl")
    assert out.returncode == 0, out.stderr
    import json
    rows = [json.loads(line) for line in out.stdout.splitlines()]
    assert rows[1]["kind"] == "ack" and rows[1]["latency"] == pytest.approx(ack.latency, abs=1e-9)


def test_noise_and_bad_checksum_through_socat(socat_tap):
    ctl, dev, log = socat_tap
    bad = bytearray(frame((1, 1, 2), 0, "P0FA0FC18"))
    bad[-1] ^= 0x10
    exchange(ctl, dev, bytes(bad), b"\x15", 0.005)
    time.sleep(0.1)
    dev.write(b"\x00\xff\x00")   # noise on the device line
    dev.flush()
    time.sleep(0.1)
    events = list(analyzer.open(str(log)))
    assert [(e.kind, e.checksum_ok) for e in events] == [("command", False), ("nak", None), ("noise", None)]
    assert events[0].problems[0].startswith("bad checksum")
    assert events[0].status == "nak"
