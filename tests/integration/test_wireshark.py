"""Wireshark interop, read back by real tshark (Debian's package; .ci/run
installs it): pcapng export, the generated Lua dissector, the extcap live
capture and ``gimbalscope wireshark install``."""

import json
import math
import os
import shutil
import subprocess
import sys
import time

import pytest

from tests.conftest import BUS, CTL, DEV, ROOT, SOCAT_LOG, frame, run_cli

SAMPLES = {"socat log": [SOCAT_LOG], "two raw dumps": [CTL, DEV], "single-line dump": [BUS]}
PATIENCE = 60.0


@pytest.fixture(scope="module")
def tshark():
    path = shutil.which("tshark")
    assert path, "tshark is not installed: .ci/run installs Debian's tshark package"
    return path


@pytest.fixture(scope="module")
def plugin(tmp_path_factory, tshark):
    """The dissector as ``wireshark install --dir`` writes it."""
    d = tmp_path_factory.mktemp("plugin")
    r = run_cli("wireshark", "install", "--dir", d)
    assert r.returncode == 0, r.stderr
    lua = d / "gimbal.lua"
    assert lua.exists() and os.access(d / "gimbalscope-extcap", os.X_OK)
    return lua


def run_tshark(tshark, plugin, *args, env=None):
    r = subprocess.run([tshark, "-X", f"lua_script:{plugin}", *map(str, args)], capture_output=True,
                       text=True, timeout=PATIENCE, env=env, check=False)
    assert r.returncode == 0, r.stderr
    assert "Lua" not in r.stderr or "error" not in r.stderr.lower(), r.stderr
    return r.stdout


def fields(tshark, plugin, path, names, *extra):
    """One dict per packet of ``names`` (several values of one field joined by '|')."""
    args = ["-r", path, "-T", "fields", "-E", "occurrence=a", "-E", "aggregator=|", *extra]
    for n in names:
        args += ["-e", n]
    out = run_tshark(tshark, plugin, *args)
    return [dict(zip(names, line.split("\t"))) for line in out.splitlines()]


def jsonl(*inputs, args=()):
    r = run_cli("decode", *inputs, "--format", "jsonl", *args)
    assert r.returncode == 0, r.stderr
    return [json.loads(line) for line in r.stdout.splitlines()]


def export(tmp_path, *inputs, name="out.pcapng"):
    out = tmp_path / name
    r = run_cli("export", *inputs, "-o", out)
    assert r.returncode == 0, r.stderr
    return out


def shown(value) -> str:
    """A JSON value as tshark -T fields prints it (booleans 1/0, lists joined)."""
    if isinstance(value, list):
        return "|".join(shown(v) for v in value)
    if value is True:
        return "1"
    if value is False:
        return "0"
    return str(value)


def same(want, got: str) -> bool:
    if want is None:
        return got == ""
    if isinstance(want, float):
        return got != "" and math.isclose(float(got), want, abs_tol=1e-9)
    return shown(want) == got


def field_names():
    from analyzer.wireshark.lua import abbr
    from dissectors.commands import field_types
    return {name: abbr(name) for name in field_types()}


def assert_agrees(tshark, plugin, pcap, events):
    """Every event's kind, command, status, device and every decoded value (the
    dissector decodes them from the wire bytes) as tshark shows them."""
    names = field_names()
    cols = ["gimbal.number", "gimbal.kind", "gimbal.command", "gimbal.status", "gimbal.device",
            *names.values()]
    rows = fields(tshark, plugin, pcap, cols)
    events = [e for e in events if e["kind"] != "rate"]   # no bytes on the wire, no packet
    assert len(rows) == len(events)
    wrong = []
    for e, r in zip(events, rows):
        for key, col in (("number", "gimbal.number"), ("kind", "gimbal.kind"), ("command", "gimbal.command"),
                         ("status", "gimbal.status"), ("device", "gimbal.device")):
            if not same(e[key], r[col]):
                wrong.append((e["number"], key, e[key], r[col]))
        for name, col in names.items():
            if not same(e["fields"].get(name), r[col]):
                wrong.append((e["number"], name, e["fields"].get(name), r[col]))
    assert wrong == []


