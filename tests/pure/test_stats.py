"""Statistics: counts and latency summaries, checked against hand-made events."""

import json
import os

import pytest

import analyzer
from analyzer.analysis.stats import Latency, Stats
from tests.conftest import BUS, ROOT, SOCAT_LOG, run_cli
from tests.pure.test_pairing import cmd, res, run, simple
from tests.text_tables import assert_fits, cells, headers, read_tables, run_piped


def test_latency_quantiles_within_one_percent():
    lat = Latency()
    for ms in (10, 20, 30, 40, 1000):
        lat.add(ms / 1000)
    d = lat.to_dict()
    assert d["count"] == 5 and d["min"] == 0.010 and d["max"] == 1.0
    assert d["median"] == pytest.approx(0.030, rel=0.01)
    # nearest rank: p95 of five samples is sample ceil(0.95 * 5) = 5
    assert d["p95"] == pytest.approx(1.0, rel=0.01)


def test_counts_per_command_and_device():
    evs = run([cmd(b"P?", 0.0), simple("ack", 0.012), res(b"0FA0FC18", 0.015),   # ok, ACK after 3 ms
               cmd(b"HO", 1.0, dst=(1, 1, 2)), simple("nak", 1.019),              # nak after 10 ms
               cmd(b"HO", 2.0, dst=(1, 1, 2)), simple("ack", 2.014),              # retransmission, 5 ms
               cmd(b"PL", 3.0, dst=(1, 1, 2))], ack=0.2)                          # pending
    st = Stats()
    for e in evs:
        st.add(e)
    d = st.to_dict()
    assert d["commands"] == 4 and d["events"] == 8
    assert d["status"] == {"ok": 2, "nak": 1, "nic": 0, "no_ack": 0, "no_result": 0, "pending": 1}
    assert d["retransmissions"] == 1
    ho = d["by_command"]["HO"]
    assert (ho["commands"], ho["ok"], ho["nak"], ho["retransmissions"]) == (2, 1, 1, 1)
    assert ho["ack_latency"]["min"] == pytest.approx(0.005) and ho["ack_latency"]["max"] == pytest.approx(0.010)
    assert d["by_device"]["1.1.1"]["commands"] == 1
    assert d["by_device"]["1.1.2"]["commands"] == 3
    assert d["by_command"]["P?"]["result_latency"]["max"] == pytest.approx(0.006)


def test_checksum_errors_agree_with_the_problems_and_say_what_is_not_a_frame():
    """captures/demo-bus.bin: 12 frames arrive with a bad checksum, and one frame is
    broken beyond reading (a good frame starts inside it), so its bytes are a noise
    event whose problem is `bad checksum`. Both count as checksum errors, as in the
    problems, and the summary says which is which."""
    st = Stats()
    for ev in analyzer.open(os.path.join(ROOT, "captures", "demo-bus.bin")):
        st.add(ev)
    d = st.to_dict()
    assert d["checksum_errors"] == d["problems"]["bad checksum"] + d["problems"].get("bad length byte", 0) == 13
    assert d["broken_frames"] == 1
    assert d["noise"] == {"events": 5, "bytes": 27, "by_problem": {"noise": 4, "bad checksum": 1}}
    assert d["noise"]["events"] == d["problems"]["noise"] + d["broken_frames"]
    text = run_cli("stats", os.path.join(ROOT, "captures", "demo-bus.bin")).stdout
    assert "checksum errors 13 (12 in frames, 1 in a broken frame shown as noise)" in text
    assert "noise 5 events / 27 bytes (4 noise runs, 1 broken frame)" in text
    assert "problems (events per category): " in text and "bad checksum 13" in text


def test_problems_count_events_per_category():
    evs = run([cmd(b"P?", 0.0), simple("ack", 0.012), res(b"0FA0FC18", 0.015)], ack=0.2)
    evs[0].note("unknown command: one")
    evs[0].note("unknown command: two")      # two details, one event
    st = Stats()
    for e in evs:
        st.add(e)
    assert st.to_dict()["problems"] == {"unknown command": 1}


# ------------------------------------------------------------ the text fits the terminal
# The tables' columns, named as the JSON names them (by hand, from docs/cli.md's table)
COLUMNS = ["commands", "ok", "nak", "nic", "no_ack", "no_result", "pending", "retransmissions", "checksum_errors",
           "ACK min", "ACK median", "ACK p95", "ACK max", "result median", "result max"]


def stats_text(path, columns: int | None) -> str:
    return run_piped("stats", path, columns=columns)


def _ms(seconds) -> str:
    return f"{seconds * 1000:.1f} ms"   # the sample's latencies are all under a second


def expected_cells(counts: dict) -> dict:
    """What each row of a table must show, worked out from the JSON figures."""
    out = {}
    for key, c in counts.items():
        for name in COLUMNS[:9]:
            out[key, name] = f"{c[name]:,}"
        for name, which, stat in [("ACK min", "ack_latency", "min"), ("ACK median", "ack_latency", "median"),
                                  ("ACK p95", "ack_latency", "p95"), ("ACK max", "ack_latency", "max"),
                                  ("result median", "result_latency", "median"),
                                  ("result max", "result_latency", "max")]:
            out[key, name] = _ms(c[which][stat]) if c[which]["count"] else ""
    return out


@pytest.mark.parametrize("columns", [80, None, 120])
def test_stats_fits_the_width_with_every_cell_whole(columns):
    text = stats_text(SOCAT_LOG, columns)
    assert_fits(text, columns or 80)   # piped without COLUMNS: 80, not the 134 a table would need
    data = json.loads(run_cli("stats", SOCAT_LOG, "--format", "json").stdout)
    tables = read_tables(text)
    per_command = [t for t in tables if t.title.startswith("per command")]
    per_device = [t for t in tables if t.title.startswith("per device")]
    assert len(per_command) + len(per_device) == len(tables)
    assert headers(per_command) == ["command", *COLUMNS] and headers(per_device) == ["device", *COLUMNS]
    assert cells(per_command) == expected_cells(data["by_command"])
    assert cells(per_device) == expected_cells(data["by_device"])


def test_the_summary_fits_80_columns_and_says_each_count_once():
    data = json.loads(run_cli("stats", BUS, "--format", "json").stdout)
    text = stats_text(BUS, 80)
    assert_fits(text, 80)
    lines = text.split("per command")[0].splitlines()
    assert data["events"] > 1000     # thousands separators in every count, as in the tables
    assert lines[0] == (f"{data['events']:,} events, {data['commands']:,} commands (no time in this capture)  "
                        f"bytes: line AB {data['bytes']['AB']:,}")
    assert lines[1] == "  ".join(f"{s} {data['status'][s]}"
                                 for s in ("ok", "nak", "nic", "no_ack", "no_result", "pending"))
    assert lines[2] == f"retransmissions {data['retransmissions']}  orphans {data['orphans']}"
    assert lines[3].startswith(f"checksum errors {data['checksum_errors']} (")
    assert lines[4].startswith(f"noise {data['noise']['events']} events / {data['noise']['bytes']} bytes")
    # the problems line, longer than 80 columns, is wrapped at spaces, never cut
    problems = " ".join(lines[5:])
    assert len(problems) > 80
    assert problems == "problems (events per category): " + ", ".join(f"{k} {v}" for k, v in data["problems"].items())
