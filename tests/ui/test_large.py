"""The TUI on captures too large to handle row by row on the screen's thread:
End while a file loads, a filter swept in the background with its progress on
the status line and stopped by Esc, and the number column's width. Driven by
keys with Textual's Pilot."""

from __future__ import annotations

import asyncio
import threading

import pytest

import analyzer
from analyzer.formats import sweep
from analyzer.simulation.traffic import generate
from analyzer.tui.run import make_app, stop_feed
from analyzer.tui.screens import capture as capture_screen
from analyzer.tui.widgets import EventList
from tests.ui.test_pilot import SIZE, settle


@pytest.fixture
def big_capture(tmp_path):
    """A single-line raw dump of a few thousand events."""
    tr = generate(2000, baud=115200, seed=4, noise_rate=0.01)
    path = tmp_path / "bus.bin"
    path.write_bytes(tr.single_line())
    return str(path)


def in_view(path: str, drive, ready=lambda app: app.model.done) -> None:
    """``await drive(app, pilot)`` on the TUI viewing ``path`` once ``ready(app)``
    (by default: the file has loaded)."""
    app = make_app(analyzer.open(path, baud=115200), mode="view")

    async def run():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, ready)
            await drive(app, pilot)
    asyncio.run(run())
    stop_feed(app)


def test_end_while_loading_follows_to_the_last_event(big_capture):
    total = sum(1 for _ in analyzer.open(big_capture, baud=115200))

    async def drive(app, pilot):
        await pilot.press("end")          # the list's own End, pressed as early as the first rows
        await settle(pilot, app, lambda a: a.model.done)
        await pilot.pause()
        lst = app.query_one(EventList)
        assert app.model.follow and lst.selected == total == app.model.shown
    in_view(big_capture, drive, ready=lambda a: a.model.row_count > 0)


def test_a_background_filter_shows_progress_and_esc_stops_it(big_capture, monkeypatch):
    # every filter goes to the background, one event a step; the sweep is held at
    # the first event from 500 on it rebuilds until Esc has been pressed, so the
    # test does not race it. The filter is one the store's columns cannot decide
    # (the payload's text), so the closure runs on rebuilt events
    monkeypatch.setattr(capture_screen, "BACKGROUND_ROWS", 1)
    monkeypatch.setattr(sweep, "STEP", 1)
    escaped = threading.Event()
    reached = threading.Event()

    async def drive(app, pilot):
        store = app.model.store
        real = store.event

        def event(i):
            if i >= 500 and not reached.is_set():
                reached.set()
                escaped.wait(30)
            return real(i)
        store.event = event
        await pilot.press("slash", *'payload != "zz"', "enter")
        await settle(pilot, app, lambda a: reached.is_set() and "filtering" in a.sweep_text)
        status = str(app.status_bar.render())
        assert "filtering" in status and "Esc stops" in status
        await pilot.press("escape")
        escaped.set()
        await pilot.pause(0.2)
        assert app.model.filter_text == "" and app.sweep_text == ""
        assert app.model.row_count == app.model.shown      # the view is as it was
        # the same filter left to run: it applies, and only noise rows remain
        store.event = real
        await pilot.press("slash", "ctrl+u", *'kind == "noise"', "enter")
        await settle(pilot, app, lambda a: a.model.filter_text == 'kind == "noise"')
        kinds = {app.model.row(r).kind for r in range(app.model.row_count)}
        assert kinds == {"noise"}
    in_view(big_capture, drive)


def test_the_number_column_widens_for_large_numbers(big_capture):
    async def drive(app, pilot):
        lst = app.query_one(EventList)
        assert lst.column_widths()[0] == 6            # "No." and up to 999,999
        app.model.shown = 12_345_678                 # as if a day had loaded: 8 digits
        assert lst.column_widths()[0] == 8
        app.model.shown = len(app.model.store)
    in_view(big_capture, drive)


def test_go_to_an_event_number(big_capture):
    async def drive(app, pilot):
        lst = app.query_one(EventList)
        await pilot.press("ctrl+g", *"1500", "enter")
        await pilot.pause()
        assert lst.selected == 1500 and not app.model.follow
        assert 1500 - lst.scroll_y in range(1, lst.size.height)     # on screen
        await pilot.press("colon", *str(app.model.shown + 1), "enter")   # past the last: refused
        await pilot.pause()
        assert lst.selected == 1500
        answer = next(n for n in range(1, 100) if app.model.event(n).kind == "ack")
        app.model.set_filter('kind == "command"')
        lst.rows_changed()
        await pilot.press("ctrl+g", *str(answer), "enter")   # filtered out: the next command
        await pilot.pause()
        ev = app.model.event(lst.selected)
        assert ev.kind == "command" and lst.selected > answer
    in_view(big_capture, drive)


def test_plot_reads_position_columns():
    from analyzer.tui.model.plots import Series
    from analyzer.tui.screens.plots import plot

    s = Series()
    for t, deg in ((0.0, -10.0), (5.0, 0.0), (10.0, 10.0)):
        s.append(t, deg)
    rows = plot({"reported azimuth": s}, width=11, height=3).plain.splitlines()
    # 10.00° at the top right, 0 in the middle, -10.00° at the bottom left
    assert rows[0].startswith("   10.00° │") and rows[0].endswith("●")
    assert rows[1][len("          │"):] == "     ●     "
    assert rows[2].startswith("  -10.00° │●")
