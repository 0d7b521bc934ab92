"""The TUI driven by keys with Textual's Pilot: filtering, error and pair jumps,
follow mode, replay controls, the record toggle. Captures are real: a socat-log
file, and a live tap over pseudo-terminals opened with pyserial."""

import asyncio
import io
import os
import time
import tty
from collections import Counter

import analyzer
from analyzer.analysis.findings import LINES_SWAPPED
from analyzer.capture import open_live
from analyzer.tui.run import make_app, stop_feed
from analyzer.tui.widgets import EventList
from tests.conftest import frame
from tests.integration.test_mcap import doctor, jsonl
from tests.tui_fixtures import write_capture

SIZE = (120, 40)


def run(coro):
    return asyncio.run(coro)


# A guard against a hang, not a timing check: on a loaded machine the feed and the
# doctor can take many times longer than on a quiet one, and the test must not fail then.
HANG_GUARD = float(os.environ.get("HANG_GUARD", "120"))


async def settle(pilot, app, until, seconds=HANG_GUARD, what=lambda app: ""):
    """Let the feed deliver until ``until(app)`` holds (``what`` says what there was
    instead, if it never does)."""
    end = time.monotonic() + seconds
    while not until(app):
        assert time.monotonic() < end, f"timed out waiting for the TUI: {what(app)}"
        await pilot.pause(0.05)


async def record_three_exchanges(pilot, app, ma: int, mb: int) -> None:
    """The record key, three exchanges with 1.1.2 on the wire, the record key again."""
    await pilot.press("r")
    await settle(pilot, app, lambda a: a.last is not None and a.last.recording)
    for _ in range(3):
        exchange(ma, mb, dst=(1, 1, 2))
    await settle(pilot, app, lambda a: sum(1 for e in a.model.events if e.dst == (1, 1, 2)) >= 3)
    await pilot.press("r")
    await settle(pilot, app, lambda a: a.last is not None and not a.last.recording)


def selected(app) -> int | None:
    return app.query_one(EventList).selected


def view_of_fixture(tmp_path, **kw):
    """The TUI on the scripted conversation (tests/tui_fixtures.py): (app, expected)."""
    path = tmp_path / "tap.log"
    expected = write_capture(path)
    return make_app(analyzer.open(str(path)), mode="view", **kw), expected


async def all_loaded(pilot, app):
    await settle(pilot, app, lambda a: a.model.done and a.model.row_count == 13)


def test_view_keys_errors_pairs_filter(tmp_path):
    app, expected = view_of_fixture(tmp_path)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await all_loaded(pilot, app)
            assert selected(app) == 1 and not app.model.follow     # a file opens at its start
            await pilot.press("e")
            assert selected(app) == expected["errors"][0] == 4
            await pilot.press("p")
            assert selected(app) == 5                           # its NAK
            await pilot.press("p")
            assert selected(app) == 4
            await pilot.press("e", "e", "E")          # 4 → 5 → 6 → back to 5
            assert selected(app) == 5
            # the filter bar: validated as you type, applied on Enter
            await pilot.press("slash")
            await pilot.press(*'kind == "comand"')
            err = str(app.query_one("#filter-error").render())
            assert "column 9" in err and ">>>\"comand\"" in err   # points at the token
            await pilot.press("escape")
            assert app.model.filter_text == "" and app.model.row_count == 13
            await pilot.press("slash", *'kind == "ack"', "enter")
            assert [app.model.row(i).number for i in range(app.model.row_count)] == [2, 7, 9, 13]
            assert selected(app) == 7          # the nearest shown event to where the cursor was
            await pilot.press("down")
            assert selected(app) == 9
            # history: the previous filter comes back with up
            await pilot.press("slash", "ctrl+u", "up")
            assert app.query_one("#filter").value == 'kind == "ack"'
            await pilot.press("escape")
        stop_feed(app)

    run(drive())


def notices(app) -> list[str]:
    """Every notification the app gives from now on."""
    said: list[str] = []
    notify = app.notify
    app.notify = lambda message, *a, **k: (said.append(message), notify(message, *a, **k))[1]
    return said


def test_pair_key_says_when_the_partner_is_filtered_out(tmp_path):
    app, _expected = view_of_fixture(tmp_path)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await all_loaded(pilot, app)
            said = notices(app)
            await pilot.press("slash", *'kind == "ack"', "enter")
            assert selected(app) == 2                    # the ACK of #1, which the filter hides
            await pilot.press("p")
            assert selected(app) == 2                    # the cursor stays
            assert said[-1] == "#1, the partner, is filtered out (/ changes the filter)"
            await pilot.press("colon", *"6", "enter")   # the go-to prompt's word for the same
            assert said[-1] == "#6 is filtered out: at the nearest shown event" and selected(app) == 7
            await pilot.press("slash", "ctrl+u", "enter")   # no filter: p goes there
            await pilot.press("p")
            assert selected(app) == 6 and len(said) == 2
        stop_feed(app)

    run(drive())