# ---------------------------------------------------------------- export and the dissector
@pytest.mark.parametrize("sample", sorted(SAMPLES))
def test_tshark_agrees_with_json_lines_on_every_sample_capture(tmp_path, tshark, plugin, sample):
    inputs = SAMPLES[sample]
    pcap = export(tmp_path, "+".join(inputs))
    events = jsonl(*inputs)
    # the four columns the issue names, as the user would ask for them
    rows = fields(tshark, plugin, pcap, ["gimbal.kind", "gimbal.command", "gimbal.status", "gimbal.azimuth_deg"])
    wire = [e for e in events if e["kind"] != "rate"]
    assert [r["gimbal.kind"] for r in rows] == [e["kind"] for e in wire]
    assert [r["gimbal.command"] for r in rows] == [e["command"] or "" for e in wire]
    assert [r["gimbal.status"] for r in rows] == [e["status"] or "" for e in wire]
    az = [(r["gimbal.azimuth_deg"], e["fields"].get("azimuth_deg")) for r, e in zip(rows, wire)]
    assert all(same(want, got) for got, want in az)
    assert sum(1 for got, want in az if want is not None) > 10
    # and everything else the dissector decodes
    assert_agrees(tshark, plugin, pcap, events)


def sample_payload(layout) -> bytes:
    """Characters that fit ``layout``: each field filled by the shape of its
    characters (hex, decimal, text, one character of a choice)."""
    out = b""
    for part in layout.parts:
        if isinstance(part, bytes):
            out += part
            continue
        f = part
        rx = f.regex
        if f.codec == "choice":
            out += f.choices[-1][0]
        elif f.codec == "decimal":
            out += b"1"
        elif rx == rb"[A-Fa-f]":
            out += b"C"
        elif f.codec == "hex":
            n = int(rx.split(b"{")[1].split(b"}")[0].split(b",")[-1] or 1)
            out += (b"F38C" * 3)[:n] if f.signed else (b"1A2B3C" * 2)[:n]
        else:   # text: a fixed width, or the rest of the payload
            head = rx.split(b"{")[1].split(b"}")[0]
            n = int(head.split(b",")[0]) if b"," not in head else max(int(head.split(b",")[0]), 5)
            out += (b" ab c" * 10)[:n] if f.strip else (b"xy z!" * 10)[:n]
    return out


def test_every_layout_of_the_command_table_decodes_alike(tmp_path, tshark, plugin):
    """A conversation with every command of the table and every result layout:
    the Lua decoders (codecs, patterns, derived values) and Python's agree."""
    from dissectors.commands import COMMANDS
    bus = b""   # a single-line tap: both directions in wire order
    for c in COMMANDS:
        params = sample_payload(c.layout)
        for layout in c.result or (None,):
            bus += frame((1, 1, 3), 0, params) + b"\x06"
            if layout is not None:   # the answer goes to the controller's group 0, from group 1 (Table 3)
                bus += frame((0, 1, 3), 1, sample_payload(layout))
    (tmp_path / "bus.bin").write_bytes(bus)
    events = jsonl(tmp_path / "bus.bin")
    layouts = sum(1 for c in COMMANDS if c.layout.fields) + sum(1 for c in COMMANDS for r in c.result if r.fields)
    decoded = [e for e in events if e["fields"]]
    assert len(decoded) >= layouts - 5   # a few samples fit another command's layout first
    pcap = export(tmp_path, tmp_path / "bus.bin")
    assert_agrees(tshark, plugin, pcap, events)


def test_display_filter_on_status_selects_what_the_filter_language_does(tmp_path, tshark, plugin):
    pcap = export(tmp_path, f"{CTL}+{DEV}")
    ours = [e["number"] for e in jsonl(CTL, DEV, args=("--filter", 'status == "nak"'))]
    theirs = [int(r["gimbal.number"]) for r in
              fields(tshark, plugin, pcap, ["gimbal.number"], "-Y", 'gimbal.status == "nak"')]
    assert ours and theirs == ours


