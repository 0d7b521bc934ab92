"""``gimbalscope report`` on a dataset of hand-written timed captures over four
days: one device whose ACK latency and NAKs grow, one steady. The expected
rates and percentiles are worked out here from the captures' contents."""

from __future__ import annotations

import json
import re
import shutil
import struct
import subprocess
import zlib

import pytest

from tests.conftest import frame, run_cli
from tests.integration.test_query import ACK, BYTE, NAK, socat_log
from tests.text_tables import assert_fits, cells, headers, read_tables, run_piped

DAYS = ["2026-04-06", "2026-04-07", "2026-04-08", "2026-04-09"]
WORSE_MS = [10, 14, 18, 22]        # 1.1.1's ACK latency each day
WORSE_NAKS = [0, 1, 2, 4]          # of its 25 commands, NAKed
STEADY_MS = 10                     # 1.1.2, every day, never a NAK
PER_DAY = 25


def day_log(path, day: str, worse_ms: int, naks: int) -> None:
    entries = []
    t = 0.0
    for i in range(PER_DAY):
        for device, ms, nak in (((1, 1, 1), worse_ms, i < naks), ((1, 1, 2), STEADY_MS, False)):
            entries.append((t, ">", frame(device, 0, "HO")))
            entries.append((t + ms / 1000 + BYTE, "<", NAK if nak else ACK))
            t += 0.2
    socat_log(path, day, entries)


@pytest.fixture
def fleet(tmp_path):
    logs = []
    for day, ms, naks in zip(DAYS, WORSE_MS, WORSE_NAKS):
        log = tmp_path / f"{day}.log"
        day_log(log, day, ms, naks)
        logs.append(log)
    out = tmp_path / "fleet"
    r = run_cli("export", *logs, "-o", out, "--tz", "UTC", timeout=300)
    assert r.returncode == 0, r.stderr
    return out


def test_the_worsening_device_is_flagged_and_the_steady_one_not(fleet):
    r = run_cli("report", fleet, "--format", "json")
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    devices = {d["device"]: d for d in data["devices"]}
    worse, steady = devices["1.1.1"], devices["1.1.2"]
    assert {t["what"] for t in worse["trending_worse"]} == {"ack_p95", "error_rate"}
    assert steady["trending_worse"] == []
    # each day by hand: 25 commands, the NAKed ones errors; every answer after the day's latency
    for p, day, ms, naks in zip(worse["periods"], DAYS, WORSE_MS, WORSE_NAKS):
        assert (p["start"], p["commands"], p["ok"], p["nak"]) == (day, PER_DAY, PER_DAY - naks, naks)
        assert p["error_rate"] == pytest.approx(naks / PER_DAY)
        assert p["ack_p95_ms"] == pytest.approx(ms, abs=0.01)
    latency = next(t for t in worse["trending_worse"] if t["what"] == "ack_p95")
    # the least-squares line through 10, 14, 18, 22 ms is the points themselves
    assert latency["first"] == pytest.approx(0.010, abs=1e-5) and latency["last"] == pytest.approx(0.022, abs=1e-5)
    errors = next(t for t in worse["trending_worse"] if t["what"] == "error_rate")
    # rates 0, .04, .08, .16 on days 0..3: slope .26 / 5 = .052 a day
    assert errors["slope_per_day"] == pytest.approx(0.052)
    assert [p["ack_p95_ms"] for p in steady["periods"]] == pytest.approx([STEADY_MS] * 4, abs=0.01)


def test_text_names_the_worsening_device_first(fleet):
    r = run_cli("report", fleet)
    assert r.returncode == 0, r.stderr
    head = r.stdout.split("\n\n")[0] if "\n\n" in r.stdout else r.stdout[:400]
    assert "1 trending worse" in r.stdout
    assert "1.1.1" in head and "p95 ACK latency 10.0 → 22.0 ms" in r.stdout
    assert r.stdout.index("1.1.1") < r.stdout.index("1.1.2")


def test_week_periods(fleet):
    data = json.loads(run_cli("report", fleet, "--format", "json", "--period", "week").stdout)
    periods = {d["device"]: d["periods"] for d in data["devices"]}
    assert [(p["start"], p["commands"], p["nak"]) for p in periods["1.1.1"]] == [
        ("2026-04-06", 4 * PER_DAY, sum(WORSE_NAKS))]   # 2026-04-06 is a Monday


def test_html_is_one_self_contained_page(fleet, tmp_path):
    page = tmp_path / "report.html"
    r = run_cli("report", fleet, "--html", page)
    assert r.returncode == 0, r.stderr
    text = page.read_text()
    assert text.count("<svg") == 4   # two charts for each of the two devices
    # nothing fetched: no script, no link, no src; the only URLs are SVG's namespace names
    assert "<script" not in text and "<link" not in text and " src=" not in text
    urls = {u for u in re.findall(r"https?://[^\"' )]+", text)}
    assert urls <= {"http://www.w3.org/2000/svg", "http://www.w3.org/1999/xlink"}
    assert "trending worse" in text and "1.1.1" in text
    r = run_cli("report", fleet, "--html", page)
    assert r.returncode != 0 and "exists" in r.stderr   # never over a file without --force


