"""``send`` and ``probe`` against gimbals on pseudo-terminals: a responder written
here from the spec's tables alone (Table 1's frame, Table 6's identification,
READING's layout of it), and the simulator behind a virtual link whose rates
are real (a listener at another rate reads garbage).

Expected bytes are computed by hand: ``P`` to 10.00°, −5.00° is ``P03E8FE0C``
(Table 15: hundredths, signed 16-bit: 1000 = 0x03E8, −500 = 0xFE0C).
"""

import json
import os
import select
import threading
import time
import tty
from contextlib import contextmanager

import pytest

from analyzer.simulation.bus import GimbalBus
from analyzer.simulation.gimbal import Faults, GimbalModel
from analyzer.simulation.link import VirtualLink
from tests.child import PATIENCE, Child
from tests.conftest import frame, run_cli

ACK, NAK, NIC = b"\x06", b"\x15", b"\x3f"
IDENTITY = "03" + "19" + "PAN-TILT-X".ljust(20) + "A1234".ljust(20)   # Table 6: id, revision, name, serial


def frames_in(data: bytes) -> list[bytes]:
    """The whole frames in ``data`` (Table 1: F8, 3 address bytes, source, length, payload, checksum)."""
    out, k = [], 0
    while k < len(data):
        if data[k] != 0xF8 or k + 6 > len(data):
            k += 1
            continue
        end = k + 7 + (data[k + 5] or 256)
        out.append(data[k:end])
        k = end
    return out


class Responder:
    """A gimbal at ``address`` on a pty, from the tables: each command frame gets
    the next of ``answers`` (bytes, or a callable of the frame), else silence."""

    def __init__(self, answers=()) -> None:
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.port = os.ttyname(slave)
        self._slave = slave
        self.answers = list(answers)
        self.heard = b""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        pending = b""
        while not self._stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            self.heard += data
            pending += data
            found = frames_in(pending)
            if found and sum(map(len, found)) <= len(pending):
                pending = b""
                for f in found:
                    if self.answers:
                        answer = self.answers.pop(0)
                        os.write(self.master, answer(f) if callable(answer) else answer)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        os.close(self.master)
        os.close(self._slave)


@contextmanager
def responder(*answers):
    r = Responder(answers)
    try:
        yield r
    finally:
        r.close()


@contextmanager
def simulated(baud: int, *addresses, faults: Faults | None = None, wrong_baud: int | None = None):
    """The simulator's gimbals behind a virtual link at ``baud`` (with the gimbals'
    ``faults``; answering at ``wrong_baud``): the controller's port."""
    link = VirtualLink(baud=baud)
    gimbals = [GimbalModel(a, serial=f"SN{k:04d}", faults=faults or Faults()) for k, a in enumerate(addresses, 1)]
    bus = GimbalBus(link.device_port, gimbals, baud, wrong_baud=wrong_baud)
    bus.start()
    try:
        yield link.controller_port
    finally:
        bus.stop()
        bus.join(2)
        link.close()


def result_to_controller(device, payload: str) -> bytes:
    """A result frame (Table 3): groups swapped (to group 0), port and device kept, source the gimbal's group."""
    g, p, d = device
    return frame((0, p, d), g, payload)


def jsonl(text: str) -> list[dict]:
    return [json.loads(line) for line in text.splitlines() if line.strip()]


# ------------------------------------------------------------------ send
def test_send_asks_and_prints_the_answer_decoded():
    with responder(ACK + result_to_controller((1, 1, 3), IDENTITY)) as gimbal:
        out = run_cli("send", gimbal.port, "D?", "--to", "1.1.3", "--format", "json")
        assert gimbal.heard == frame((1, 1, 3), 0, "D?")
    assert out.returncode == 0, out.stderr
    events = jsonl(out.stdout)
    assert [(e["kind"], e["command"]) for e in events] == [("command", "D?"), ("ack", None), ("result", "D?")]
    assert events[0]["status"] == "ok" and events[1]["request"] == events[2]["request"] == 1
    assert events[2]["fields"] == {"device_id": "03", "revision": "19", "name": "PAN-TILT-X", "serial": "A1234"}
    assert "ACK in" in out.stderr and "and its result" in out.stderr


def test_send_encodes_named_fields_in_their_units():
    with responder(ACK) as gimbal:
        out = run_cli("send", gimbal.port, "P", "--to", "1.1.3", "azimuth_deg=10", "elevation_deg=-5",
                      "--allow-motion")
        assert gimbal.heard == frame((1, 1, 3), 0, "P03E8FE0C")
    assert out.returncode == 0, out.stderr
    assert "go to az +10.00° el -5.00°" in out.stdout and "[ok]" in out.stdout


