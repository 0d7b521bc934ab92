"""The TUI's record key writes lean recordings when the tap was started with
``--lean`` (docs/mcap.md, "Lean recordings")."""

from analyzer.tui.run import stop_feed
from tests.integration.test_mcap import doctor, go_read, jsonl
from tests.ui.test_pilot import SIZE, exchange, live_on_ptys, record_three_exchanges, run, settle


def test_the_record_key_records_lean_with_the_tap_lean(tmp_path):
    rec = tmp_path / "toggled.mcap"
    app, ma, mb = live_on_ptys(record_path=str(rec), record_lean=True)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 2)
            await record_three_exchanges(pilot, app, ma, mb)
        stop_feed(app)

    run(drive())
    events = jsonl(rec)
    commands = [e for e in events if e["kind"] == "command"]
    assert len(commands) == 3 and all(e["dst"] == [1, 1, 2] and e["status"] == "ok" for e in commands)
    report = go_read(rec)
    meta = report["metadata"]["gimbalscope"]
    assert meta["profile"] == "lean" and meta["recorded_from"] == "the TUI's record key"
    assert "/events" not in report["messages"] and report["messages"]["/serial/reads"] >= 1
    assert doctor(rec) == []