def test_bad_dataset_and_bad_html_path(tmp_path, fleet):
    r = run_cli("report", tmp_path / "nowhere")
    assert r.returncode == 2 and "no such dataset" in r.stderr and "Traceback" not in r.stderr
    r = run_cli("report", fleet, "--html", tmp_path / "no" / "such" / "dir" / "r.html")
    assert r.returncode != 0 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1


def _png_colours(path) -> int:
    """Distinct pixel values of an 8-bit RGB(A) PNG, read with the stdlib only."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, _height, depth, colour = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and colour in (2, 6)
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = width * channels + 1
    seen = set()
    # unfiltered values are enough to tell a blank page from a drawn one: sample rows
    for y in range(0, len(raw) // stride, 7):
        row = raw[y * stride + 1:(y + 1) * stride]
        seen.update(row[i:i + channels] for i in range(0, len(row), channels * 5))
    return len(seen)


def test_the_page_renders_in_a_real_browser(fleet, tmp_path):
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("chromium is not installed (.ci/run installs Debian's chromium)")
    page = tmp_path / "report.html"
    assert run_cli("report", fleet, "--html", page).returncode == 0
    shot = tmp_path / "shot.png"
    subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}",
                    "--window-size=1200,1600", page.as_uri()], capture_output=True, timeout=120, check=False)
    assert shot.exists() and shot.stat().st_size > 10_000
    assert _png_colours(shot) > 20   # text, tables and charts, not one blank colour


# ------------------------------------------------------------ the text fits; one name a column
# named as the JSON names the values (the latencies as stats names them: ack_p50_ms is "ACK median"), the
# counts as `stats` names them
COLUMNS = ["commands", "ok", "nak", "nic", "no_ack", "no_result", "pending", "error_rate", "nak_rate",
           "ACK median", "ACK p95", "result median", "result p95"]


@pytest.mark.parametrize("columns", [80, None])
def test_text_fits_the_width_and_shows_every_cell_whole(fleet, columns):
    text = run_piped("report", fleet, columns=columns)
    assert_fits(text, columns or 80)
    tables = read_tables(text)
    worse = [t for t in tables if t.title.startswith("1.1.1")]
    assert len(worse) > 1 and worse[0].title == "1.1.1  trending worse"
    assert headers(worse) == ["day", *COLUMNS]
    shown = cells(worse)
    for day, ms, naks in zip(DAYS, WORSE_MS, WORSE_NAKS):
        rate = f"{naks / PER_DAY:.1%}"        # every error is a NAK: both rates the same
        # HO has no result: no result latency; every answer (ACK or NAK) after the day's latency
        assert [shown[day, c] for c in COLUMNS] == [
            str(PER_DAY), str(PER_DAY - naks), str(naks), "0", "0", "0", "0", rate, rate,
            f"{ms}.0 ms", f"{ms}.0 ms", "", ""], day
    steady = cells([t for t in tables if t.title.startswith("1.1.2")])
    assert {steady[day, "ACK p95"] for day in DAYS} == {f"{STEADY_MS}.0 ms"}


def test_the_page_names_the_columns_as_the_text_does(fleet, tmp_path):
    page = tmp_path / "report.html"
    assert run_cli("report", fleet, "--html", page).returncode == 0
    html = page.read_text()
    first = html.split("<table>")[1].split("</tr>")[0]
    assert re.findall(r"<th>(.*?)</th>", first) == ["day", *COLUMNS]
    assert "NAKs" not in html and "<th>errors</th>" not in html
    # a row of 1.1.1's last day, as the text shows it
    last = f"<tr><td>{DAYS[-1]}</td>" + "".join(f"<td>{c}</td>" for c in [
        "25", "21", "4", "0", "0", "0", "0", "16.0%", "16.0%", "22.0 ms", "22.0 ms", "", ""]) + "</tr>"
    assert last in html
    assert "<p>2 devices, 200 commands, per day.</p>" in html   # 25 commands a day, 4 days, 2 devices


def test_report_and_stats_name_a_quantity_alike():
    """One name a column: the counts and latencies the report shares with stats (and
    the TUI's statistics screen, which draws stats's tables) read the same."""
    from analyzer.analysis.stats import COUNT_COLUMNS, LATENCY_COLUMNS
    from analyzer.dataset.report import PERIOD_COLUMNS
    stats_names = {name for group in COUNT_COLUMNS for name in group} | {
        label for group in LATENCY_COLUMNS for label, *_ in group}
    report_names = {name for group in PERIOD_COLUMNS for name in group}
    # the counts, and the latencies both show; the rates and result p95 are the report's own
    for name in ("commands", "ok", "nak", "nic", "no_ack", "no_result", "pending",
                 "ACK median", "ACK p95", "result median"):
        assert name in report_names and name in stats_names, name
    assert not any("p50" in n or "NAKs" in n for n in report_names)
