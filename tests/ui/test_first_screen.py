"""The first screen of ``view`` comes early (docs/tui.md, "Loading a file"): a
file's decoding process is started before the screen is made, and the screen's
feed adopts it rather than start a second one; where no process can be had, the
view falls back as it would (feed_choice.py's cases), to a capture thread with
the doctor in its runner."""

from __future__ import annotations

import asyncio

import pytest

import analyzer
from analyzer import worker_process
from analyzer.info import CaptureInfo
from analyzer.tui import decode_process
from analyzer.tui.app import GimbalscopeApp
from analyzer.tui.decode_process import ProcessFeed
from analyzer.tui.feed import Feed
from analyzer.tui.feed_choice import Loading, early_decoding
from analyzer.tui.run import make_app, run_app, stop_feed
from tests.conftest import CTL, DEV
from tests.ui.test_pilot import settle

EVENTS = 1012   # the events of CTL and DEV


def decoding_starts(monkeypatch) -> list[worker_process.Worker | None]:
    """The decoding processes started from now on (None: one that could not be)."""
    started: list[worker_process.Worker | None] = []
    real = worker_process.start

    def start(work, args):
        worker = real(work, args)
        if work.__module__ == decode_process.__name__:
            started.append(worker)
        return worker
    monkeypatch.setattr(worker_process, "start", start)
    return started


def no_process_to_be_had(monkeypatch) -> None:
    monkeypatch.setattr(worker_process, "start", lambda work, args: None)


def loading_of(mode: str = "view") -> Loading:
    capture = analyzer.open(CTL, DEV)
    return Loading(capture, CaptureInfo.of(capture, command=mode), mode)


def loaded(app: GimbalscopeApp) -> tuple[type, int, object]:
    """The app headless until its file has loaded and the doctor has spoken: its
    feed's kind, the rows shown, and the feed."""
    async def drive():
        async with app.run_test(size=(100, 30)) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.model.findings,
                         what=lambda a: f"done {a.model.done}, findings {a.model.findings}")
            return type(app.feed), app.model.shown, app.feed
    return asyncio.run(drive())


@pytest.fixture
def headless_run(monkeypatch) -> list[tuple[type, int, object]]:
    """``run_app`` with its screen headless: what ``loaded`` saw of each app it ran."""
    seen: list[tuple[type, int, object]] = []
    monkeypatch.setattr(GimbalscopeApp, "run", lambda app: seen.append(loaded(app)))
    return seen


def test_the_decoding_process_started_early_is_the_one_the_screen_reads(monkeypatch):
    started = decoding_starts(monkeypatch)
    loading = loading_of()
    early = early_decoding(loading)
    assert early is not None and started == [early]
    app = make_app(loading.capture, mode="view", decoding=early)
    try:
        kind, shown, feed = loaded(app)
    finally:
        stop_feed(app)
    assert kind is ProcessFeed and shown == EVENTS
    assert feed.process is early and started == [early]   # adopted: no second one
    assert not early.is_alive()


def test_run_app_starts_the_decoding_before_the_screen_and_ends_it_after(monkeypatch, headless_run):
    started = decoding_starts(monkeypatch)
    assert run_app(analyzer.open(CTL, DEV), mode="view") == 0
    [(kind, shown, feed)] = headless_run
    assert kind is ProcessFeed and shown == EVENTS
    assert len(started) == 1 and feed.process is started[0] and not started[0].is_alive()


def test_nothing_is_started_early_for_what_the_decoding_process_does_not_load(monkeypatch):
    started = decoding_starts(monkeypatch)
    assert early_decoding(loading_of("replay")) is None
    capture = analyzer.open(CTL, DEV)
    assert early_decoding(Loading(capture, CaptureInfo.of(capture, command="view"), "view",
                                  listeners=[object()])) is None   # someone else hears the capture
    assert started == []


def test_a_view_with_no_process_to_be_had_falls_back_to_a_capture_thread(monkeypatch, headless_run):
    no_process_to_be_had(monkeypatch)
    assert early_decoding(loading_of()) is None
    assert run_app(analyzer.open(CTL, DEV), mode="view") == 0
    [(kind, shown, feed)] = headless_run
    # neither the decoding nor the doctor's process: a capture thread, the doctor in its runner
    assert kind is Feed and shown == EVENTS and feed.doctor_process is None
