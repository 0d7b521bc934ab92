"""The status bar keeps its two rows at any width: a long note, finding, filter,
path or port name is shortened with an ellipsis, and the parts a user needs
first (ports' states, the recording, counts, follow, the end of a capture) stay
when the rest is left out. Driven with Textual's Pilot at narrow terminals; the
feed is the test's, so the texts do not depend on timing."""

from __future__ import annotations

import pytest
from textual.geometry import Region

from analyzer.tui.app import GimbalscopeApp
from analyzer.tui.feed import FeedBatch, LineStatus
from analyzer.tui.model import CaptureModel
from analyzer.tui.widgets import EventList
from analyzer.tui.widgets.status_bar import Part, fit
from tests.ui.test_pilot import run, settle
from tests.ui.test_status_bar import StillFeed

NOTE = ("/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0: lost ([Errno 5] Input/output error); "
        "keeping what was captured, reopening when it returns")
PORTS = ("/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0",
         "/dev/serial/by-id/usb-Prolific_Technology_Inc._USB-Serial_Controller_D-if00-port0")
RECORDING = "/home/operator/captures/site-north/gimbal-rig-7/2024-05-17T08-31-02.mcap"


def still_live_app() -> tuple[GimbalscopeApp, list[StillFeed]]:
    feeds: list[StillFeed] = []

    def make_feed(deliver) -> StillFeed:
        feeds.append(StillFeed(deliver))
        return feeds[-1]
    app = GimbalscopeApp(CaptureModel(follow=True), make_feed, mode="live", source=" + ".join(PORTS),
                         settings="115200 8N1")
    return app, feeds


def long_batch(**kw) -> FeedBatch:
    lines = [LineStatus("A", PORTS[0], "lost", rate=0.0), LineStatus("B", PORTS[1], "open", rate=11520.0)]
    return FeedBatch([], [], lines, skew=0.0123, recording=RECORDING, recording_bytes=12_300_000,
                     warnings=[NOTE], settings="115200 8N1", **kw)


def rows(app) -> list[str]:
    """The status bar's rows as the terminal shows them, without its padding."""
    bar = app.status_bar
    return [strip.text[1:-1] for strip in bar.render_lines(Region(0, 0, *bar.outer_size))]


@pytest.mark.parametrize("width", [40, 60, 80, 120])
def test_a_long_note_keeps_the_bar_on_two_rows(width):
    app, feeds = still_live_app()

    async def drive():
        async with app.run_test(size=(width, 24)) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            feeds[0].deliver(long_batch())
            await pilot.pause()
            bar = app.status_bar
            assert bar.outer_size.height == 2 and app.query_one(EventList).region.y == 2
            wire, events = (line.rstrip() for line in rows(app))
            text = str(bar.render()).splitlines()
            assert len(text) == 2 and all(len(line) <= width - 2 for line in text), text
            # what a user needs first: each line's state and the recording
            assert "A" in wire and "lost" in wire and "open" in wire and "● REC" in wire, wire
            assert events.startswith("0 events  0 errors") and "FOLLOW" in events, events
            if width >= 80:   # room for the note, shortened; the paths keep their ends, as long as each other
                assert events.endswith("…") and "FOLLOW  /dev/serial/by-id/usb-FTDI" in events, events
                assert "A …" in wire and "B …" in wire and "● REC …" in wire and ".mcap 12.3 MB" in wire, wire
            if width >= 120:   # and for the lines' rates, the settings, the skew and the clock
                assert "0 B/s" in wire and "11.5 kB/s  115200 8N1  skew +12.3 ms" in wire, wire
                assert wire.endswith("12.3 MB  00:00:00"), wire
            # the capture ends: said at any width
            feeds[0].deliver(long_batch(done=True))
            await pilot.pause()
            assert "capture ended" in rows(app)[1] and bar.outer_size.height == 2

    run(drive())


def test_resizing_refits_the_bar():
    app, feeds = still_live_app()

    async def drive():
        async with app.run_test(size=(120, 24)) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            feeds[0].deliver(long_batch())
            await pilot.pause()
            wide = rows(app)
            await pilot.resize_terminal(60, 24)
            await pilot.pause()
            narrow = rows(app)
            assert len(narrow[1].rstrip()) <= 58 < len(wide[1].rstrip()), (wide, narrow)
            assert app.status_bar.outer_size.height == 2

    run(drive())


def test_fit_shortens_free_text_then_leaves_out_the_least_needed():
    def parts():
        return [Part(9, "12 events"), Part(2, "9600 8N1"), Part(6, "filter: ", free="kind == 'noise'"),
                Part(5, free="a note that goes on and on")]
    assert fit(parts(), None).plain == "12 events  9600 8N1  filter: kind == 'noise'  a note that goes on and on"
    # the note is shortened first (its rank, 5, is the lowest free text's) once the settings are left out
    assert fit(parts(), 60).plain == "12 events  filter: kind == 'noise'  a note that goes on and…"
    assert fit(parts(), 44).plain == "12 events  filter: kind == 'noise'  a note…"
    # too little room for the shortest note: it is left out, then the filter is shortened
    assert fit(parts(), 40).plain == "12 events  filter: kind == 'noise'"
    assert fit(parts(), 30).plain == "12 events  filter: kind == 'n…"
    assert fit(parts(), 6).plain == "12 ev…"   # nothing left to leave out: cropped
    # a path keeps its end
    assert fit([Part(6, free="/very/long/folder/name/tap.log", cut_start=True)], 12).plain == "…ame/tap.log"
