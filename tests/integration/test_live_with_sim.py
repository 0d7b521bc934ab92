"""Trying ``live`` with the simulator, as the README says, on real pseudo-terminals:
the recipe's commands are read from the README (and must be the same in
docs/simulator.md and docs/live.md), run as written, and ``live`` must show the
simulated controller's commands paired with the simulated gimbal's ACKs and
results; Ctrl-C (SIGINT) ends both cleanly. Also the simulated controller on a port
of its own (``sim --controller PORT``, beside the gimbals' ``PORT`` in one process),
and what ``sim`` refuses.

Nothing waits for a time: every wait is for output, with a generous timeout."""

from __future__ import annotations

import os
import re
import select
import shlex
import threading
import tty

from dissectors import Deframer
from dissectors.event import ACK, COMMAND, RESULT
from tests.child import Child, wait_for
from tests.conftest import ROOT, frame, run_cli

RECIPE_PAGES = ("README.md", os.path.join("docs", "simulator.md"), os.path.join("docs", "live.md"))
EXAMPLE_PTY = re.compile(r"/dev/pts/[0-9]+")
# a line of live's text output: number, time, line, arrow, device, kind, the rest
ROW = re.compile(r"^\s*(?P<number>\d+)\s+\S+\s+(?P<line>[AB])\s+[→←]\s+(?P<device>\S+)\s+"
                 r"(?P<kind>command|ack|nak|nic|result)\s+(?P<rest>.*)$")


def recipe(page: str) -> list[list[str]]:
    """The commands of a page's recipe: the first plain code block with a
    ``gimbalscope sim`` line and a ``gimbalscope live`` line, comments dropped."""
    with open(os.path.join(ROOT, page), encoding="utf-8") as f:
        text = f.read()
    for block in re.findall(r"^```\n(.*?)^```", text, re.DOTALL | re.MULTILINE):
        commands = [shlex.split(line, comments=True) for line in block.splitlines()]
        commands = [c for c in commands if c]
        if any(c[:2] == ["gimbalscope", "sim"] for c in commands) and \
                any(c[:2] == ["gimbalscope", "live"] for c in commands):
            return commands
    raise AssertionError(f"{page}: no recipe block (gimbalscope sim, then gimbalscope live)")


def masked(argv: list[str]) -> list[str]:
    """A command with its pseudo-terminal names (which change each run) left out."""
    return [EXAMPLE_PTY.sub("PTY", a) for a in argv]


def test_the_recipe_is_the_same_on_every_page():
    readme = recipe("README.md")
    assert [c[:2] for c in readme] == [["gimbalscope", "sim"], ["gimbalscope", "live"]]
    for page in RECIPE_PAGES[1:]:
        assert recipe(page) == readme, page


def paired(rows: list[dict]) -> list[int]:
    """Numbers of the P? commands that went well and whose ACK and decoded result
    both name them (``[#N ...]``): the request/response pairs live formed."""
    acks = {r["to"] for r in rows if r["kind"] == "ack"}
    results = {r["to"] for r in rows if r["kind"] == "result"
               and re.match(r"P\?\s+at az [+-]\d+\.\d\d° el [+-]\d+\.\d\d°", r["rest"])}
    return [r["number"] for r in rows if r["kind"] == "command" and r["rest"].startswith("P? ")
            and r["rest"].endswith("[ok]") and r["number"] in acks & results]


def rows_of(lines: list[str]) -> list[dict]:
    rows = []
    for line in list(lines):
        m = ROW.match(line.rstrip("\n"))
        if m:
            row = m.groupdict()
            row["number"] = int(row["number"])
            to = re.search(r"\[#(\d+) ", row["rest"])
            row["to"] = int(to.group(1)) if to else None
            rows.append(row)
    return rows


def test_live_shows_the_simulators_conversation_as_the_readme_says():
    (sim_argv, live_argv) = recipe("README.md")
    sim = Child(*sim_argv[1:])
    tap = None
    try:
        wait_for(lambda: sim.out or sim.proc.poll() is not None, "sim to print the live command")
        printed = shlex.split(sim.out[0])
        # what it prints is the README's second command, with this run's ports
        assert masked(printed) == masked(live_argv), (printed, live_argv)
        assert sim.said("tap line A (controller→device) and line B (device→controller)")
        tap = Child(*printed[1:])   # as typed, piped: it prints events
        tap.wait_listening()
        wait_for(lambda: len(paired(rows_of(tap.out))) >= 3, "three P? commands with their ACK and result")
        rows = rows_of(tap.out)
        assert {r["line"] for r in rows if r["kind"] == "command"} == {"A"}
        assert {r["line"] for r in rows if r["kind"] != "command"} == {"B"}
        assert {r["device"] for r in rows if r["kind"] == "command"} == {"1.1.1"}
        code, _, err = tap.stop()
        assert code == 0 and "Traceback" not in err, err
        code, _out, err = sim.stop()
        assert code == 0 and "Traceback" not in err, err
    finally:
        for child in (tap, sim):
            if child is not None:
                child.kill()


