"""The search prompt (ctrl+f) on a viewed file: a text goes to the next row
holding it, ``=`` and a filter expression to the next row the expression
selects, ``n``/``N`` on from there; an expression that does not compile is said
and the prompt stays open on it."""

from __future__ import annotations

import asyncio

import analyzer
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import CTL, DEV
from tests.ui.test_pilot import notices, settle


def test_search_by_text_and_by_filter_expression():
    events = list(analyzer.open(CTL, DEV))
    naks = [e.number for e in events if e.kind == "nak"]
    # "go to preset 37", "preset 37?": every command with the preset field 37
    preset = [e.number for e in events if e.kind == "command" and e.fields.get("preset") == 37]
    assert len(naks) >= 2 and preset
    app = make_app(analyzer.open(CTL, DEV), mode="view")

    async def drive():
        async with app.run_test(size=(110, 30)) as pilot:
            await settle(pilot, app, lambda a: a.model.done)
            screen = app.main
            said = notices(app)
            seen = [screen.current]
            await pilot.press("ctrl+f", *'=kind == "nak"', "enter")
            await pilot.pause()
            seen.append(screen.current)
            await pilot.press("n")
            await pilot.pause()
            seen.append(screen.current)
            await pilot.press("N")
            await pilot.pause()
            seen.append(screen.current)
            await pilot.press("ctrl+f", "ctrl+u", *"=kind ==", "enter")   # does not compile
            await pilot.pause()
            still_open = screen.search_bar.has_class("shown")
            await pilot.press("ctrl+u", *"preset 37", "enter")
            await pilot.pause()
            seen.append(screen.current)
            return seen, still_open, said
    try:
        seen, still_open, said = asyncio.run(drive())
    finally:
        stop_feed(app)
    start = seen[0]
    after = [n for n in naks if n > start] + [n for n in naks if n <= start]
    assert seen[1:4] == [after[0], after[1], after[0]]
    assert still_open and any(m.startswith("not a filter:") for m in said)
    assert seen[4] == ([n for n in preset if n > after[0]] + preset)[0]   # round the end if need be
