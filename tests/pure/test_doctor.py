"""The wiring doctor's rules on scripted traffic, the echo stripper, advice that
fits where the traffic is read (files, live ports), and the findings table: every
rule fills its entry's words, the hiding rules name real ids, docs/doctor.md shows
the table."""

import ast
import json
import os
import subprocess
import sys
import time

import pytest

import analyzer
from analyzer.analysis import findings
from analyzer.analysis.doctor import ERROR, INFO, WARNING, Invocation, WiringDoctor
from analyzer.analysis.echo import EchoStripper
from analyzer.analysis.findings import (
    CONTROLLER_NO_RETRY,
    CONTROLLER_NO_WAIT,
    DEAD_LINK,
    DEVICE_MAP,
    ECHO,
    FINDINGS,
    LINES_SWAPPED,
    NOISY_LINK,
    SILENT_AFTER_RATE,
    SILENT_DEVICE,
    SLOW_ANSWERS,
    TABLE,
    Finding,
    FindingKind,
    fields_of,
    render,
    unexplained,
)
from analyzer.simulation.traffic import Traffic, Write
from dissectors.event import ACK, COMMAND, RESULT, Event
from tests.conftest import ROOT, frame, run_cli
from tests.integration.test_live import pty_pair
from tests.tui_fixtures import conversation

BT = 10 / 9600


def findings_of(*paths, **kw):
    cap = analyzer.open(*map(str, paths), **kw)
    doctor = WiringDoctor(cap.lines)
    for batch in cap.batches():
        for ev in batch:
            doctor.add(ev)
        if cap.echo is not None:
            for cmd in cap.echo.take_echoed():
                doctor.echoed(cmd)
    return {f.code: f for f in doctor.findings()}


def polls(rounds=12, answer=lambda k: True, echo=False) -> Traffic:
    """A controller polling 1.1.1 and 1.1.2 with P?; each answers ACK + result
    unless ``answer(k)`` says not (then the controller moves on after 0.3 s)."""
    tr = Traffic(baud=9600)
    t = 0.0
    for k in range(rounds):
        dst = (1, 1, 1 + k % 2)
        cmd = frame(dst, 0, "P?")
        tr.writes.append(Write("A", cmd, t))
        if echo:
            tr.writes.append(Write("B", cmd, t + BT / 2))   # the adapter hears itself
        t += len(cmd) * BT
        if answer(k):
            tr.writes.append(Write("B", b"\x06", t + 0.005))
            res = frame((0, 1, dst[2]), 1, "03E8FE0C")
            tr.writes.append(Write("B", res, t + 0.005 + BT + 0.001))
            t += 0.005 + BT + 0.001 + len(res) * BT + 0.03
        else:
            t += 0.3
    return tr


def test_a_clean_conversation_has_no_warnings(tmp_path):
    log = tmp_path / "tap.log"
    log.write_text(polls().socat_log())
    found = findings_of(log)
    assert [f.severity for f in found.values()] == ["info"]      # the device map only
    assert "1.1.1: 6 commands, answers on B" in found[DEVICE_MAP].detail


def test_lines_swapped_from_two_dumps_given_the_wrong_way_round(tmp_path):
    tr = polls()
    (tmp_path / "a.bin").write_bytes(tr.line_bytes("A"))
    (tmp_path / "b.bin").write_bytes(tr.line_bytes("B"))
    found = findings_of(tmp_path / "b.bin", tmp_path / "a.bin")
    assert found[LINES_SWAPPED].severity == "error"
    # 12 ACKs arrive on "line A" and 12 P? commands on "line B"
    assert "12 ACK/NAK/NIC bytes arrived on line A and 12 command frames on line B" in found[LINES_SWAPPED].detail
    assert DEAD_LINK not in found          # explained by the swap
    fixed = findings_of(tmp_path / "b.bin", tmp_path / "a.bin", swap_lines=True)
    assert LINES_SWAPPED not in fixed and not [f for f in fixed.values() if f.severity != "info"]


def test_silent_device_among_answering_ones_and_dead_link(tmp_path):
    log = tmp_path / "tap.log"
    log.write_text(polls(answer=lambda k: k % 2 == 0).socat_log())     # 1.1.2 never answers
    found = findings_of(log)
    assert found[SILENT_DEVICE].subject == "1.1.2" and "6 commands to 1.1.2" in found[SILENT_DEVICE].detail
    # 1.1.1's commands take 3 events (command, ACK, result), 1.1.2's one: #4, #8, ...;
    # the sixth (#24) is still pending when the capture ends, so not yet evidence
    assert found[SILENT_DEVICE].evidence == [4, 8, 12, 16, 20]
    log.write_text(polls(answer=lambda k: False).socat_log())
    found = findings_of(log)
    assert found[DEAD_LINK].severity == "error" and "line B is silent" in found[DEAD_LINK].detail
    assert SILENT_DEVICE not in found


