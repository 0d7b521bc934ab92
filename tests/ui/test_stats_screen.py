"""The TUI's statistics screen (``S``) shows what ``gimbalscope stats`` prints, in
its words: the same summary lines and the same tables, every column named as the
command names it, fitted to the screen's width (no cell cut)."""

import asyncio

from textual.geometry import Region
from textual.widgets import Static

import analyzer
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import SOCAT_LOG
from tests.pure.test_stats import stats_text
from tests.text_tables import cells, headers, read_tables
from tests.ui.test_pilot import settle


def screen_text(width: int, filter_text: str | None = None) -> dict[str, str]:
    """The statistics screen's parts as drawn on a terminal ``width`` columns wide."""
    app = make_app(analyzer.open(SOCAT_LOG), mode="view", filter_text=filter_text)

    async def drive():
        async with app.run_test(size=(width, 40)) as pilot:
            await settle(pilot, app, lambda a: a.model.done)
            await pilot.press("S")
            await pilot.pause(0.2)
            out = {}
            for part in ("summary", "by-command", "by-device"):
                w = app.screen.query_one(f"#{part}", Static)
                strips = w.render_lines(Region(0, 0, w.size.width, w.size.height))
                out[part] = "\n".join(strip.text.rstrip() for strip in strips)
            out["width"] = app.screen.query_one("#by-device", Static).size.width
            return out

    try:
        return asyncio.run(drive())
    finally:
        stop_feed(app)


def test_the_screen_names_and_shows_what_the_command_prints():
    shown = screen_text(80)
    assert "…" not in shown["by-command"] + shown["by-device"]
    # the command at the width of the screen's tables gives the same text
    printed = stats_text(SOCAT_LOG, shown["width"])
    tables = read_tables(printed)
    command = [t for t in tables if t.title.startswith("per command")]
    device = [t for t in tables if t.title.startswith("per device")]
    for part, theirs in (("by-command", command), ("by-device", device)):
        ours = read_tables(shown[part])
        assert len(ours) > 1     # 80 columns: split, as the command splits them
        assert headers(ours) == headers(theirs)
        assert [t.headers for t in ours] == [t.headers for t in theirs]
        assert cells(ours) == cells(theirs)
    assert headers(device)[1:9] == ["commands", "ok", "nak", "nic", "no_ack", "no_result", "pending",
                                    "retransmissions"]
    summary = printed.split("\nper command")[0]
    assert " ".join(shown["summary"].split()) == " ".join(summary.split())


def test_with_a_filter_the_screen_shows_the_filtered_rows_as_stats_filter_prints_them():
    from tests.pure.test_stats import run_piped

    text = 'device == "1.1.2"'
    shown = screen_text(120, text)
    head, _, rest = shown["summary"].partition("\n")
    assert head.startswith("the 142 rows of the filter: ") and text in head
    printed = run_piped("stats", SOCAT_LOG, "--filter", text, columns=shown["width"])
    assert " ".join(rest.split()) == " ".join(printed.split("\nper command")[0].split())
    tables = read_tables(printed)
    ours = read_tables(shown["by-device"])
    assert cells(ours) == cells([t for t in tables if t.title.startswith("per device")])