@pytest.mark.parametrize(("answers", "retries", "code", "sent", "said"), [
    ((NAK,), 0, 1, 1, "NAK"),
    ((NAK, NAK, ACK), 2, 0, 3, "ACK"),
    ((NAK, NAK, ACK), 1, 1, 2, "NAK"),
    ((ACK + NIC,), 0, 1, 1, "NIC"),
    ((), 1, 1, 2, "no answer"),
])
def test_send_exit_status_and_retries(answers, retries, code, sent, said):
    with responder(*answers) as gimbal:
        out = run_cli("send", gimbal.port, "HS", "--to", "1.1.3", "--retries", retries)
        heard = frames_in(gimbal.heard)
    assert out.returncode == code, out.stderr
    assert heard == [frame((1, 1, 3), 0, "HS")] * sent
    assert said in out.stderr.splitlines()[-1]
    if said == "no answer":
        assert "power" in out.stderr and "wiring" in out.stderr and "rate" in out.stderr and "address" in out.stderr


@pytest.mark.parametrize(("args", "message"), [
    (["P", "--to", "1.1.3", "azimuth_deg=10", "elevation_deg=0"],
     "P (Go to pan-tilt position) moves the gimbal: it would go to az +10.00° el +0.00°; add --allow-motion"),
    (["#NN", "--to", "255.255.255", "new_address=4"], "add --allow-config"),
    (["C", "--to", "1.1.3", "rate_code=4", "--allow-motion"],
     "changes the gimbal's address, rate, settings or outputs: it would set data rate 19200 bps"),
    (["QQ", "--to", "1.1.3"], "unknown command 'QQ'; the table's codes: #NN, AW, B?, C, D?,"),
    (["p?", "--to", "1.1.3"], "did you mean 'P?'?"),
    (["P", "--to", "1.1.3", "azimuth=1", "elevation_deg=0", "--allow-motion"], "did you mean azimuth_deg?"),
    (["P", "--to", "1.1.3", "--allow-motion"], "needs azimuth_deg [deg], elevation_deg [deg]"),
    (["P", "--to", "1.1.3", "azimuth_deg=400", "elevation_deg=0", "--allow-motion"], "-327.68 to 327.67"),
    (["D?"], "--to G.P.D"),
    (["P", "--to", "1.1.3", "azimuth_deg", "--allow-motion"], "'azimuth_deg': fields are given as FIELD=VALUE"),
    (["--raw", "F8 01 01 03 00 02 5A 5A 69"], "no command of the table"),
    (["--raw", "zz"], "hex bytes"),
])
def test_send_refuses_before_writing_anything(args, message):
    with responder() as gimbal:
        out = run_cli("send", gimbal.port, *args)
        time.sleep(0.2)
        assert gimbal.heard == b""
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gimbalscope: error:") and message in lines[0], out.stderr


def test_send_raw_sends_the_bytes_as_given_and_shows_a_bad_checksum():
    bad = frame((1, 1, 3), 0, "D?")[:-1] + b"\x00"
    with responder(NAK) as gimbal:
        out = run_cli("send", gimbal.port, "--raw", bad.hex(" "), "--allow-motion", "--allow-config")
        assert gimbal.heard == bad
    assert out.returncode == 1
    assert "bad checksum" in out.stdout


def test_send_records_what_it_printed(tmp_path):
    rec = tmp_path / "talk.mcap"
    with responder(ACK + result_to_controller((1, 1, 3), IDENTITY)) as gimbal:
        out = run_cli("send", gimbal.port, "D?", "--to", "1.1.3", "--format", "jsonl", "--record", rec)
    assert out.returncode == 0, out.stderr
    decoded = run_cli("decode", rec, "--format", "jsonl")
    assert decoded.returncode == 0, decoded.stderr
    strip = ("t", "t_end", "latency")   # the recording's times are its own clock's, to the nanosecond
    assert [{k: v for k, v in e.items() if k not in strip} for e in jsonl(decoded.stdout)] == \
        [{k: v for k, v in e.items() if k not in strip} for e in jsonl(out.stdout)]


def test_a_rate_change_switches_our_side_after_the_ack():
    with simulated(9600, (1, 1, 3)) as port:
        out = run_cli("send", port, "C", "rate_code=4", "--to", "1.1.3", "--allow-config")
        assert out.returncode == 0, out.stderr
        assert "link rate 9600 → 19200 bps" in out.stdout
        # the gimbal switched too: asked at the new rate it answers, at the old one it cannot
        assert run_cli("send", port, "D?", "--to", "1.1.3", "--baud", "19200").returncode == 0
        assert run_cli("send", port, "D?", "--to", "1.1.3", "--baud", "9600", "--ack-timeout", "0.3").returncode == 1