class Wire(threading.Thread):
    """A cable between two pseudo-terminals' master ends, keeping what each way
    carried: line A from the controller's end, line B from the gimbals'."""

    def __init__(self, controller: int, gimbals: int) -> None:
        super().__init__(daemon=True, name="test-wire")
        self.ends = {controller: (gimbals, "A"), gimbals: (controller, "B")}
        self.carried = {"A": bytearray(), "B": bytearray()}
        self.halt = threading.Event()

    def run(self) -> None:
        while not self.halt.is_set():
            ready, _, _ = select.select(list(self.ends), [], [], 0.05)
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue
                peer, line = self.ends[fd]
                os.write(peer, data)
                self.carried[line] += data

    def events(self, line: str) -> list:
        deframer = Deframer(line)
        return deframer.feed(bytes(self.carried[line])) + deframer.finish()


def pty() -> tuple[int, int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def test_one_process_runs_the_gimbals_and_a_controller_on_two_ports():
    (mg, sg, gimbal_port), (mc, sc, controller_port) = pty(), pty()
    wire = Wire(mc, mg)
    wire.start()
    sim = Child("sim", gimbal_port, "--controller", controller_port, "--address", "1.1.2")
    try:
        sim.wait_said("(Ctrl-C stops)", "sim to start")
        assert sim.err[0] == (f"gimbalscope: sim: gimbal 1.1.2 answering on {gimbal_port}, a controller driving it "
                              f"on {controller_port} at 9600 baud (Ctrl-C stops)\n")
        wait_for(lambda: sum(e.kind == ACK for e in wire.events("B")) >= 6, "six ACKs on line B")
        code, out, err = sim.stop()
        assert code == 0 and out == "" and "Traceback" not in err, err
    finally:
        sim.kill()
        wire.halt.set()
        wire.join(5)
        for fd in (mg, sg, mc, sc):
            os.close(fd)
    commands = [e for e in wire.events("A") if e.kind == COMMAND]
    # the controller's first command: a position query to the gimbal it was given, from group 0
    assert wire.carried["A"].startswith(frame((1, 1, 2), 0, "P?"))
    assert b"P?" in {bytes(e.payload) for e in commands} and {tuple(e.dst) for e in commands} == {(1, 1, 2)}
    # the gimbal answers it: ACK, then the result to group 0 from device 1.1.2 (Table 3),
    # at the home position
    assert wire.carried["B"].startswith(b"\x06" + frame((0, 1, 2), 1, "00000000"))
    assert any(e.kind == RESULT for e in wire.events("B"))


def test_a_controller_alone_says_what_it_drives_and_retransmits_when_nothing_answers():
    master, slave, port = pty()
    sim = Child("sim", "--controller", port)
    try:
        sim.wait_said("(Ctrl-C stops)", "sim to start")
        assert sim.err[0] == (f"gimbalscope: sim: a controller driving gimbal 1.1.1 on {port} at 9600 baud "
                              "(Ctrl-C stops)\n")
        query = frame((1, 1, 1), 0, "P?")
        got = bytearray()

        def read() -> bool:
            if select.select([master], [], [], 0.05)[0]:
                got.extend(os.read(master, 4096))
            return len(got) >= 2 * len(query)

        # nobody answers: the same command again after the timeout
        wait_for(read, "the command and its retransmission")
        assert bytes(got[:2 * len(query)]) == query * 2
        code, out, err = sim.stop()
        assert code == 0 and out == "" and "Traceback" not in err, err
    finally:
        sim.kill()
        os.close(master)
        os.close(slave)


def test_sim_refuses_in_one_line():
    for args, fragment in ((["sim"], "nothing to simulate: give PORT (gimbals), --controller PORT, or --pty"),
                           (["sim", "--pty", "/dev/ttyS0"], "--pty makes its own ports"),
                           (["sim", "--controller", "/dev/ttyNOPE9"], "/dev/ttyNOPE9: no such serial port"),
                           (["sim", "/dev/ttyNOPE8", "--controller", "/dev/ttyNOPE9"], "/dev/ttyNOPE8: no such"),
                           (["sim", "--controller", "/dev/ttyNOPE9", "--drop-acks", "0.1"],
                            "--drop-acks is a fault of the simulated gimbals")):
        out = run_cli(*args)
        lines = out.stderr.strip().splitlines()
        assert out.returncode == 2 and len(lines) == 1 and fragment in lines[0], (args, out.stderr)
