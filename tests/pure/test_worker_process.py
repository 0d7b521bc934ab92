"""Work in a process of its own (analyzer/worker_process.py): its messages arrive
in order; what it prints reaches no terminal; SIGTERM ends it through its
``finally`` clauses; a child killed mid-way is an EOFError, not a garbled message;
a process prepared for a module's work is the one its ``start`` takes, and one
that none took is ended."""

from __future__ import annotations

import os
import sys
import time

import pytest

from analyzer import worker_process


def count_to(n: int, sender: worker_process.Sender) -> None:
    print("printed by the work")
    os.write(2, b"written to standard error\n")
    for k in range(n):
        sender.send(("item", k, b"x" * k))
    sender.send(None)


def wait_forever(sender: worker_process.Sender) -> None:
    try:
        sender.send("started")
        time.sleep(600)
    finally:
        sender.send("finally")


def messages_of(worker: worker_process.Worker) -> list:
    got = []
    while (message := worker.messages.recv()) is not None:
        got.append(message)
    return got


def test_messages_arrive_in_order_and_nothing_reaches_the_terminal(capfd):
    worker = worker_process.start(count_to, (2000,))
    assert worker is not None
    assert messages_of(worker) == [("item", k, b"x" * k) for k in range(2000)]
    worker.end()
    worker.messages.close()
    assert not worker.is_alive()
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_sigterm_ends_the_work_through_its_finally_clauses():
    worker = worker_process.start(wait_forever, ())
    assert worker is not None and worker.messages.recv() == "started"
    worker.end()
    assert worker.messages.recv() == "finally"
    with pytest.raises(EOFError):
        worker.messages.recv()
    worker.messages.close()


def test_a_killed_child_is_an_eof():
    worker = worker_process.start(wait_forever, ())
    assert worker is not None and worker.messages.recv() == "started"
    worker.kill()
    with pytest.raises(EOFError):
        worker.messages.recv()
    worker.end()
    worker.messages.close()


def send_a_chunk_then_say_so(size: int, done: str, sender: worker_process.Sender) -> None:
    sender.send(b"c" * size)
    with open(done, "w"):   # reached only once the message is in the pipe
        pass
    time.sleep(600)


@pytest.mark.skipif(sys.platform != "linux", reason="the pipe's size is Linux's to set")
def test_a_chunk_of_columns_goes_in_without_waiting_for_the_reader(tmp_path):
    # a loading file's chunk is about a megabyte; the screen's thread reads it when
    # its busy interpreter lets it: the child goes on meanwhile (analyzer/worker_process.py)
    done = tmp_path / "sent"
    worker = worker_process.start(send_a_chunk_then_say_so, (900_000, str(done)))
    assert worker is not None
    try:
        deadline = time.monotonic() + 60
        while not done.exists() and time.monotonic() < deadline:   # nothing read meanwhile
            time.sleep(0.05)
        assert done.exists(), "the child waited for its message to be read"
        assert worker.messages.recv() == b"c" * 900_000
    finally:
        worker.end()
        worker.messages.close()


def path_of_child(sender: worker_process.Sender) -> None:
    sender.send(list(sys.path))


def test_a_path_entry_that_is_not_text_is_left_out_as_imports_leave_it_out(monkeypatch, tmp_path):
    monkeypatch.setattr(sys, "path", [*sys.path, tmp_path / "a path object", os.fsencode(tmp_path / "bytes")])
    worker = worker_process.start(path_of_child, ())
    assert worker is not None
    child_path = worker.messages.recv()
    worker.end()
    worker.messages.close()
    assert child_path == [entry for entry in sys.path if isinstance(entry, str)]


def test_a_channel_without_a_process():
    messages, sender = worker_process.channel()
    sender.send({"a": 1})
    sender.send_bytes(b"not a pickle")
    sender.close()
    assert messages.recv() == {"a": 1}
    with pytest.raises(Exception, match="invalid load key"):
        messages.recv()
    with pytest.raises(EOFError):
        messages.recv()
    messages.close()


def counting_spawns(monkeypatch) -> list:
    """The processes ``worker_process`` starts from now on (their ``Popen``)."""
    spawned: list = []
    real = worker_process.subprocess.Popen

    def popen(*args, **kw):
        spawned.append(real(*args, **kw))
        return spawned[-1]
    monkeypatch.setattr(worker_process.subprocess, "Popen", popen)
    return spawned


def test_start_takes_the_process_prepared_for_its_work(monkeypatch):
    spawned = counting_spawns(monkeypatch)
    with worker_process.prepared(__name__):
        worker = worker_process.start(count_to, (3,))
        assert worker is not None and messages_of(worker) == [("item", k, b"x" * k) for k in range(3)]
        worker.end()
        worker.messages.close()
    assert len(spawned) == 1 and worker.pid == spawned[0].pid


def test_work_of_another_module_has_a_process_of_its_own_and_the_prepared_one_ends_unused(monkeypatch):
    spawned = counting_spawns(monkeypatch)
    with worker_process.prepared("json.decoder"):
        worker = worker_process.start(count_to, (1,))
        assert worker is not None and messages_of(worker) == [("item", 0, b"")]
        worker.end()
        worker.messages.close()
        assert len(spawned) == 2 and worker.pid == spawned[1].pid
        assert spawned[0].poll() is None   # still waiting for work of json.decoder
    assert spawned[0].poll() is not None   # no start took it: ended on leaving


def test_a_prepared_process_that_died_is_replaced(monkeypatch):
    spawned = counting_spawns(monkeypatch)
    with worker_process.prepared(__name__):
        spawned[0].kill()
        spawned[0].wait()
        worker = worker_process.start(count_to, (2,))
        assert worker is not None and messages_of(worker) == [("item", k, b"x" * k) for k in range(2)]
        worker.end()
        worker.messages.close()
    assert len(spawned) == 2 and worker.pid == spawned[1].pid


def test_no_process_to_be_had_is_none_prepared_or_not(monkeypatch):
    def no_process(*args, **kw):
        raise OSError(11, "Resource temporarily unavailable")
    monkeypatch.setattr(worker_process.subprocess, "Popen", no_process)
    with worker_process.prepared(__name__):
        assert worker_process.start(count_to, (1,)) is None