def test_echo_is_found_and_stripped(tmp_path):
    log = tmp_path / "tap.log"
    log.write_text(polls(echo=True).socat_log())
    events = list(analyzer.open(str(log)))
    assert [e.kind for e in events[:3]] == ["command", "ack", "result"]     # no copy of the command
    assert all(e.status == "ok" for e in events if e.kind == COMMAND)
    found = findings_of(log)
    assert found[ECHO].severity == "warning" and "12 commands came back" in found[ECHO].detail


def test_echo_stripper_keeps_real_results():
    cmd = Event("A", 0, COMMAND, frame((1, 1, 1), 0, "P?"), 0.0, 0.009)
    copy = Event("B", 0, RESULT, frame((1, 1, 1), 0, "P?"), 0.0005, 0.0095)
    ack = Event("B", 9, ACK, b"\x06", 0.015, 0.016)
    result = Event("B", 10, RESULT, frame((0, 1, 1), 1, "03E8FE0C"), 0.017, 0.031)
    late_copy = Event("B", 24, RESULT, frame((1, 1, 1), 0, "P?"), 0.5, 0.509)   # not overlapping: kept
    s = EchoStripper()
    assert s.strip([copy, cmd, ack, result, late_copy]) == [cmd, ack, result, late_copy]
    assert s.count == 1 and s.take_echoed() == [cmd] and s.take_echoed() == []


def test_noisy_line_and_length_correlation(tmp_path):
    tr = Traffic(baud=9600)
    t = 0.0
    for k in range(40):
        cmd = frame((1, 1, 1), 0, "P0FA0FC18" if k % 2 else "P?")   # long and short commands
        if k % 2 and k % 6 == 1:
            cmd = cmd[:-1] + bytes([cmd[-1] ^ 0x01])                  # every third long one corrupted
        tr.writes.append(Write("A", cmd, t))
        t += len(cmd) * BT + 0.005
        tr.writes.append(Write("B", b"\x06" if cmd[-1] == frame((1, 1, 1), 0, cmd[6:-1].decode())[-1]
                               else b"\x15", t))
        t += BT + 0.03
    log = tmp_path / "tap.log"
    log.write_text(tr.socat_log())
    found = findings_of(log)
    noisy = found[NOISY_LINK]
    assert noisy.subject == "A" and "7 checksum errors" in noisy.detail
    assert "errors grow with length" in noisy.detail          # 7 of 20 long frames, 0 of 20 short


def test_fixture_conversation_is_below_every_threshold(tmp_path):
    tr, _expected = conversation()
    log = tmp_path / "tap.log"
    log.write_text(tr.socat_log())
    assert [f.code for f in findings_of(log).values() if f.severity != "info"] == []


# ------------------------------------------------------------ advice fits its input
def swapped(tr: Traffic) -> Traffic:
    """The same traffic as tapped with the two lines given the other way round."""
    return Traffic(tr.baud, [Write("B" if w.line == "A" else "A", w.data, w.t) for w in tr.writes])


def test_advice_on_raw_dumps_names_them_and_counts_events_not_seconds(tmp_path):
    tr = polls()
    a, b = tmp_path / "ctl.bin", tmp_path / "dev.bin"
    a.write_bytes(tr.line_bytes("A"))
    b.write_bytes(tr.line_bytes("B"))
    r = run_cli("doctor", b, a)                   # given the wrong way round
    assert r.returncode == 3, r.stderr            # an error-level finding (docs/doctor.md, "Exit status")
    assert f"try: give the dumps the other way round: gimbalscope decode {a} {b} " \
           f"(or gimbalscope decode {b} {a} --swap-lines)" in r.stdout
    assert "PORT" not in r.stdout and "press x" not in r.stdout
    # no time in raw dumps: the traffic is counted in events
    assert "in 36 events (no time in this capture)" in r.stdout and "0.0 s" not in r.stdout
    assert "[found after 36 events]" in r.stdout
    # and what it suggests works
    fixed = run_cli("doctor", b, a, "--swap-lines", "--format", "json")
    assert [f["code"] for f in json.loads(fixed.stdout)["findings"]] == [DEVICE_MAP]