def test_request_in_and_response_in_link_the_frames_of_a_transaction(tmp_path, tshark, plugin):
    pcap = export(tmp_path, SOCAT_LOG)
    events = {e["number"]: e for e in jsonl(SOCAT_LOG)}
    rows = fields(tshark, plugin, pcap, ["frame.number", "gimbal.number", "gimbal.request_in",
                                          "gimbal.response_in"], "-2")   # two passes: links to later frames
    number_of = {r["frame.number"]: int(r["gimbal.number"]) for r in rows}
    answers: dict[int, list[int]] = {}
    for e in events.values():
        if e["request"] is not None and e["kind"] != "rate":
            answers.setdefault(e["request"], []).append(e["number"])
    linked = 0
    for r in rows:
        e = events[int(r["gimbal.number"])]
        if e["kind"] == "command":
            got = [number_of[f] for f in r["gimbal.response_in"].split("|") if f]
            assert got == answers.get(e["number"], []), e
            linked += len(got)
        elif e["request"] is not None:
            assert number_of[r["gimbal.request_in"]] == e["request"], e
        else:
            assert r["gimbal.request_in"] == ""
    assert linked > 100


def test_problems_are_comments_and_expert_infos(tmp_path, tshark, plugin):
    from dissectors import problems as P
    pcap = export(tmp_path, f"{CTL}+{DEV}")
    events = [e for e in jsonl(CTL, DEV) if e["kind"] != "rate"]
    rows = fields(tshark, plugin, pcap, ["frame.comment", "gimbal.problem"])
    assert [r["frame.comment"].replace("\\n", "\n") for r in rows] == ["\n".join(e["problems"]) for e in events]
    assert [r["gimbal.problem"] for r in rows] == ["|".join(e["problems"]) for e in events]
    # each category is an expert info of its own: filterable, with its severity
    bad = [e["number"] for e in events if any(p.startswith(P.CHECKSUM.text) for p in e["problems"])]
    hits = fields(tshark, plugin, pcap, ["gimbal.number", "_ws.expert.severity"], "-Y", "gimbal.expert.checksum")
    assert bad and [int(r["gimbal.number"]) for r in hits] == bad
    # "error" severity, as Wireshark numbers it (PI_ERROR, 0x00800000)
    assert all("8388608" in r["_ws.expert.severity"] for r in hits)


def test_one_interface_per_line(tmp_path, tshark, plugin):
    two = fields(tshark, plugin, export(tmp_path, f"{CTL}+{DEV}", name="two.pcapng"),
                 ["frame.interface_name", "gimbal.line"])
    assert {r["frame.interface_name"] for r in two} == {"A", "B"}
    assert all(r["frame.interface_name"] == r["gimbal.line"] for r in two)
    one = fields(tshark, plugin, export(tmp_path, BUS, name="one.pcapng"), ["frame.interface_name"])
    assert {r["frame.interface_name"] for r in one} == {"AB"}


def test_packet_times_are_the_events_wire_times(tmp_path, tshark, plugin):
    events = [e for e in jsonl(SOCAT_LOG) if e["kind"] != "rate"]
    rows = fields(tshark, plugin, export(tmp_path, SOCAT_LOG), ["frame.time_relative"])
    t0 = events[0]["t"]
    assert all(math.isclose(float(r["frame.time_relative"]), e["t"] - t0, abs_tol=2e-9)
               for r, e in zip(rows, events))


def test_several_captures_in_one_file_keep_their_own_pairing(tmp_path, tshark, plugin):
    out = tmp_path / "fleet.pcapng"
    r = run_cli("export", SOCAT_LOG, BUS, "-o", out, "-j", "2")
    assert r.returncode == 0, r.stderr
    first, second = jsonl(SOCAT_LOG), jsonl(BUS)
    rows = fields(tshark, plugin, out, ["frame.number", "gimbal.capture", "gimbal.number", "gimbal.request_in"])
    n1 = len([e for e in first if e["kind"] != "rate"])
    assert len(rows) == n1 + len([e for e in second if e["kind"] != "rate"])
    assert {r["gimbal.capture"] for r in rows[:n1]} == {""} and {r["gimbal.capture"] for r in rows[n1:]} == {"1"}
    # an answer of the second capture links to a frame of the second capture
    frame_no = {r["frame.number"]: i for i, r in enumerate(rows)}
    for i, r in enumerate(rows[n1:], n1):
        if r["gimbal.request_in"]:
            assert frame_no[r["gimbal.request_in"]] >= n1
    # the file's two sections, as tshark counts them
    sections = fields(tshark, plugin, out, ["frame.section_number"])
    assert {s["frame.section_number"] for s in sections} == {"1", "2"}