def help_text(app) -> str:
    """The help screen's key table as plain text."""
    from rich.console import Console
    from textual.widgets import Static

    console = Console(width=120, record=True, file=io.StringIO())
    console.print(app.screen.query(Static).first().content)
    return console.export_text()


def test_help_shows_keys_as_typed_and_as_the_keymap_binds_them(tmp_path):
    from analyzer.tui.screens.help import HelpScreen

    app, _expected = view_of_fixture(tmp_path, keymap={"app.next_error": "x"})

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await all_loaded(pilot, app)
            await pilot.press("question_mark")
            assert isinstance(app.screen, HelpScreen)
            rows = {line.split("│")[3].strip(): line.split("│")[1].strip()
                    for line in help_text(app).splitlines() if line.count("│") == 4}
            assert rows["app.seek_forward"] == ">" and rows["app.seek_back"] == "<"
            assert rows["app.seek_forward_1"] == "." and rows["app.seek_back_1"] == ","
            assert rows["app.next_mark"] == "'" and rows["app.filter"] == "/" and rows["app.help"] == "?"
            assert rows["app.goto"] == "^g" and rows["app.quit"] == "q or ^c"   # as the footer shows ctrl
            assert rows["app.talk"] == ":"   # live --talk's prompt, the go-to prompt elsewhere
            assert rows["app.next_error"] == "x"                                  # the keymap's key
            assert "greater_than_sign" not in help_text(app) and "full_stop" not in help_text(app)
        stop_feed(app)

    run(drive())


def test_detail_enter_jumps_and_hex_highlights_field(tmp_path):
    app, _expected = view_of_fixture(tmp_path)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await all_loaded(pilot, app)
            await pilot.press("down", "down")          # #3, the P? result
            assert selected(app) == 3
            tree = app.query_one("#detail")
            tree.focus()
            # walk to the "answers #1" line and press Enter
            for _ in range(40):
                node = tree.cursor_node
                if node is not None and str(node.label).startswith("answers #1"):
                    break
                await pilot.press("down")
            await pilot.press("enter")
            assert selected(app) == 1
        stop_feed(app)

    run(drive())


def pty_pair():
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def live_on_ptys(**kw):
    """The live TUI on two pseudo-terminals opened with pyserial, lines A and B:
    (app, the master ends to write A's and B's traffic to). ``kw`` for make_app."""
    ma, _sa, pa = pty_pair()
    mb, _sb, pb = pty_pair()
    return make_app(open_live([pa, pb]), mode="live", ports=[pa, pb], **kw), ma, mb


def exchange(ma, mb, dst=(1, 1, 1)):
    os.write(ma, frame(dst, 0, "HO"))
    time.sleep(0.02)
    os.write(mb, b"\x06")
    time.sleep(0.03)


def test_live_follow_badge_and_record_toggle(tmp_path):
    rec = tmp_path / "toggled.mcap"
    app, ma, mb = live_on_ptys(record_path=str(rec))

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 2)
            assert app.model.follow and selected(app) == app.model.row(app.model.row_count - 1).number
            await pilot.press("up")                  # navigating stops following
            assert not app.model.follow
            at = selected(app)
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.new_while_away >= 2)
            assert selected(app) == at               # the view stayed
            await settle(pilot, app, lambda a: "+2 new" in str(a.status_bar.render()))
            await pilot.press("G")
            assert app.model.follow and selected(app) == app.model.row(app.model.row_count - 1).number
            await record_three_exchanges(pilot, app, ma, mb)   # record from now on, then stop
        stop_feed(app)

    run(drive())
    # the recording holds what crossed the wire while it ran, and passes the checkers
    events = jsonl(rec)
    assert [e["kind"] for e in events if e["kind"] == "command"] == ["command"] * 3
    assert all(e["dst"] == [1, 1, 2] and e["status"] == "ok" for e in events if e["kind"] == "command")
    assert doctor(rec) == []


def test_an_ended_live_capture_stops_its_clock_and_rates():
    """Once a live capture has ended, its status line says so and stays as it was:
    the elapsed time stops, and no line rate is shown (nothing is read any more);
    the screen is not redrawn for a clock that runs on."""
    app, ma, mb = live_on_ptys()
    redraws = []

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 2)
            assert "B/s" in str(app.status_bar.render())     # a running tap shows each line's rate
            app.feed.stop()
            await settle(pilot, app, lambda a: "capture ended" in str(a.status_bar.render()))
            ended = str(app.status_bar.render())
            assert "B/s" not in ended
            update = app.status_bar.update
            app.status_bar.update = lambda *a, **k: (redraws.append(a), update(*a, **k))[1]
            await pilot.pause(1.3)                           # the clock would have moved on by a second
            assert str(app.status_bar.render()) == ended
        stop_feed(app)

    run(drive())
    assert redraws == []