def test_advice_on_a_socat_log_is_the_flag_with_its_name(tmp_path):
    log = tmp_path / "tap.log"
    log.write_text(swapped(polls()).socat_log())
    found = json.loads(run_cli("doctor", log, "--format", "json").stdout)["findings"]
    fix = next(f["fix"] for f in found if f["code"] == LINES_SWAPPED)
    assert fix == f"read its lines the other way round: gimbalscope decode {log} --swap-lines"
    assert [f["code"] for f in json.loads(run_cli("doctor", log, "--swap-lines", "--format", "json").stdout)
            ["findings"]] == [DEVICE_MAP]


def test_advice_on_live_ports_is_the_swapped_port_order(tmp_path):
    ma, _sa, pa = pty_pair()
    mb, _sb, pb = pty_pair()
    proc = subprocess.Popen([sys.executable, "-m", "analyzer", "doctor", pa, pb, "--seconds", "3", "--format", "json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    time.sleep(1.0)
    for k in range(8):                            # the gimbal's side on line A, the controller's on B
        os.write(mb, frame((1, 1, 1 + k % 2), 0, "P?"))
        time.sleep(0.02)
        os.write(ma, b"\x06")
        time.sleep(0.05)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 3, err              # lines swapped is an error
    found = {f["code"]: f for f in json.loads(out)["findings"]}
    # the ports swapped, the flag `live` and `doctor` take; no TUI here, so no key
    assert found[LINES_SWAPPED]["fix"] == (f"give the ports the other way round: gimbalscope live {pb} {pa} "
                                            f"(or add --swap-lines)")


def test_advice_never_names_what_the_command_rejects():
    ports = ("/dev/pts/7", "/dev/pts/8")
    demo = Invocation(ports, live=True, command="demo").swap_fix()
    assert "--swap-lines" not in demo and "press x" not in demo and "gimbalscope live" not in demo
    assert "press x" in Invocation(ports, live=True, command="demo", tui=True).swap_fix()
    live_tui = Invocation(ports, live=True, command="live", tui=True).swap_fix()
    assert live_tui.startswith("give the ports the other way round: gimbalscope live /dev/pts/8 /dev/pts/7")
    assert live_tui.endswith("; press x here to swap them now")
    assert "press x" not in Invocation(("a.bin", "b.bin"), tui=True).swap_fix()   # files: no swap key
    assert "--scan-baud" not in Invocation(("tap.log",)).baud_fix()              # files have no rate to scan
    assert "gimbalscope decode tap.log --baud RATE" in Invocation(("tap.log",)).baud_fix()
    # a named rate (docs/doctor.md, "Wrong rate or not this protocol"): a byte capture holds
    # what the tap's UART read, so no --baud decodes it again: it is captured again at the rate
    again = Invocation(("tap.log",), command="doctor").rate_fix(9600, 19200)
    assert "capture it again" in again and "--baud 9600" in again and "decode tap.log" not in again
    # a logic analyser's waveform is decoded again at that rate
    assert Invocation(("cap.sr",)).rate_fix(9600, 19200, waveform=True).endswith(
        "gimbalscope decode cap.sr --baud 9600")
    live = Invocation(ports, live=True, command="doctor").rate_fix(9600, 19200)
    assert "gimbalscope live /dev/pts/7 /dev/pts/8 --baud 9600" in live
    # demo takes no --baud
    assert "--baud 9600" not in Invocation(ports, live=True, command="demo").rate_fix(9600, 19200)


# ------------------------------------------------------------ the findings table
def found_and_phrase_calls() -> list[tuple[str, FindingKind, str | None, set[str]]]:
    """Every ``.found(...)`` and ``.phrase(...)`` call of the doctor's rules: (where,
    the table entry, the phrase or None for ``found``, the fields passed). The entry
    is ``FINDINGS[ID]`` in the call, or a local variable set to it in the function."""
    trees = []
    # the doctor's rules, the wiring signs it rests on, and send's word for a silent link
    for name in ("analysis/doctor.py", "analysis/signs.py", "cli/send.py"):
        with open(os.path.join(ROOT, "analyzer", *name.split("/")), encoding="utf-8") as f:
            trees.append((name, ast.parse(f.read())))

    def entry(node, local):
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id == "FINDINGS":
            return FINDINGS[getattr(findings, node.slice.id)]
        return local.get(node.id) if isinstance(node, ast.Name) else None

    calls = []
    for module, fn in ((m, fn) for m, tree in trees for fn in ast.walk(tree)):
        if not isinstance(fn, ast.FunctionDef):
            continue
        local = {t.id: kind for a in ast.walk(fn) if isinstance(a, ast.Assign)
                 for t in a.targets if isinstance(t, ast.Name) and (kind := entry(a.value, {})) is not None}
        for call in ast.walk(fn):
            if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute)
                    and call.func.attr in ("found", "phrase")):
                continue
            kind = entry(call.func.value, local)
            where = f"{module}:{call.lineno}"
            assert kind is not None, f"{where}: say which entry: FINDINGS[ID].{call.func.attr}(...)"
            assert all(k.arg for k in call.keywords), f"{where}: name every field (no **values)"
            passed = {k.arg for k in call.keywords}
            if call.func.attr == "found":
                calls.append((where, kind, None, passed))
                continue
            name = call.args[0]   # a phrase's name, or one of two
            names = [name.body, name.orelse] if isinstance(name, ast.IfExp) else [name]
            assert all(isinstance(n, ast.Constant) for n in names), f"{where}: name the phrase"
            calls += [(where, kind, n.value, passed) for n in names]
    return calls