def test_a_bad_input_is_skipped_and_the_rest_written(tmp_path, tshark, plugin):
    out = tmp_path / "part.pcapng"
    r = run_cli("export", SOCAT_LOG, tmp_path / "missing.log", "-o", out)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert "missing.log" in r.stderr and "skipped 1" in r.stderr
    assert len(fields(tshark, plugin, out, ["gimbal.number"])) == len(
        [e for e in jsonl(SOCAT_LOG) if e["kind"] != "rate"])
    # nothing readable: no file at all (an empty one would not open)
    none = tmp_path / "none.pcapng"
    r = run_cli("export", tmp_path / "missing.log", "-o", none)
    assert r.returncode == 1 and not none.exists()
    # an existing file is kept unless --force
    r = run_cli("export", SOCAT_LOG, "-o", out)
    assert r.returncode != 0 and "exists" in r.stderr
    assert run_cli("export", SOCAT_LOG, "-o", out, "--force").returncode == 0


def test_export_to_a_format_of_one_capture_points_to_convert(tmp_path):
    r = run_cli("export", SOCAT_LOG, "-o", tmp_path / "x.mcap")
    assert r.returncode == 2 and "gimbalscope convert" in r.stderr and "Traceback" not in r.stderr


def test_convert_writes_pcapng_too(tmp_path, tshark, plugin):
    out = tmp_path / "c.pcapng"
    r = run_cli("convert", CTL, DEV, "-o", out)
    assert r.returncode == 0, r.stderr
    assert_agrees(tshark, plugin, out, jsonl(CTL, DEV))


def test_verbose_tree_names_fields_units_and_spec(tmp_path, tshark, plugin):
    pcap = export(tmp_path, SOCAT_LOG)
    out = run_tshark(tshark, plugin, "-r", pcap, "-V", "-Y", "gimbal.azimuth_deg && gimbal.kind == \"command\"")
    out = out.split("\n\n")[0]   # the first such frame
    assert "Gimbal serial protocol (rev 1.9), command P to " in out
    assert "[Command name: Go to pan-tilt position]" in out and "[Spec reference: Table 11, Table 15]" in out
    assert " deg\n" in out and "Checksum OK: True" in out


# ---------------------------------------------------------------- install and extcap
def home_env(home):
    env = dict(os.environ, HOME=str(home))
    env.pop("XDG_CONFIG_HOME", None)
    return env


@pytest.fixture
def installed(tmp_path, tshark):
    """``gimbalscope wireshark install`` into a fresh home's personal folders."""
    home = tmp_path / "home"
    home.mkdir()
    r = subprocess.run([sys.executable, "-m", "analyzer", "wireshark", "install"], capture_output=True, text=True,
                       env=home_env(home), cwd=ROOT, timeout=PATIENCE, check=False)
    assert r.returncode == 0, r.stderr
    return home


def test_install_puts_the_plugin_where_tshark_loads_it(installed, tshark):
    env = home_env(installed)
    protocols = subprocess.run([tshark, "-G", "protocols"], capture_output=True, text=True, env=env, check=False).stdout
    assert any(line.split("\t")[2:3] == ["gimbal"] for line in protocols.splitlines())
    interfaces = subprocess.run([tshark, "-D"], capture_output=True, text=True, env=env, check=False).stdout
    assert "gimbalscope (Gimbal serial bus, one or two serial ports)" in interfaces