def test_the_simulators_faults_read_as_a_controller_would_see_them():
    # dropped ACKs: every try goes unanswered, and send says what to check
    with simulated(9600, (1, 1, 3), faults=Faults(drop_ack=1.0)) as port:
        out = run_cli("send", port, "D?", "--to", "1.1.3", "--retries", "2", "--format", "jsonl")
    assert out.returncode == 1 and "no answer (try 3 of 3)" in out.stderr
    assert [e["status"] for e in jsonl(out.stdout) if e["kind"] == "command"] == ["no_ack"] * 3
    # an answer 0.8 s late: past the protocol's 0.5 s, in time for a patient controller
    with simulated(9600, (1, 1, 3), faults=Faults(late=1.0)) as port:
        assert run_cli("send", port, "HS", "--to", "1.1.3").returncode == 1
        assert run_cli("send", port, "HS", "--to", "1.1.3", "--ack-timeout", "3").returncode == 0


def test_probe_of_a_gimbal_at_a_wrong_rate_says_garbled():
    # the line runs at 9600 and the gimbal answers at 19200: what comes back is no answer
    with simulated(9600, (1, 1, 3), wrong_baud=19200) as port:
        out = run_cli("probe", port, "--addresses", "1.1.3", "--baud", "9600", "--format", "json")
    assert out.returncode == 1
    report = json.loads(out.stdout)
    assert report["devices"] == [] and {"address": "1.1.3", "baud": 9600} in report["garbled"]
    assert "something garbled came back: another rate" in out.stderr


# ------------------------------------------------------------------ probe
def test_probe_finds_the_simulated_gimbals_and_their_rate():
    with simulated(19200, (1, 1, 3), (1, 1, 5)) as port:
        # the protocol's own ACK timeout: a loaded machine still answers well within it
        out = run_cli("probe", port, "--addresses", "1.1.3-1.1.5", "--format", "json", timeout=PATIENCE * 3)
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    assert report["rates_tried"] == [9600, 19200, 38400, 57600, 115200, 4800, 2400, 1200]
    devices = {(d["address"], d["baud"]): d for d in report["devices"]}
    assert set(devices) == {("1.1.3", 19200), ("1.1.5", 19200)}
    assert devices["1.1.3", 19200]["identity"]["serial"] == "SN0001"
    assert devices["1.1.5", 19200]["answer"] == "result" and devices["1.1.5", 19200]["latency_ms"] > 0


def test_probe_of_a_silent_line_says_what_to_check():
    with simulated(19200, (1, 1, 3)) as port:
        out = run_cli("probe", port, "--addresses", "1.1.1-2", "--baud", "9600", "--ack-timeout", "0.25")
    assert out.returncode == 1
    assert "nothing answered" in out.stderr and "power" in out.stderr and "rate" in out.stderr


def test_probe_table_names_who_answered():
    with responder(*([ACK + result_to_controller((1, 1, 2), IDENTITY)] * 3)) as gimbal:
        out = run_cli("probe", gimbal.port, "--addresses", "1.1.2", "--baud", "9600", "--listen", "0.2")
    assert out.returncode == 0, out.stderr
    row = next(line for line in out.stdout.splitlines() if line.strip().startswith("1.1.2 "))
    assert "9600" in row and "result" in row and "PAN-TILT-X rev 19 s/n A1234" in row


def test_probe_stops_when_a_controller_is_talking():
    with responder() as line:
        talking = threading.Event()

        def chatter():
            while not talking.is_set():
                os.write(line.master, frame((1, 1, 1), 0, "P?"))
                time.sleep(0.05)

        thread = threading.Thread(target=chatter, daemon=True)
        thread.start()
        try:
            out = run_cli("probe", line.port, "--listen", "0.5")
        finally:
            talking.set()
            thread.join(2)
    assert out.returncode == 2
    assert "a controller is talking on this line" in out.stderr and "--force" in out.stderr


# ------------------------------------------------------------------ the tap stays read-only
@pytest.mark.parametrize(("args", "message"), [
    (["/dev/null", "/dev/zero", "--talk"], "--talk takes one port"),
    (["--samples", "-", "--samplerate", "1MHz", "--talk"], "--talk takes one port"),
    (["/dev/null", "--allow-config"], "--allow-motion and --allow-config go with --talk (a tap never sends)"),
    (["/dev/null", "--talk", "--no-tui"], "--talk sends from the TUI's : prompt: it needs the TUI"),
])
def test_live_talk_mistakes_are_one_line(args, message):
    out = run_cli("live", *args, input="")
    lines = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(lines) == 1 and lines[0].startswith("gimbalscope: error:")
    assert message in lines[0]


def test_a_live_tap_never_writes():
    master, slave = os.openpty()
    tty.setraw(slave)
    tap = Child("live", os.ttyname(slave), "--no-tui", "--format", "jsonl")
    try:
        tap.wait_listening()
        os.write(master, frame((1, 1, 1), 0, "D?") + ACK)
        end, written = time.monotonic() + 2.0, b""
        while time.monotonic() < end:
            ready, _, _ = select.select([master], [], [], 0.1)
            if ready:
                written += os.read(master, 4096)
        code, stdout, _err = tap.stop()
    finally:
        tap.kill()
        os.close(master)
        os.close(slave)
    assert written == b""
    assert code == 0 and '"command":"D?"' in stdout