class AnyValue:
    """Formats under any spec: a template is checked for its fields, not its values."""

    def __format__(self, spec: str) -> str:
        return "x"


def test_every_rule_fills_its_entrys_templates_with_exactly_their_fields():
    calls = found_and_phrase_calls()
    for where, kind, phrase, passed in calls:
        if phrase is None:
            assert passed == kind.fields, f"{where}: {kind.id} fills {sorted(kind.fields)}, got {sorted(passed)}"
            f = kind.found("subject", [], **{name: AnyValue() for name in passed})
            assert (f.code, f.severity, f.subject) == (kind.id, kind.severity, "subject")
        else:
            assert phrase in kind.phrases, f"{where}: {kind.id} has no phrase {phrase!r}"
            assert passed == fields_of(kind.phrases[phrase]), f"{where}: {kind.id}'s {phrase!r} phrase"
            kind.phrase(phrase, **{name: AnyValue() for name in passed})
    # every entry is raised by a rule, and every phrase is said
    assert {kind.id for _w, kind, phrase, _p in calls if phrase is None} == set(FINDINGS)
    assert {(kind.id, p) for _w, kind, p, _f in calls if p} == {(k.id, p) for k in TABLE for p in k.phrases}


def test_a_missing_field_is_found():
    silent = FINDINGS[SILENT_DEVICE]
    with pytest.raises(KeyError, match="answering"):
        silent.found("1.1.2", [], addr="1.1.2", commands=6)


def test_the_table_names_each_id_once_and_hides_only_ids_of_the_table():
    ids = [kind.id for kind in TABLE]
    assert len(ids) == len(set(ids)) and set(ids) == set(FINDINGS)
    # the module's constants are the ids: code and tests name them, never the string
    constants = {name: value for name, value in vars(findings).items() if name.isupper() and isinstance(value, str)
                 and value in FINDINGS}
    assert sorted(constants.values()) == sorted(ids) and all(name.lower() == v for name, v in constants.items())
    for kind in TABLE:
        assert set(kind.hides) <= set(FINDINGS) and kind.id not in kind.hides, kind.id
        assert kind.severity in (ERROR, WARNING, INFO) and kind.shows, kind.id


def found(code: str, subject: str = "") -> Finding:
    return Finding(code, FINDINGS[code].severity, "", "", "", [], subject)


def test_a_kept_finding_hides_what_the_table_says_in_later_rules_only():
    swapped, no_wait, slow = found(LINES_SWAPPED, "A,B"), found(CONTROLLER_NO_WAIT), found(SLOW_ANSWERS, "1.1.1")
    # the swap explains the controller; a hidden finding explains nothing itself
    assert unexplained([[swapped], [found(DEAD_LINK, "B")], [no_wait], [slow]]) == [swapped, slow]
    assert unexplained([[no_wait], [slow]]) == [no_wait]
    assert unexplained([[slow], [no_wait]]) == [slow, no_wait]          # earlier rules are not hidden
    # a device silent since a rate change: nothing else about it, nor the controller
    rate = found(SILENT_AFTER_RATE, "1.1.1")
    other = found(SLOW_ANSWERS, "1.1.2")
    assert unexplained([[rate], [found(SILENT_DEVICE, "1.1.3")], [found(CONTROLLER_NO_RETRY, "controller")],
                        [slow, other]]) == [rate, other]


def test_docs_doctor_md_findings_table_is_rendered_from_the_table():
    with open(os.path.join(ROOT, "docs", "doctor.md"), encoding="utf-8") as f:
        page = f.read()
    assert render() in page, "paste the output of: python -m analyzer.analysis.findings"
    for kind in TABLE:
        assert f"| `{kind.id}` | {kind.severity} |" in page