def test_install_needs_no_wireshark(tmp_path):
    env = dict(home_env(tmp_path), PATH=os.path.dirname(sys.executable))   # no tshark on it
    r = subprocess.run([sys.executable, "-m", "analyzer", "wireshark", "install"], capture_output=True,
                       text=True, env=env, cwd=ROOT, timeout=PATIENCE, check=False)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / ".local/lib/wireshark/plugins/gimbal.lua").exists()
    assert os.access(tmp_path / ".config/wireshark/extcap/gimbalscope-extcap", os.X_OK)
    assert "not installed" in r.stderr


def test_install_into_a_file_is_one_line(tmp_path):
    (tmp_path / "f").write_text("x")
    r = run_cli("wireshark", "install", "--dir", tmp_path / "f")
    assert r.returncode == 2 and "is a file" in r.stderr and "Traceback" not in r.stderr


def extcap(installed, *args):
    exe = installed / ".config/wireshark/extcap/gimbalscope-extcap"
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=PATIENCE,
                          env=home_env(installed), check=False)


def test_extcap_speaks_the_protocol(installed):
    r = extcap(installed, "--extcap-interfaces")
    assert r.returncode == 0 and "interface {value=gimbalscope}" in r.stdout
    r = extcap(installed, "--extcap-interface", "gimbalscope", "--extcap-dlts")
    assert "dlt {number=252}" in r.stdout
    r = extcap(installed, "--extcap-interface", "gimbalscope", "--extcap-config")
    calls = [line.split("{call=")[1].split("}")[0] for line in r.stdout.splitlines() if line.startswith("arg ")]
    assert calls == ["--port", "--port2", "--baud", "--framing"]
    assert "value {arg=2}{value=9600}{display=9600}{default=true}" in r.stdout


def tshark_live(tshark, installed, tmp_path, *options, seconds=3):
    out = tmp_path / "live.pcapng"
    args = [tshark, "-i", "gimbalscope", "-a", f"duration:{seconds}", "-w", str(out)]
    for o in options:
        args += ["-o", o]
    r = subprocess.run(args, capture_output=True, text=True, timeout=PATIENCE + seconds, env=home_env(installed),
                       check=False)
    return r, out


def extcap_running(home) -> bool:
    """Is an extcap program of this home's install still running?"""
    program = str(home / ".config/wireshark/extcap/gimbalscope-extcap").encode()
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                if program in f.read():
                    return True
        except OSError:   # gone meanwhile
            continue
    return False


SITE = """
import sys, time
from analyzer.simulation import scenario
site = scenario.build(set(), clean=True, seed=5)
site.start()
print(" ".join(site.link.tap_ports), flush=True)
sys.stdin.read()
site.stop()
"""


def test_a_live_tshark_capture_from_the_simulator_decodes(installed, tshark, tmp_path):
    """A simulated controller and gimbals on pseudo-terminals, tapped by tshark
    through the extcap for 3 seconds."""
    site = subprocess.Popen([sys.executable, "-c", SITE], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, cwd=ROOT)
    try:
        a, b = site.stdout.readline().split()
        r, out = tshark_live(tshark, installed, tmp_path, f"extcap.gimbalscope.port:{a}",
                             f"extcap.gimbalscope.port2:{b}")
    finally:
        site.stdin.close()
        site.wait(timeout=PATIENCE)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    # stopped cleanly: the extcap program has gone with tshark
    deadline = time.monotonic() + 10
    while extcap_running(installed) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not extcap_running(installed)
    env = home_env(installed)
    rows = subprocess.run([tshark, "-r", str(out), "-T", "fields", "-e", "gimbal.kind", "-e", "gimbal.line",
                           "-e", "gimbal.command", "-e", "gimbal.checksum_ok"],
                          capture_output=True, text=True, env=env, check=False).stdout.splitlines()
    kinds = [row.split("\t")[0] for row in rows]
    assert kinds.count("command") >= 5 and kinds.count("ack") >= 5
    assert {row.split("\t")[1] for row in rows} == {"A", "B"}
    # a clean installation: every frame's checksum holds
    assert all(row.split("\t")[3] in ("", "1") for row in rows)
    # and the capture Wireshark saved opens in gimbalscope: the same events again
    again = [e["kind"] for e in jsonl(out) if e["kind"] != "rate"]
    assert again == kinds


