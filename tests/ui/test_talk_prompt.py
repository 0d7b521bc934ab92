"""``live --talk``: the TUI's ``:`` prompt sends a command, in ``send``'s words, on
the port the screen watches, with ``send``'s safety rules; the answers come back as
events like any other. Driven with Pilot against a responder on a pseudo-terminal
(tests/integration/test_talk.py's, written from the spec's tables)."""

from analyzer.capture import Capture
from analyzer.talk.link import TalkLink
from analyzer.talk.safety import ASK_ONLY, Allowed
from analyzer.talk.session import TalkSession
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import frame
from tests.integration.test_talk import ACK, IDENTITY, responder, result_to_controller
from tests.ui.test_pilot import SIZE, run, settle
from tests.ui.test_pilot import live_on_ptys as two_line_tap


def talking_app(port: str, allowed: Allowed = ASK_ONLY):
    """The live TUI talking on ``port``; what it tells the user is kept in ``app.said``."""
    link = TalkLink(port)
    capture = Capture(link)
    capture.inputs = (port,)
    app = make_app(capture, mode="live", ports=[port], talk=TalkSession(link, allowed))
    app.said = []
    notify = app.notify
    app.notify = lambda message, *a, **k: (app.said.append(str(message)), notify(message, *a, **k))[1]
    return app


def notes(app) -> list[str]:
    return list(app.said)


async def type_line(pilot, line: str) -> None:
    await pilot.press("colon")
    for key in line:
        await pilot.press({" ": "space", "?": "question_mark", "=": "equals_sign", ".": "full_stop",
                           "-": "minus"}.get(key, key))
    await pilot.press("enter")


def test_the_prompt_sends_and_the_answers_come_back_as_events():
    with responder(ACK + result_to_controller((1, 1, 3), IDENTITY)) as gimbal:
        app = talking_app(gimbal.port)

        async def drive():
            async with app.run_test(size=SIZE) as pilot:
                await type_line(pilot, "D? --to 1.1.3")
                await settle(pilot, app, lambda a: a.model.row_count >= 3, what=lambda a: notes(a))
                rows = [app.model.row(k) for k in range(3)]
                assert [(r.kind, r.command) for r in rows] == [("command", "D?"), ("ack", None), ("result", "D?")]
                assert rows[2].fields["serial"] == "A1234"
                assert any("sent D? to 1.1.3 (9 bytes)" in n for n in notes(app))
            stop_feed(app)

        run(drive())
        assert gimbal.heard == frame((1, 1, 3), 0, "D?")


def test_the_prompt_refuses_what_send_refuses():
    with responder(ACK) as gimbal:
        app = talking_app(gimbal.port)

        async def drive():
            async with app.run_test(size=SIZE) as pilot:
                await type_line(pilot, "P --to 1.1.3 azimuth_deg=10 elevation_deg=-5")
                await settle(pilot, app, lambda a: any("add --allow-motion" in n for n in notes(a)))
                await type_line(pilot, "p? --to 1.1.3")
                await settle(pilot, app, lambda a: any("did you mean 'P?'" in n for n in notes(a)))
                assert app.model.row_count == 0
                # the same line with the permission on it is sent
                await type_line(pilot, "P --to 1.1.3 azimuth_deg=10 elevation_deg=-5 --allow-motion")
                await settle(pilot, app, lambda a: a.model.row_count >= 2)
            stop_feed(app)

        run(drive())
        assert gimbal.heard == frame((1, 1, 3), 0, "P03E8FE0C")


def test_without_talk_colon_is_still_go_to():
    app, _ma, _mb = two_line_tap()

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await pilot.press("colon")
            assert app.main.goto_bar.has_class("shown") and not app.main.talk_bar.has_class("shown")
            await pilot.press("escape")
        stop_feed(app)

    run(drive())
