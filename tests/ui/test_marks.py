"""Marks and notes in the TUI: `m` marks the selected event, `M` writes a note on
it, `'` goes from mark to mark. A viewed file keeps them in its sidecar, read back
when it opens again; a live tap's recording keeps them on /marks, which `decode`
shows under the events."""

from __future__ import annotations

import json
import shutil

import analyzer
from analyzer.capture import open_live
from analyzer.formats.marks import recorded_marks
from analyzer.info import CaptureInfo
from analyzer.tui.run import make_app, stop_feed
from analyzer.writers.mcap import McapWriter
from tests.conftest import SOCAT_LOG, run_cli
from tests.ui.test_pilot import SIZE, exchange, pty_pair, run, selected, settle


async def _type(pilot, text: str) -> None:
    await pilot.press(*["space" if c == " " else c for c in text])


def _viewed(path):
    return make_app(analyzer.open(str(path)), mode="view")


def test_a_viewed_file_keeps_its_marks_and_notes_beside_it(tmp_path):
    log = tmp_path / "tap.log"
    shutil.copy(SOCAT_LOG, log)
    app = _viewed(log)

    async def mark_two():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: a.last is not None and a.last.done and a.model.row_count > 10)
            assert selected(app) == 1
            await pilot.press("m")                  # #1 marked, no note
            await pilot.press("down", "down")
            await pilot.press("M")
            await _type(pilot, "late ACK")
            await pilot.press("enter")              # #3 marked with its note
            await pilot.press("apostrophe")         # from #3 to the next mark: #1 (wrapping)
            assert selected(app) == 1
        stop_feed(app)

    run(mark_two())
    data = json.loads((tmp_path / "tap.log.marks.json").read_text())
    assert [(m["number"], m["note"]) for m in data["marks"]] == [(1, ""), (3, "late ACK")]
    assert abs(data["marks"][1]["t"] - 0.018435) < 1e-6   # #3's time: the sample's decode says 0.018435

    again = _viewed(log)

    async def reopen():
        async with again.run_test(size=SIZE) as pilot:
            await settle(pilot, again, lambda a: a.last is not None and a.last.done)
            assert again.model.marks.notes == {1: "", 3: "late ACK"}
            ev = again.model.event(3)
            assert again.model.detail(ev)[0].label == "★ marked: late ACK"
            await pilot.press("down", "down", "m")   # #3's mark taken off: the sidecar says so
        stop_feed(again)

    run(reopen())
    data = json.loads((tmp_path / "tap.log.marks.json").read_text())
    assert [m["number"] for m in data["marks"]] == [1]
    decoded = run_cli("decode", log).stdout.splitlines()
    assert decoded[1] == "        ★ marked"


def test_a_live_taps_marks_go_into_its_recording(tmp_path):
    rec = tmp_path / "live.mcap"
    ma, _sa, pa = pty_pair()
    mb, _sb, pb = pty_pair()
    capture = open_live([pa, pb])
    info = CaptureInfo.of(capture, command="live")
    recorder = McapWriter(str(rec), info, live=True)
    app = make_app(capture, mode="live", ports=[pa, pb], info=info, recorder=recorder, record_path=str(rec))

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 2)
            await pilot.press("up")                  # #1, the command
            await pilot.press("M")
            await _type(pilot, "first HO")
            await pilot.press("enter")
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 4)
        stop_feed(app)

    run(drive())
    marks = recorded_marks(str(rec))
    assert [(m.number, m.note, m.removed) for m in marks] == [(1, "first HO", False)]
    # each message is a foxglove.Log, as Foxglove's Log panel reads it
    import jsonschema
    from mcap.reader import make_reader

    from analyzer.formats import mcap_schemas as S
    with open(rec, "rb") as f:
        for schema, _channel, message in make_reader(f).iter_messages(topics=[S.MARKS_TOPIC]):
            assert schema is not None and schema.name == "foxglove.Log"
            jsonschema.validate(json.loads(message.data), S.LOG)
    lines = run_cli("decode", rec).stdout.splitlines()
    assert lines[1] == "        ★ marked: first HO" and lines[0].lstrip().startswith("1 ")