@pytest.mark.parametrize("options, said", [
    (["extcap.gimbalscope.port:/dev/ttyNOPE9"], "/dev/ttyNOPE9: no such serial port"),
    (["extcap.gimbalscope.port:/dev/null", "extcap.gimbalscope.framing:9Q1"], "framing '9Q1'"),
    ([], "no port given"),
])
def test_a_bad_extcap_configuration_reaches_tshark_as_one_line(installed, tshark, tmp_path, options, said):
    # the extcap program's error ends the capture at once; the duration is only a
    # bound, long enough for a busy machine to start the program and have it say why
    r, _out = tshark_live(tshark, installed, tmp_path, *options, seconds=PATIENCE)
    assert r.returncode != 0
    assert said in r.stderr and "Traceback" not in r.stderr


# ---------------------------------------------------------------- reading pcapng back
KEYS = ("line", "offset", "kind", "command", "fields", "checksum_ok", "txn", "status", "problems", "raw",
        "request", "retransmission", "device")


@pytest.mark.parametrize("sample", sorted(SAMPLES))
def test_a_pcapng_decodes_as_the_capture_it_came_from(tmp_path, sample):
    inputs = SAMPLES[sample]
    pcap = tmp_path / "rt.pcapng"
    r = run_cli("convert", *inputs, "-o", pcap)
    assert r.returncode == 0, r.stderr
    original = [e for e in jsonl(*inputs) if e["kind"] != "rate"]
    again = [e for e in jsonl(pcap) if e["kind"] != "rate"]
    # raw dumps have no time: the file says so, and they read back untimed (no latencies)
    assert [e["t"] is None for e in again] == [e["t"] is None for e in original]
    assert all(abs(a["t"] - b["t"]) < 1e-6 for a, b in zip(original, again) if a["t"] is not None)
    assert [{k: e[k] for k in KEYS} for e in again] == [{k: e[k] for k in KEYS} for e in original]


def test_a_pcapng_not_of_gimbalscope_is_one_line(tmp_path):
    from analyzer.formats.pcapng import PcapngStream
    other = tmp_path / "eth.pcapng"
    with open(other, "wb") as f:
        s = PcapngStream(f, "another program")
        s.packet(s.add_interface(1, "eth0"), 10**18, bytes(60))
    r = run_cli("decode", other)
    assert r.returncode == 2 and "not written by gimbalscope" in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_pcapng_cut_short_decodes_up_to_the_cut(tmp_path):
    pcap = tmp_path / "full.pcapng"
    assert run_cli("convert", SOCAT_LOG, "-o", pcap).returncode == 0
    data = pcap.read_bytes()
    cut = tmp_path / "cut.pcapng"
    cut.write_bytes(data[:len(data) * 2 // 3 + 5])   # inside a block
    r = run_cli("decode", cut, "--format", "jsonl")
    assert r.returncode == 0 and "ends inside a block" in r.stderr
    n = len(r.stdout.splitlines())
    assert 0.5 * 474 < n < 474


def test_a_pcapng_through_a_pipe(tmp_path):
    timed, untimed = tmp_path / "timed.pcapng", tmp_path / "untimed.pcapng"
    assert run_cli("convert", SOCAT_LOG, "-o", timed).returncode == 0
    assert run_cli("convert", CTL, DEV, "-o", untimed).returncode == 0
    exe = shutil.which("gimbalscope") or sys.executable
    args = [exe] if exe != sys.executable else [exe, "-m", "analyzer"]
    piped = subprocess.run(args + ["decode", "-", "--format", "jsonl"], input=timed.read_bytes(),
                           capture_output=True, cwd=ROOT, timeout=PATIENCE, check=False)
    assert piped.returncode == 0 and len(piped.stdout.splitlines()) == len(jsonl(SOCAT_LOG))
    # an untimed capture of two lines is read line by line: a pipe cannot be
    refused = subprocess.run(args + ["decode", "-"], input=untimed.read_bytes(), capture_output=True, cwd=ROOT,
                             timeout=PATIENCE, check=False)
    err = refused.stderr.decode()
    assert refused.returncode == 2 and "not through a pipe" in err and "Traceback" not in err
