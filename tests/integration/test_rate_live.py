"""Following the link's rate live (docs/time.md, "Rate changes") and one clock
behind socat ("Clocks", "Byte order"), on real pseudo-terminals through pyserial.

The simulated controller switches the link to 115200 bit/s with a broadcast C7;
the gimbals ACK at 9600 and switch. Each tap port is a pty whose termios rate the
link honours: a tap still listening at 9600 reads garbage (the link misreads the
bytes for it, as a UART would), so a clean decode after the change shows the tap
really set its ports to the new rate."""

from __future__ import annotations

import signal
import statistics
import subprocess
import sys
import threading
import time

import pytest

import analyzer
from analyzer.capture import Options, open_live
from analyzer.cli.common import run_tap
from analyzer.info import CaptureInfo
from analyzer.runner import Listener
from analyzer.simulation import scenario
from analyzer.simulation.bus import GimbalBus
from analyzer.simulation.controller import SimController
from analyzer.simulation.gimbal import GimbalModel
from analyzer.writers.mcap import McapWriter
from dissectors.event import ACK, COMMAND, NOISE, OK, PENDING, RATE, RESULT, ST_NIC
from tests.conftest import ROOT

SECONDS = 6.0
BT_115200 = 10 / 115200
BT_9600 = 10 / 9600


@pytest.fixture(autouse=True)
def patient_controller(monkeypatch):
    """The simulated controller waits this long after switching before it talks at
    the new rate. A live tap sets its ports once it has decoded the ACK (docs/time.md,
    "Limits"); on a machine busy with other work that can take longer than the
    0.15 s the controller gives the gimbals, so the tests give it a second."""
    from analyzer.simulation import controller
    monkeypatch.setattr(controller, "RATE_SETTLE", 1.0)


class Collect(Listener):
    def __init__(self) -> None:
        self.events = []

    def on_events(self, events) -> None:
        self.events += events


def tap_for(seconds: float, follow: bool, record: str | None = None,
            rotate_bytes: int | None = None) -> tuple[list, list]:
    """Run the clean installation with a rate change after 1 s, tapped live."""
    site = scenario.build(set(), clean=True, rate_change=(115200, 1.0))
    capture = open_live(list(site.link.tap_ports), Options(follow_rate=follow))
    collect = Collect()
    listeners = [collect]
    if record:
        listeners.append(McapWriter(record, CaptureInfo.of(capture, command="live"), live=True,
                                    rotate_bytes=rotate_bytes))
    site.start()
    timer = threading.Timer(seconds, capture.source.stop)
    timer.start()
    try:
        runner = run_tap(capture, "live", *listeners, notes=False)
    finally:
        timer.cancel()
        site.stop()
    return collect.events, capture.warnings + [n for n in getattr(runner, "notes", [])]


def after_change(events: list) -> tuple[object, list]:
    rates = [e for e in events if e.kind == RATE]
    assert len(rates) == 1, [e for e in events if e.kind == RATE]
    k = events.index(rates[0])
    return rates[0], events[k + 1:]


def test_a_live_tap_follows_the_rate_change():
    events, _warnings = tap_for(SECONDS, follow=True)
    rate, later = after_change(events)
    assert rate.fields == {"baud": 115200, "previous_baud": 9600}
    cmd = next(e for e in events if e.number == rate.request)
    assert cmd.kind == COMMAND and cmd.payload == b"C7" and cmd.status == OK
    # after it, the tap reads the conversation at 115200: answered commands, no garbage
    commands = [e for e in later if e.kind == COMMAND]
    assert len(commands) >= 10
    assert not [e for e in later if e.kind == NOISE or e.checksum_ok is False]
    # every one answered (ok, or NIC for what the simulated firmware does not implement),
    # but those still in flight when the tap stopped, at the end (under load, more than one)
    in_flight = len(commands)
    while in_flight and commands[in_flight - 1].status == PENDING:
        in_flight -= 1
    assert in_flight >= len(commands) - 3
    assert {e.status for e in commands[:in_flight]} <= {OK, ST_NIC} and sum(e.status == OK for e in commands) >= 10
    # and times them at its byte time: a 9-byte P? takes 9 × 10/115200 s, not 9.4 ms
    spans = [e.t_end - e.t for e in commands if len(e.raw) == 9]
    assert spans and statistics.median(spans) == pytest.approx(9 * BT_115200, rel=0.05)


def test_no_follow_rate_keeps_listening_at_the_first_rate():
    events, _warnings = tap_for(SECONDS, follow=False)
    assert RATE not in [e.kind for e in events]
    c7 = next(e for e in events if e.kind == COMMAND and e.payload == b"C7")
    later = events[events.index(c7) + 1:]
    # the link runs at 115200 and the tap at 9600: nothing after it decodes as the conversation
    assert not [e for e in later if e.kind == COMMAND and e.status == OK]
    assert [e for e in later if e.kind == NOISE or e.checksum_ok is False]


