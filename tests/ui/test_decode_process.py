"""A file viewed is decoded in a process of its own (analyzer/tui/decode_process.py)
that hands the screen columns. The screen shows what the file holds (the rows
``decode`` gives, the doctor's findings); the wiring doctor starts beside the
decoding where there are cores enough and after the load where there are not;
a decoding process that dies leaves the rows that came, the reason said; and
quitting while a file loads ends the process."""

from __future__ import annotations

import asyncio
import json
import os

import pytest

import analyzer
from analyzer.simulation.traffic import generate
from analyzer.tui import decode_process
from analyzer.tui.app import FeedMessage
from analyzer.tui.decode_process import ProcessFeed
from analyzer.tui.doctor_process import DoctorProcess
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import CTL, DEV, run_cli
from tests.ui.test_pilot import settle


def drive(app, until, then=None, size=(100, 30)):
    async def run():
        async with app.run_test(size=size) as pilot:
            await settle(pilot, app, until, what=lambda a: f"done {a.model.done}, shown {a.model.shown}")
            return then(app) if then else None
    try:
        return asyncio.run(run())
    finally:
        stop_feed(app)


def big_capture(tmp_path) -> str:
    """Two raw dumps of tens of thousands of events: a load of a second or so."""
    tr = generate(20_000, baud=115200, seed=3, bit_error_rate=0.001)
    (tmp_path / "ctl.bin").write_bytes(tr.line_bytes("A"))
    (tmp_path / "dev.bin").write_bytes(tr.line_bytes("B"))
    return str(tmp_path / "ctl.bin"), str(tmp_path / "dev.bin")


def on_batches(app, then) -> None:
    """``then(batch)`` for each batch the feed hands the app, in the feed's
    thread, once it has posted it (``FeedMessage``)."""
    post = app.post_message

    def posted(message):
        queued = post(message)
        if isinstance(message, FeedMessage):
            then(message.batch)
        return queued
    app.post_message = posted


def order_of_starts(monkeypatch, app) -> list[str]:
    """What happened, in order: the screen was handed a last batch ("done"),
    the doctor's process started ("doctor")."""
    log: list[str] = []
    start = DoctorProcess.start

    def started(self):
        log.append("doctor")
        return start(self)

    def handed(batch):
        if batch.done and "done" not in log:
            log.append("done")
    monkeypatch.setattr(DoctorProcess, "start", started)
    on_batches(app, handed)
    return log


def test_the_rows_are_the_files_events():
    app = make_app(analyzer.open(CTL, DEV), mode="view")
    rows = drive(app, lambda a: a.model.done,
                 lambda a: (type(a.feed), [json.loads(json.dumps(a.model.event(n).to_dict()))
                                            for n in range(1, a.model.shown + 1)]))
    kind, got = rows
    assert kind is ProcessFeed
    want = [json.loads(line) for line in run_cli("decode", CTL, DEV, "--format", "jsonl").stdout.splitlines()]
    assert len(got) == len(want) == 1012
    assert got == want


@pytest.mark.parametrize("cores_needed, order", [(10 ** 6, ["done", "doctor"]), (1, ["doctor", "done"])],
                         ids=["few cores: after the load", "cores enough: beside the decoding"])
def test_the_doctor_starts_after_the_load_on_few_cores_beside_it_on_enough(monkeypatch, cores_needed, order):
    monkeypatch.setattr(decode_process, "DOCTOR_BESIDE_CORES", cores_needed)
    app = make_app(analyzer.open(CTL, DEV), mode="view")
    log = order_of_starts(monkeypatch, app)
    found = drive(app, lambda a: a.model.done and a.model.findings,
                  lambda a: sorted((f.code, f.subject) for f in a.model.findings))
    assert ("noisy_link", "B") in found
    assert log == order


