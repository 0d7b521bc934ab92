"""A file viewed in the TUI: its wiring doctor runs in a process of its own
(analyzer/tui/doctor_process.py), off the load's path, and its findings reach the
screen when it is done: the findings ``gimbalscope doctor`` gives the same file.
A pipe, which cannot be read twice, keeps the doctor in the capture thread."""

from __future__ import annotations

import asyncio
import json
import os

import analyzer
from analyzer.tui.decode_process import ProcessFeed
from analyzer.tui.doctor_process import DoctorProcess, DoctorWord, readable_by_another_process
from analyzer.tui.feed import FeedBatch
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import CTL, DEV, SOCAT_LOG, run_cli
from tests.ui.test_pilot import settle


def doctor_says(*paths) -> list[tuple[str, str]]:
    r = run_cli("doctor", *paths, "--format", "json")
    return sorted((f["code"], f["subject"]) for f in json.loads(r.stdout)["findings"])


def viewed(*paths) -> tuple[list[tuple[str, str]], object]:
    app = make_app(analyzer.open(*paths), mode="view")

    async def drive():
        async with app.run_test(size=(100, 30)) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.model.findings,
                         what=lambda a: f"done {a.model.done}, findings {a.model.findings}")
            return sorted((f.code, f.subject) for f in app.model.findings), app.feed

    try:
        return asyncio.run(drive())
    finally:
        stop_feed(app)


def test_a_files_findings_come_from_the_doctor_process():
    for paths in ((SOCAT_LOG,), (CTL, DEV)):
        found, feed = viewed(*paths)
        assert found == doctor_says(*paths)
        assert ("noisy_link", "B") in found
        # the file was decoded in a process of its own, the doctor in another, which has ended
        assert isinstance(feed, ProcessFeed)
        assert isinstance(feed.doctor_process, DoctorProcess)
        assert not feed.doctor_process.process.is_alive()


def test_what_cannot_be_read_twice_keeps_the_doctor_in_the_capture_thread(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    readable = readable_by_another_process
    assert readable((SOCAT_LOG,)) and readable((CTL, DEV))
    assert not readable((str(fifo),)) and not readable(("-",)) and not readable(())
    assert not readable((str(tmp_path / "gone.log"),))


def test_a_doctor_that_failed_is_a_warning_in_the_next_batch():
    batch = FeedBatch([], [], [], warnings=["earlier"])
    batch.hear(DoctorWord(None, "its process ended without a word"))
    assert batch.warnings == ["earlier", "the wiring doctor stopped: its process ended without a word"]
    assert batch.doctor_error == "its process ended without a word" and batch.findings is None
    found = FeedBatch([], [], [])
    found.hear(DoctorWord([]))
    assert found.warnings == [] and found.findings == [] and found.doctor_error is None
