"""An idle live screen does nothing on a timer but its clock: the feed sends no
batch while nothing changes, no interval timer runs (the detail panes catch up
once after a move, a replay is paced only while it plays), and the clock stops
while a full screen hides the status bar. Over quiet pseudo-terminals opened
with pyserial, as the live tests; nothing here measures time."""

from __future__ import annotations

from analyzer.tui.run import make_app, stop_feed
from analyzer.tui.screens.stats import StatsScreen
from tests.ui.test_pilot import SIZE, exchange, live_on_ptys, run, settle


def running_intervals(app) -> list[str]:
    """The repeating timers of the app, its screens and their widgets that are
    running (not paused, not stopped): Textual keeps each node's timers."""
    nodes = [app, *app.screen_stack]
    for screen in app.screen_stack:
        nodes.extend(screen.walk_children())
    found = []
    for node in nodes:
        for timer in list(node._timers):
            task = timer._task
            if timer._repeat is None and task is not None and not task.done() and timer._active.is_set():
                found.append(f"{node!r}: {timer.name}")
    return found


def test_an_idle_live_screen_runs_no_interval_and_gets_no_batches():
    app, ma, mb = live_on_ptys()
    batches = []

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 2)
            # the rates fall to 0 once the last second holds no bytes: then nothing changes
            await settle(pilot, app, lambda a: str(a.status_bar.render()).count(" 0 B/s") == 2)
            await pilot.pause(0.5)   # the screen has caught up with the last change
            batch = app.status_bar.batch
            app.status_bar.batch = lambda b: (batches.append(b), batch(b))[1]
            assert running_intervals(app) == []
            assert app.status_bar.clock_running          # the elapsed time, once a second
            await pilot.pause(1.0)
            assert batches == [] and running_intervals(app) == []
            # under a full screen the clock stops; back, it runs again
            await pilot.press("S")
            await settle(pilot, app, lambda a: isinstance(a.screen, StatsScreen))
            assert not app.status_bar.clock_running and running_intervals(app) == []
            await pilot.press("escape")
            await settle(pilot, app, lambda a: a.screen is a.main)
            assert app.status_bar.clock_running
            # traffic again: batches come, and the screen follows
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 4)
            assert batches
        stop_feed(app)

    run(drive())


def test_a_replay_played_to_its_end_stops_its_pace():
    # a timed capture played fast: once at its last event, nothing ticks on
    import analyzer
    from tests.conftest import SOCAT_LOG

    app = make_app(analyzer.open(SOCAT_LOG), mode="replay", speed=1000.0)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.model.shown == len(a.model.store)
                         and not a.model.replay.playback.playing,
                         what=lambda a: f"shown {a.model.shown} of {len(a.model.store)}")
            await pilot.pause()
            return running_intervals(app), app.model.replay.position, app.model.store.t[len(app.model.store) - 1]
    try:
        intervals, position, last = run(drive())
    finally:
        stop_feed(app)
    assert intervals == [] and position == last
