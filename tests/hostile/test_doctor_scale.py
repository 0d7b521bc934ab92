"""The wiring doctor on long captures without time (raw dumps): a failed command
the controller moved on from expires by command count, since there is no clock to
expire it by, and what the doctor keeps stays bounded however many events, noise
runs and garbled addresses it is fed."""

from __future__ import annotations

import gc
import json
import tracemalloc

import analyzer
from analyzer.analysis.doctor import RETRY_WINDOW, WiringDoctor
from analyzer.analysis.findings import CONTROLLER_NO_RETRY, DEVICE_MAP
from tests.conftest import frame, run_cli


def write_unanswered_every_other(path, commands: int = 40) -> list[int]:
    """A single-line dump: P? to 1.1.1 answered (ACK, result), then a command to
    1.1.2 that nothing answers and the controller never sends again. Returns the
    indexes (among commands) of the unanswered ones."""
    data = b""
    unanswered = []
    for k in range(commands):
        if k % 2 == 0:
            data += frame((1, 1, 1), 0, "P?") + b"\x06" + frame((0, 1, 1), 1, "0FA0FC18")
        else:
            # a different command each time: none repeats the one before (no retransmission)
            data += frame((1, 1, 2), 0, f"P{k:02d}")
            unanswered.append(k)
    path.write_bytes(data)
    return unanswered


def test_without_time_a_failed_command_expires_after_a_window_of_commands(tmp_path):
    bus = tmp_path / "bus.bin"
    unanswered = write_unanswered_every_other(bus)
    r = run_cli("doctor", bus, "--format", "json")
    assert r.returncode == 1, r.stderr      # a warning (controller_no_retry), no error
    report = json.loads(r.stdout)
    assert report["seconds"] is None and report["events"] == 80
    found = {f["code"]: f for f in report["findings"]}
    no_retry = found[CONTROLLER_NO_RETRY]
    # decided once RETRY_WINDOW more commands came; the last ones are still open
    decided = [k for k in unanswered if 40 - (k + 1) > RETRY_WINDOW]
    assert no_retry["detail"] == f"{len(decided)} commands NAK'd or unanswered were not sent again"
    assert no_retry["after_events"] is not None and no_retry["after"] is None


def doctor_retains(events) -> float:
    """MB the doctor still holds after being fed ``events`` (already in memory)."""
    gc.collect()
    tracemalloc.start()
    try:
        doctor = WiringDoctor(("AB",))
        for ev in events:
            doctor.add(ev)
        doctor.findings()
        gc.collect()
        held, _peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return held / 1e6


def test_a_long_garbled_capture_leaves_the_doctor_flat(tmp_path):
    """20 000 answered commands to as many addresses (bit errors in headers name
    thousands), each followed by a noise run: the doctor keeps a bounded device
    map and a bounded error window, not one entry per event."""
    bus = tmp_path / "garbled.bin"
    parts = []
    for k in range(20_000):
        dst = (1 + k // 10_000, (k // 100) % 100 + 1, k % 100 + 1)
        parts.append(frame(dst, 0, "HO") + b"\x06" + b"\x00\x00")
    bus.write_bytes(b"".join(parts))
    events = list(analyzer.open(str(bus)))
    assert len(events) == 60_000 and sum(e.kind == "noise" for e in events) == 20_000
    assert doctor_retains(events) < 3.0


def test_the_device_map_says_when_addresses_are_past_counting(tmp_path):
    bus = tmp_path / "garbled.bin"
    bus.write_bytes(b"".join(frame((1, k // 100 + 1, k % 100 + 1), 0, "HO") + b"\x06" for k in range(600)))
    doctor = WiringDoctor(("AB",))
    for ev in analyzer.open(str(bus)):
        doctor.add(ev)
    device_map = next(f for f in doctor.findings() if f.code == DEVICE_MAP)
    assert device_map.title.endswith("and more (past 256)")
    assert "344 commands to further addresses, not tracked one by one" in device_map.detail
