"""Hostile filters and the ``device`` field.

Filters: long ``or``/``and`` chains, deep nesting, huge numbers and huge
constant lists must compile to something that evaluates in bounded stack and
time, or be one FilterError; random token soup never raises anything else, and
what compiles never raises on an event.

``device``: every event of one gimbal, answers included, selected by
``device == "G.P.D"``, on a conversation written by hand from the spec (Table 1
framing, §1.4.2 answers, Table 3 addresses)."""

import json
import os
import sys

import pytest
from hypothesis import given
from hypothesis import strategies as st

import analyzer
from analyzer.analysis.filter import FilterError, compile_filter
from analyzer.simulation.traffic import Traffic, Write
from dissectors.event import Event
from tests.conftest import ROOT, frame, run_cli

BT = 10 / 9600   # one byte at 9600 baud, 8N1


def numbered(n: int, **kw) -> Event:
    e = Event("A", 0, "command", b"\xf8", None)
    e.number = n
    for k, v in kw.items():
        setattr(e, k, v)
    return e


# ------------------------------------------------------------ long chains
@pytest.mark.parametrize("n", [1000, 10000])
def test_long_or_and_and_chains_evaluate(n):
    any_number = compile_filter(" or ".join(f"number == {i}" for i in range(1, n + 1)))
    assert any_number(numbered(1)) and any_number(numbered(n))     # the first and the last operand
    assert not any_number(numbered(n + 1))
    every = compile_filter(" and ".join(f"number != {i}" for i in range(1, n + 1)))
    assert every(numbered(n + 1)) and not every(numbered(n))


def calls_made(fn, *args) -> int:
    """Python function calls made while running ``fn`` (a structural measure of
    the work per event, unlike a time)."""
    count = 0

    def profile(frame, event, arg):
        nonlocal count
        if event == "call":
            count += 1

    sys.setprofile(profile)
    try:
        fn(*args)
    finally:
        sys.setprofile(None)
    return count


def test_a_30k_constant_list_is_built_once_and_keeps_membership_rules():
    # 30 000 commands, and problem strings "category: detail" among them
    names = [f"X{i}" for i in range(29_998)] + ["P?", "bad checksum: expected 0x94, got 0x92"]
    keep = compile_filter("command in [" + ", ".join(f'"{s}"' for s in names) + "]")
    per_event = [calls_made(keep, numbered(k, command=c)) for k, c in enumerate(["P?", "HO", None], 1)]
    assert max(per_event) < 50, per_event          # not one call per list element
    events = [numbered(k, command=("P?" if k % 3 == 0 else f"Y{k}")) for k in range(1, 1001)]
    assert sum(map(keep, events)) == 333            # every third of 1..1000 is P?
    # a category still matches its details; numbers and lists still match by value
    assert compile_filter('"bad checksum" in [' + ", ".join(f'"{s}"' for s in names) + "]")(numbered(1))
    big_numbers = compile_filter("number in [" + ", ".join(str(k * 2) for k in range(30_000)) + "]")
    assert calls_made(big_numbers, numbered(4)) < 50
    assert big_numbers(numbered(4)) and big_numbers(numbered(59_998)) and not big_numbers(numbered(5))
    dsts = compile_filter("dst in [" + ", ".join(f"[1, 1, {d % 256}]" for d in range(30_000)) + "]")
    assert dsts(numbered(1, dst=(1, 1, 200))) and not dsts(numbered(1, dst=(1, 2, 200)))


# ---------------------------------------------------------------- fuzzing
VOCAB = [
    "number", "t", "line", "kind", "command", "dst", "src", "payload", "checksum_ok", "fields",
    "problems", "txn", "status", "latency", "retransmission", "request", "raw", "device",
    "azimuth_deg", "elevation_deg", "nosuchname",
    "and", "or", "not", "in", "true", "false", "null",
    "==", "!=", "<", ">", "<=", ">=", "(", ")", "[", "]", ",", ".",
    "0", "-1", "2.5", "3", "1e999", "9" * 5000, "1" * 31,
    '"ok"', "'P?'", '"bad checksum"', '"1.1.2"', '"nack"', '"a\\"b"', '"',
    "\n", "\t", ";", "@", "\u0663",
    "(" * 70, ")" * 70, "not " * 70, "[" * 70,
]


def _sample_events() -> list[Event]:
    """Real events (the sample capture) and odd ones: values of every type."""
    events = list(analyzer.open(os.path.join(ROOT, "captures", "demo-socat.log")))[:300]
    odd = numbered(9999, command="P?", dst=(1, 1, 2), src=0, payload=b"\x00\xff", checksum_ok=True,
                   fields={"azimuth_deg": float("nan"), "elevation_deg": None, "flags": [1, [2]], "map": {"a": 1}},
                   problems=["bad checksum: x", "noise"], status="ok", latency=-0.0)
    return events + [odd]


EVENTS = _sample_events()


SOUP = st.one_of(
    st.builds(lambda tokens, sep: sep.join(tokens), st.lists(st.sampled_from(VOCAB), max_size=30),
              st.sampled_from([" ", ""])),
    st.text(max_size=60),
)