def test_a_decoding_process_that_dies_leaves_the_rows_that_came(tmp_path):
    paths = big_capture(tmp_path)
    total = sum(1 for _ in analyzer.open(*paths))
    app = make_app(analyzer.open(*paths), mode="view")
    killed = []

    def kill_after_the_first_rows(batch):
        if not killed and batch.chunk is not None and len(batch.chunk.stored.columns["kind"]):
            app.feed.process.kill()   # as the kernel's OOM killer would
            killed.append(len(batch.chunk.stored.columns["kind"]))
    on_batches(app, kill_after_the_first_rows)
    shown, messages = drive(app, lambda a: a.model.done, lambda a: (a.model.shown, list(a.messages)))
    assert killed and killed[0] <= shown < total
    assert "capture stopped: the decoding process ended without a word" in messages
    assert app.feed.notes == ["capture stopped: the decoding process ended without a word"]


def test_quitting_while_loading_ends_the_decoding_process(tmp_path):
    paths = big_capture(tmp_path)
    app = make_app(analyzer.open(*paths), mode="view")
    process = drive(app, lambda a: a.model.shown > 0 and not a.model.done, lambda a: a.feed.process)
    assert not process.is_alive()
    assert app.feed.notes == []   # a decoding ended on purpose is no news after the screen has closed


def test_processes_that_have_said_their_last_word_are_reaped_before_the_screen_closes():
    def unreaped(app) -> list[int]:
        """Looked at before ``stop_feed`` ends them: a child not reaped is still listed (a zombie)."""
        pids = (app.feed.process.pid, app.feed.doctor_process.process.pid)
        return [pid for pid in pids if os.path.exists(f"/proc/{pid}")]

    app = make_app(analyzer.open(CTL, DEV), mode="view")
    assert drive(app, lambda a: a.model.done and a.model.findings, unreaped) == []


def receiving(sent) -> list:
    """What the screen's side delivers of the messages ``sent(sender)`` sends on
    its channel (as the decoding process would), with no process behind it."""
    from analyzer.worker_process import channel

    got = []
    feed = ProcessFeed((CTL, DEV), None, got.append)
    feed.messages, sender = channel()
    feed.start()
    sent(sender)
    sender.close()
    feed.join(timeout=30)
    assert not feed.is_alive()
    return got, feed


def chunks_of(n: int) -> list:
    from analyzer.tui.model.chunks import ChunkMaker

    events = list(analyzer.open(CTL, DEV))
    maker, out = ChunkMaker(), []
    for k in range(n):
        maker.add(events[k * 10:(k + 1) * 10])
        out.append(maker.take())
    return out


def test_a_chunk_that_does_not_follow_ends_the_load_with_the_reason():
    from analyzer.tui.feed import FeedBatch

    first, _lost, third = chunks_of(3)
    got, feed = receiving(lambda sender: [sender.send(FeedBatch([], [], [], chunk=c)) for c in (first, third)])
    assert [b.chunk is not None for b in got] == [True, False] and got[-1].done
    assert got[-1].error == "the decoding process lost events 11 to 20"
    assert feed.notes == ["capture stopped: the decoding process lost events 11 to 20"]


def test_a_message_that_cannot_be_read_ends_the_load_with_the_reason():
    got, _feed = receiving(lambda sender: sender.send_bytes(b"not a pickle"))
    assert len(got) == 1 and got[0].done
    assert got[0].error.startswith("a batch from the decoding process could not be read: UnpicklingError")


def test_after_a_chunk_that_could_not_be_sent_only_the_last_word_goes():
    from analyzer.tui.decode_process import BatchSender
    from analyzer.tui.feed import FeedBatch

    class Conn:
        def __init__(self):
            self.sent, self.fail = [], True

        def send(self, batch):
            if self.fail:
                self.fail = False
                raise MemoryError("pickling a chunk")
            self.sent.append(batch)

    events = list(analyzer.open(CTL, DEV))
    conn = Conn()
    sender = BatchSender(conn)
    try:
        sender(FeedBatch(events[:10], [], []))
    except MemoryError:
        pass
    sender(FeedBatch(events[10:20], [], []))
    sender(FeedBatch([], [], [], done=True, error="MemoryError: pickling a chunk"))
    assert [(b.chunk, b.done, b.error) for b in conn.sent] == [(None, True, "MemoryError: pickling a chunk")]
