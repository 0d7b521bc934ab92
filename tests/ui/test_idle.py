"""An idle live screen does nothing on a timer but its clock: the feed sends no
batch while nothing changes, no timer of the screen's fires (the detail panes
catch up once after a move, a replay is paced only while it plays) and no
widget is redrawn but the status bar, once a second for its clock, which stops
while a full screen hides the bar. Over quiet pseudo-terminals opened with
pyserial, as the live tests; nothing here measures time."""

from __future__ import annotations

import asyncio

import pytest
from textual.message_pump import MessagePump
from textual.widget import Widget

from analyzer.tui.run import make_app, stop_feed
from analyzer.tui.screens.stats import StatsScreen
from tests.ui.test_pilot import SIZE, exchange, live_on_ptys, run, settle

CLOCK = "status clock"   # the status bar's timer (widgets/status_bar.py)


class Wakeups:
    """What the app does on its own, seen through Textual's public methods: the
    timers of this code base that fire (``set_timer``, ``set_interval``: their
    names, each time their callback runs) and the widgets asked to redraw
    (``Widget.refresh``: their class names). Textual's own timers are left out
    but for what they redraw (its screen's repaint runs after a redraw asked)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.fired: list[str] = []
        self.redrawn: list[str] = []
        set_timer, set_interval, refresh = MessagePump.set_timer, MessagePump.set_interval, Widget.refresh

        def counted(callback, name):
            if callback is None or not callback.__module__.startswith("analyzer."):
                return callback

            def fire():
                self.fired.append(name)
                return callback()
            return fire

        def timer(node, delay, callback=None, *, name=None, pause=False):
            return set_timer(node, delay, counted(callback, name), name=name, pause=pause)

        def interval(node, every, callback=None, *, name=None, repeat=0, pause=False):
            return set_interval(node, every, counted(callback, name), name=name, repeat=repeat, pause=pause)

        def redraw(widget, *regions, **kw):
            self.redrawn.append(type(widget).__name__)
            return refresh(widget, *regions, **kw)

        monkeypatch.setattr(MessagePump, "set_timer", timer)
        monkeypatch.setattr(MessagePump, "set_interval", interval)
        monkeypatch.setattr(Widget, "refresh", redraw)

    async def over(self, seconds: float) -> tuple[set[str], set[str]]:
        """(the timers that fired, the widgets redrawn) in the next ``seconds``,
        the test doing nothing meanwhile."""
        fired, redrawn = len(self.fired), len(self.redrawn)
        await asyncio.sleep(seconds)
        return set(self.fired[fired:]), set(self.redrawn[redrawn:])


def test_an_idle_live_screen_wakes_for_its_clock_only_and_gets_no_batches(monkeypatch):
    wakeups = Wakeups(monkeypatch)
    app, ma, mb = live_on_ptys()
    batches = []

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 2)
            # the rates fall to 0 once the last second holds no bytes: then nothing changes
            await settle(pilot, app, lambda a: str(a.status_bar.render()).count(" 0 B/s") == 2)
            await pilot.pause(0.5)   # the screen has caught up with the last change
            from_feed = app.status_bar.from_feed
            app.status_bar.from_feed = lambda b: (batches.append(b), from_feed(b))[1]
            assert app.status_bar.clock_running          # the elapsed time, once a second
            fired, redrawn = await wakeups.over(1.5)
            assert batches == [] and fired == {CLOCK} and redrawn == {"StatusBar"}
            # under a full screen the clock stops; back, it runs again
            await pilot.press("S")
            await settle(pilot, app, lambda a: isinstance(a.screen, StatsScreen))
            await pilot.pause()
            assert not app.status_bar.clock_running
            assert await wakeups.over(1.5) == (set(), set())
            await pilot.press("escape")
            await settle(pilot, app, lambda a: a.screen is a.main)
            assert app.status_bar.clock_running
            # traffic again: batches come, and the screen follows
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 4)
            assert batches
        stop_feed(app)

    run(drive())


def test_a_replay_played_to_its_end_stops_its_pace(monkeypatch):
    # a timed capture played fast: once at its last event, nothing ticks on
    import analyzer
    from tests.conftest import SOCAT_LOG

    wakeups = Wakeups(monkeypatch)
    app = make_app(analyzer.open(SOCAT_LOG), mode="replay", speed=1000.0)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.model.shown == len(a.model.store)
                         and not a.model.replay.playback.playing,
                         what=lambda a: f"shown {a.model.shown} of {len(a.model.store)}")
            await pilot.pause(0.5)   # the screen has caught up with the last change
            idle = await wakeups.over(0.5)   # five of the pace's steps, were it running
            return idle, app.model.replay.position, app.model.store.t[len(app.model.store) - 1]
    try:
        idle, position, last = run(drive())
    finally:
        stop_feed(app)
    assert idle == (set(), set()) and position == last
