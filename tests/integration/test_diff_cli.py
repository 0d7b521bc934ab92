"""`gimbalscope diff` on captures whose truth is known: the same conversation
with its timing shifted (nothing to report), with ACKs lost (worse, and exactly
those transactions listed), and the other way round (better)."""

from __future__ import annotations

import json

import pytest

from analyzer.simulation.traffic import Traffic, Write, generate
from tests.conftest import run_cli

ACK = b"\x06"


@pytest.fixture(scope="module")
def captures(tmp_path_factory):
    folder = tmp_path_factory.mktemp("diff")
    base = generate(600, seed=5)
    writes = sorted(base.writes, key=lambda w: w.t)

    def log(name: str, kept: list[Write]) -> str:
        path = folder / name
        path.write_text(Traffic(base.baud, kept).socat_log())
        return str(path)

    # every command 30 ms later than the one before: the gaps change, not the answers' delays
    shifted, shift = [], 0.0
    for w in writes:
        if w.line == "A":
            shift += 0.03
        shifted.append(Write(w.line, w.data, w.t + shift))
    # every 4th ACK of a command that has no result (the next command follows it) lost
    # on the wire: those commands go unanswered
    acks = [k for k, w in enumerate(writes[:-1]) if w.line == "B" and w.data == ACK and writes[k + 1].line == "A"]
    lost = set(acks[::4])
    return {"base": log("base.log", writes), "shifted": log("shifted.log", shifted),
            "lossy": log("lossy.log", [w for k, w in enumerate(writes) if k not in lost]), "lost": len(lost)}


def test_timing_shifted_without_a_change_reports_nothing(captures):
    done = run_cli("diff", captures["base"], captures["shifted"])
    assert done.returncode == 0, done.stderr
    assert "no figure changed by more than chance" in done.stdout
    assert "the transactions are the same, command for command" in done.stdout
    assert all(len(line) <= 80 for line in done.stdout.splitlines())


def test_lost_acks_are_worse_and_listed(captures):
    done = run_cli("diff", captures["base"], captures["lossy"], "--format", "json")
    assert done.returncode == 1, done.stderr
    data = json.loads(done.stdout)
    whole = {c["figure"]: c for c in data["changes"] if c["scope"] == "capture"}
    timeouts = whole["timeouts"]
    assert timeouts["verdict"] == "worse"
    assert timeouts["counts"]["before"] == 0 and timeouts["counts"]["after"] == captures["lost"]
    body = data["transactions"]["unified"][2:]
    removed = [line for line in body if line.startswith("-")]
    added = [line for line in body if line.startswith("+")]
    # each lost ACK: its transaction ok before, unanswered after
    assert len(removed) == len(added) == captures["lost"]
    assert all(line.split()[-1] != "no_ack" for line in removed)
    assert all(" no_ack" in line for line in added)


def test_the_fix_is_better_and_exits_0(captures):
    done = run_cli("diff", captures["lossy"], captures["base"])
    assert done.returncode == 0, done.stderr
    assert "all: timeouts" in done.stdout and "better" in done.stdout
    assert "worse" not in done.stdout
    assert all(len(line) <= 80 for line in done.stdout.splitlines())


def test_a_missing_capture_is_one_line(tmp_path, captures):
    done = run_cli("diff", str(tmp_path / "nope.log"), captures["base"])
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "nope.log" in done.stderr and "Traceback" not in done.stderr


def test_the_html_page_says_the_same(tmp_path, captures):
    page = tmp_path / "diff.html"
    done = run_cli("diff", captures["base"], captures["lossy"], "--html", page)
    assert done.returncode == 1, done.stderr
    text = page.read_text()
    assert text.startswith("<!DOCTYPE html>") and "<script" not in text and "http" not in text
    assert '<p class="worse">' in text and "timeouts" in text and 'class="worse">worse</td>' in text
    assert text.count('<span class="del">') == captures["lost"] == text.count('<span class="add">')
    again = run_cli("diff", captures["base"], captures["lossy"], "--html", page)
    assert again.returncode == 2 and "exists" in again.stderr


def test_a_capture_that_is_not_this_protocol_is_said_as_stats_says_it(tmp_path, captures):
    import random

    noise = tmp_path / "noise.bin"
    noise.write_bytes(random.Random(3).randbytes(20_000))
    done = run_cli("diff", noise, captures["base"])
    assert done.returncode == 0, done.stderr
    assert "almost nothing decodes" in done.stderr and "Traceback" not in done.stderr