def test_replay_controls(tmp_path):
    path = tmp_path / "tap.log"
    write_capture(path)
    t = [e.t for e in analyzer.open(str(path))]
    app = make_app(analyzer.open(str(path)), mode="replay", speed=1.0)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.model.row_count >= 1)
            assert app.model.row_count < 13            # at recorded pace, the end is ~0.6 s away
            await pilot.press("space")                 # pause
            shown = app.model.row_count
            await pilot.pause(0.4)
            assert app.model.row_count == shown and not app.model.replay.playback.playing
            await pilot.press("greater_than_sign")     # +10 s: to the end
            assert app.model.row_count == 13
            await pilot.press("less_than_sign")        # -10 s: back to the start
            assert app.model.row_count == 1 and app.model.replay.position == t[0]
            await pilot.press("plus")
            assert app.model.replay.playback.speed == 2.0
            await pilot.press("space")                 # play on, twice as fast
            await settle(pilot, app, lambda a: a.model.row_count == 13)
        stop_feed(app)

    run(drive())


def test_keymap_rebinds_by_id(tmp_path):
    app, expected = view_of_fixture(tmp_path, keymap={"app.next_error": "x"})

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await all_loaded(pilot, app)
            await pilot.press("e")                 # no longer bound
            assert selected(app) == 1
            await pilot.press("x")
            assert selected(app) == expected["errors"][0]
        stop_feed(app)

    run(drive())


def test_command_palette_runs_actions_and_mode_hides_others(tmp_path):
    app, expected = view_of_fixture(tmp_path)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await all_loaded(pilot, app)
            titles = [c.title for c in app.get_system_commands(app.screen)]
            assert "Next error" in titles and "Record" not in titles and "Play/pause" not in titles
            await pilot.press("ctrl+p")
            await pilot.pause(0.2)
            await pilot.press(*"next error")
            await pilot.pause(0.4)
            await pilot.press("enter")
            await settle(pilot, app, lambda a: selected(a) == expected["errors"][0])
            await pilot.press("r")                 # not a live tap: nothing happens
            assert app.feed.recording is None
        stop_feed(app)

    run(drive())


def test_findings_panel_links_to_evidence_and_swap_key_fixes_swapped_lines():
    """Live on the simulated installation with the tap's ports swapped: the doctor's
    finding shows in the status bar and the panel (w); Enter on its evidence goes to
    that event; x swaps the lines and commands decode as commands again."""
    from analyzer.simulation import scenario
    from analyzer.tui.screens.findings import FindingsScreen

    site = scenario.build({"swapped"}, clean=True)
    ports = list(site.link.tap_ports)
    app = make_app(open_live(ports), mode="live", ports=ports)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            site.start()
            await settle(pilot, app, lambda a: any(f.code == LINES_SWAPPED for f in a.model.findings))
            await settle(pilot, app, lambda a: "lines swapped" in str(a.status_bar.render()))
            await pilot.press("w")
            assert isinstance(app.screen, FindingsScreen)
            tree = app.screen.query_one("#findings")
            for _ in range(60):                      # down to the first evidence line
                if isinstance(tree.cursor_node.data, int) if tree.cursor_node else False:
                    break
                await pilot.press("down")
            target = tree.cursor_node.data
            await pilot.press("enter")
            assert not isinstance(app.screen, FindingsScreen)
            assert selected(app) == target and not app.model.follow
            await pilot.press("x")                   # swap: line A is read as line B
            start = len(app.model.events)
            # commands to the gimbals come on line A now, and are answered: not the
            # gimbals' answers to the controller (0.1.1) taken for commands on A, as
            # when the swap did not reach the running capture
            await settle(pilot, app, lambda a: sum(1 for e in a.model.events[start:] if e.kind == "command"
                                                   and e.line == "A" and e.dst in scenario.DEVICES
                                                   and e.status == "ok") >= 5,
                         what=lambda a: Counter((e.line, e.kind, e.dst and e.dst[0])
                                                for e in a.model.events[start:]).most_common(6))
            assert app.feed.runner.swapped
            # the doctor starts again on the new wiring: the swap finding goes, and no
            # wiring error is left. (Timing warnings are not asserted: the simulated
            # controller runs in this process, and on a loaded machine it really is
            # late, which the doctor rightly reports.)
            await settle(pilot, app, lambda a: a.model.findings is not None and not any(
                f.severity == "error" for f in a.model.findings),
                what=lambda a: [(f.code, f.detail[:90]) for f in a.model.findings or []])
        stop_feed(app)
        site.stop()

    run(drive())
