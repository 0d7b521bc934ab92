"""With a filter, the status line counts the rows it shows and the errors among
them (from the store's flags column), beside the whole capture's counts."""

from __future__ import annotations

import asyncio

import analyzer
from analyzer.formats.store import is_error
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import SOCAT_LOG
from tests.ui.test_pilot import settle


def test_the_status_line_counts_the_filtered_rows_and_their_errors():
    events = list(analyzer.open(SOCAT_LOG))
    text = 'device == "1.1.2"'
    rows = [e for e in events if e.device == "1.1.2"]
    errors = sum(1 for e in rows if is_error(e))
    assert len(rows) == 142 and 0 < errors < sum(1 for e in events if is_error(e))
    app = make_app(analyzer.open(SOCAT_LOG), mode="view", filter_text=text)

    async def drive():
        async with app.run_test(size=(160, 30)) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.model.row_count == len(rows))
            await pilot.pause(0.1)
            return str(app.status_bar.render())

    try:
        status = asyncio.run(drive())
    finally:
        stop_feed(app)
    assert f"(142 shown, {errors} error{'s' if errors != 1 else ''})" in status