def test_the_recording_of_a_rate_change_decodes_the_same(tmp_path):
    rec = str(tmp_path / "rate.mcap")
    live, _ = tap_for(SECONDS, follow=True, record=rec)
    decoded = list(analyzer.open(rec))
    assert [(e.number, e.kind, e.status, e.command) for e in decoded] == \
        [(e.number, e.kind, e.status, e.command) for e in live]
    rate, _ = after_change(decoded)
    assert rate.fields["baud"] == 115200


def test_sim_behind_socat_has_one_clock(tmp_path, socat_bin):
    """socat -x -v between the controller and the gimbal, answering in 0.3 ms at
    115200: no skew is invented, no latency is negative, nothing comes before
    the command it answers."""
    ctl, dev, log = tmp_path / "ctl", tmp_path / "dev", tmp_path / "tap.log"
    with open(log, "wb") as err:
        proc = subprocess.Popen([socat_bin, "-x", "-v", f"PTY,link={ctl},raw,echo=0",
                                 f"PTY,link={dev},raw,echo=0"], stderr=err)
    try:
        end = time.monotonic() + 30
        while not (ctl.exists() and dev.exists()):
            assert time.monotonic() < end and proc.poll() is None, "socat did not start"
            time.sleep(0.01)
        bus = GimbalBus(str(dev), [GimbalModel((1, 1, 1), answer_delay=0.0003)], baud=115200)
        controller = SimController(str(ctl), [(1, 1, 1)], baud=115200, seed=2)
        bus.start()
        controller.start()
        end = time.monotonic() + 60
        while controller.sent < 60:
            assert time.monotonic() < end, "the controller did not get going"
            time.sleep(0.05)
        controller.stop()
        bus.stop()
        controller.join(5)
        bus.join(5)
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(10)
    out = subprocess.run([sys.executable, "-m", "analyzer", "decode", str(log), "--baud", "115200",
                          "--format", "jsonl"], capture_output=True, text=True, cwd=ROOT, timeout=120, check=False)
    assert out.returncode == 0, out.stderr
    assert "ahead of line A" not in out.stderr
    import json
    events = [json.loads(line) for line in out.stdout.splitlines()]
    by_number = {e["number"]: e for e in events}
    acks = [e for e in events if e["kind"] == ACK and e["request"] is not None]
    assert len(acks) >= 50
    for e in events:
        if e["request"] is not None and e["kind"] in (ACK, RESULT):
            cmd = by_number[e["request"]]
            assert e["number"] > cmd["number"] and e["t"] >= cmd["t_end"], (cmd, e)
            assert e["latency"] >= 0
    # answered in 0.3 ms behind a pty: ACK latencies stay well under the 38-43 ms a false
    # skew made (20 ms leaves room for a busy machine's late reads, not for that skew)
    assert statistics.median(a["latency"] for a in acks) < 0.02
    results = [e for e in events if e["kind"] == RESULT and e["request"] is not None]
    for r in results:   # a result never before its own ACK on the same line
        ack = next(a for a in acks if a["request"] == r["request"])
        assert r["t"] >= ack["t_end"] and r["number"] > ack["number"]


def test_parts_after_a_rate_change_start_at_the_new_rate(tmp_path):
    import glob

    from mcap.reader import make_reader

    live, _ = tap_for(SECONDS, follow=True, record=str(tmp_path / "rec.mcap"), rotate_bytes=20_000)
    parts = sorted(glob.glob(str(tmp_path / "rec-*.mcap")))
    assert len(parts) >= 3

    def baud(path):
        with open(path, "rb") as f:
            return {m.name: m.metadata for m in make_reader(f).iter_metadata()}["gimbalscope"]["baud"]

    rates = [baud(p) for p in parts]
    assert rates[0] == "9600" and rates[-1] == "115200"
    assert rates == sorted(rates, key=int)   # once switched, every later part says so
    # a part after the switch decoded on its own reads at 115200: the conversation, no
    # garbage (the last part that holds a whole exchange: under load the tap may
    # have rotated just before it stopped, leaving a last part of a few bytes)
    for part in reversed([p for p, rate in zip(parts, rates) if rate == "115200"]):
        alone = list(analyzer.open(part))
        first = next((k for k, e in enumerate(alone) if e.kind == COMMAND and e.status == OK), None)
        if first is not None:
            break
    assert first is not None, "no part after the switch holds a whole exchange"
    if part != parts[-1]:   # passed over only when it is that short, not when it reads as garbage
        assert len(list(analyzer.open(parts[-1]))) < 10
    # (a part may begin inside a frame the previous one holds the start of)
    assert not [e for e in alone[first:] if e.kind == NOISE or e.checksum_ok is False]
    # and all of them together give what the tap gave
    together = list(analyzer.open(*reversed(parts)))
    assert [(e.number, e.kind, e.status) for e in together] == [(e.number, e.kind, e.status) for e in live]
