"""The status bar: a file's load progress (bytes read of its size, from the
feed's batches; a pipe's bytes of traffic, with no share) and its counts with
thousands separators. Driven with Textual's Pilot; nothing here depends on how
fast the feed runs: the texts are read after the batches were handled, and
every text the bar showed is kept."""

from __future__ import annotations

import os
import threading

import analyzer
from analyzer.simulation.traffic import Traffic, Write
from analyzer.tui.app import GimbalscopeApp
from analyzer.tui.feed import FeedBatch, LineStatus, StreamFeed
from analyzer.tui.model import CaptureModel
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import frame
from tests.tui_fixtures import conversation, write_capture
from tests.ui.test_pilot import SIZE, run, settle


def shown_texts(app) -> list[str]:
    """Every text the status bar is given from now on (plain), in order."""
    texts: list[str] = []
    update = app.status_bar.update
    app.status_bar.update = lambda text, *a, **k: (texts.append(str(text)), update(text, *a, **k))[1]
    return texts


def wire_line(app) -> str:
    return str(app.status_bar.render()).splitlines()[0]


def test_a_file_shows_bytes_read_of_its_size_while_it_loads_then_its_size(tmp_path):
    path = tmp_path / "tap.log"
    write_capture(path)
    size = os.path.getsize(path)
    assert 1000 <= size < 100_000          # shown in kB with one decimal
    kb = f"{size / 1000:.1f} kB"
    app = make_app(analyzer.open(str(path)), mode="view")
    texts = shown_texts(app)

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: a.model.done)
            await pilot.pause()
            assert f"loaded {kb}" in wire_line(app)
        stop_feed(app)

    run(drive())
    # "loading" alone until the first batch; the first events go out before the
    # end (Feed.on_events), so at least one batch showed a share and the file's size
    loading = [t.splitlines()[0] for t in texts if "loading" in t]
    assert loading[0].endswith("  loading  9600 8N1"), texts
    assert loading[1:] and all("% · " in t and f" of {kb}  " in t for t in loading[1:]), texts
    assert app.last.done and app.last.read == app.last.total == size


class StillFeed:
    """A feed that reads nothing: the test hands the app its batches."""

    def __init__(self, deliver) -> None:
        self.deliver = deliver
        self.notes: list[str] = []
        self.recording = None

    def start(self) -> None:
        pass

    def stop(self) -> None:
        pass

    def join(self, timeout=None) -> None:
        pass


def batch(read: int, total: int | None, *, done: bool = False, error: str | None = None) -> FeedBatch:
    return FeedBatch([], [], [LineStatus("AB", "bus.bin", "file")], done=done, error=error, read=read, total=total)


def still_app() -> tuple[GimbalscopeApp, list[StillFeed]]:
    """The TUI viewing "bus.bin" over a ``StillFeed`` (in the list once it starts)."""
    feeds: list[StillFeed] = []

    def make_feed(deliver) -> StillFeed:
        feeds.append(StillFeed(deliver))
        return feeds[-1]
    return GimbalscopeApp(CaptureModel(follow=False), make_feed, mode="view", source="bus.bin"), feeds


async def shown(pilot, feeds: list[StillFeed], b: FeedBatch) -> str:
    """Line 1 of the status bar once the batch has been handled."""
    feeds[0].deliver(b)
    await pilot.pause()
    return wire_line(pilot.app)


def test_load_progress_is_bytes_read_of_the_total_or_without_a_share_when_there_is_none():
    app, feeds = still_app()

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            assert "bus.bin  loading" in wire_line(app)        # nothing read yet
            # 12.3 of 32.1 MB is 38.3 %: the share rounds down
            assert "bus.bin  loading 38% · 12.3 MB of 32.1 MB" in await shown(pilot, feeds, batch(12_300_000,
                                                                                                  32_100_000))
            assert "loading 99% · 32.0 MB of 32.1 MB" in await shown(pilot, feeds, batch(31_999_999, 32_100_000))
            # a pipe: no size, so no share; what was read is the traffic's bytes
            assert "bus.bin  loading · 5.0 MB of traffic" in await shown(pilot, feeds, batch(5_000_000, None))
            assert "bus.bin  loaded · 7.3 MB of traffic" in await shown(pilot, feeds, batch(7_260_000, None,
                                                                                           done=True))

    run(drive())


def test_a_capture_stopped_by_an_error_says_how_far_it_loaded():
    app, feeds = still_app()

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            line = await shown(pilot, feeds, batch(1_000_000, 2_000_000, done=True, error="OSError: gone"))
            assert "loaded 50% · 1.0 MB of 2.0 MB" in line      # not the whole size

    run(drive())


def test_a_pipe_shows_its_traffic_bytes_read(tmp_path):
    """A FIFO has no size: the feed counts the bytes of traffic its chunks held."""
    tr, _expected = conversation()
    traffic = sum(len(w.data) for w in tr.writes)
    assert traffic < 1000                  # shown in bytes
    fifo = tmp_path / "tap.fifo"
    os.mkfifo(fifo)
    writer = threading.Thread(target=fifo.write_text, args=(tr.socat_log(),), daemon=True)
    writer.start()
    app = make_app(analyzer.open(str(fifo)), mode="view")

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: a.model.done)
            await pilot.pause()
            assert isinstance(app.feed, StreamFeed)
            assert f"loaded · {traffic} B of traffic" in wire_line(app)
        stop_feed(app)

    run(drive())
    writer.join(5)


def many_checksum_errors(path) -> None:
    """1,000 commands to 1.1.1 each ACKed, then 1,234 with a bad checksum
    (unanswered) to 1.1.3: 3,234 events, of which the 1,234 are errors and
    checksum errors (Table 1: the checksum is the low byte of the sum after the
    start byte). The good ones come first: a good command after one with a bad
    checksum would be taken for its resend (the bad one's address is not to be
    trusted), a retransmission, which is an error too."""
    tr = Traffic(baud=9600)
    t = 0.0
    for _ in range(1000):
        tr.writes.append(Write("A", frame((1, 1, 1), 0, "HO"), t))
        tr.writes.append(Write("B", b"\x06", t + 0.02))
        t += 0.05
    bad = bytearray(frame((1, 1, 3), 0, "HO"))
    bad[-1] ^= 0xFF
    for _ in range(1234):
        tr.writes.append(Write("A", bytes(bad), t))
        t += 0.05
    path.write_text(tr.socat_log())


def test_status_counts_have_thousands_separators(tmp_path):
    path = tmp_path / "tap.log"
    many_checksum_errors(path)
    app = make_app(analyzer.open(str(path)), mode="view")

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            await settle(pilot, app, lambda a: a.model.done)
            await pilot.pause()
            counts = str(app.status_bar.render()).splitlines()[1]
            assert counts.startswith("3,234 events  1,234 errors  1,234 checksum"), counts
        stop_feed(app)

    run(drive())