@given(SOUP)
def test_token_soup_compiles_or_is_a_filter_error_and_never_raises_on_events(expr):
    try:
        keep = compile_filter(expr)
    except FilterError as e:
        line = f"--filter {e} in: {e.pointer()}"
        assert line.splitlines() == [line] and e.column >= 1
        return
    for ev in EVENTS:
        assert keep(ev) in (True, False)


# ------------------------------------------------------------------ device
def conversation() -> tuple[Traffic, dict[str, list[int]]]:
    """Two gimbals on port 1, the controller in group 0 (events numbered in wire order):

      #1 A  P? to 1.1.2          #2 ACK, #3 result from group 1 to 0.1.2 (Table 3)
      #4 A  HO to 1.1.3          #5 NAK
      #6 A  HO to 1.1.2          #7 ACK
      #8 A  HO to 1.1.3 again    #9 ACK       (a retransmission after the NAK)
      #10 B an ACK nobody waits for: an orphan, no device
    """
    tr = Traffic(baud=9600)
    t = 0.0

    def put(line: str, data: bytes, gap: float) -> None:
        nonlocal t
        t += gap
        tr.writes.append(Write(line, data, t))
        t += len(data) * BT

    put("A", frame((1, 1, 2), 0, "P?"), 0.05)
    put("B", b"\x06", 0.005)
    put("B", frame((0, 1, 2), 1, "0FA0FC18"), 0.002)   # az 40.00, el -10.00 (Table 15)
    put("A", frame((1, 1, 3), 0, "HO"), 0.05)
    put("B", b"\x15", 0.005)
    put("A", frame((1, 1, 2), 0, "HO"), 0.05)
    put("B", b"\x06", 0.005)
    put("A", frame((1, 1, 3), 0, "HO"), 0.05)
    put("B", b"\x06", 0.005)
    put("B", b"\x06", 0.2)
    return tr, {"1.1.2": [1, 2, 3, 6, 7], "1.1.3": [4, 5, 8, 9], "none": [10]}


@pytest.fixture
def tap(tmp_path):
    tr, expected = conversation()
    path = tmp_path / "tap.log"
    path.write_text(tr.socat_log())
    return path, expected


def test_device_selects_a_gimbals_commands_and_all_its_answers(tap):
    path, expected = tap
    events = list(analyzer.open(str(path)))
    assert [e.kind for e in events] == ["command", "ack", "result", "command", "nak", "command", "ack",
                                        "command", "ack", "ack"]
    for device in ("1.1.2", "1.1.3"):
        keep = compile_filter(f'device == "{device}"')
        assert [e.number for e in events if keep(e)] == expected[device]
    assert [e.number for e in events if compile_filter("device == null")(e)] == expected["none"]
    assert events[2].dst == (0, 1, 2) and events[2].device == "1.1.2"   # dst stays the header
    # status != "ok": the NAK'd command only, none of the answers (they have no status)
    assert [e.number for e in events if compile_filter('status != "ok"')(e)] == [4]
    # JSON: "device" on every object, after the keys that were there before
    keys = list(events[1].to_dict())
    assert keys[-1] == "device" and keys[:-1] == ["number", "t", "t_end", "line", "offset", "kind", "command",
                                                  "dst", "src", "payload", "checksum_ok", "fields", "problems",
                                                  "txn", "status", "latency", "retransmission", "request", "raw"]
    assert [e.to_dict()["device"] for e in events] == ["1.1.2"] * 3 + ["1.1.3"] * 2 + ["1.1.2"] * 2 \
        + ["1.1.3"] * 2 + [None]


def test_cli_device_filter_gives_the_acks_too(tap):
    path, _expected = tap
    r = run_cli("decode", path, "--format", "jsonl", "--filter", 'device == "1.1.3"')
    assert r.returncode == 0, r.stderr
    rows = [json.loads(line) for line in r.stdout.splitlines()]
    assert [(row["number"], row["kind"]) for row in rows] == [(4, "command"), (5, "nak"), (8, "command"),
                                                              (9, "ack")]


def test_cli_device_filter_on_the_sample_keeps_each_commands_answers():
    r = run_cli("decode", "captures/demo-socat.log", "--format", "jsonl", "--filter", 'device == "1.1.2"')
    assert r.returncode == 0, r.stderr
    rows = [json.loads(line) for line in r.stdout.splitlines()]
    commands = {row["number"] for row in rows if row["kind"] == "command"}
    answers = [row for row in rows if row["kind"] in ("ack", "nak", "nic")]
    assert commands and answers
    # every command is to 1.1.2; every ACK/NAK/NIC shown answers one of them
    assert all(row["dst"] == [1, 1, 2] for row in rows if row["kind"] == "command")
    assert all(row["request"] in commands for row in answers)
    # results come back from group 1 addressed to the controller's group 0, port 1, device 2
    assert all(row["src"] == 1 and row["dst"][1:] == [1, 2] for row in rows if row["kind"] == "result")


def test_cli_filter_error_with_a_newline_is_one_line():
    r = run_cli("decode", "captures/demo-socat.log", "--filter", 'kind ==\n"nack"')
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("gimbalscope: error: --filter column 9:")
    assert "\\n" in r.stderr and "Traceback" not in r.stderr
