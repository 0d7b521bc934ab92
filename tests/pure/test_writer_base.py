"""The writer base (analyzer/writers/base.py): a path is written beside itself and
takes its name only when the run ends well, in place when asked, a given file is
left open, standard output is named so in errors, and every writer says what it
wrote in one line. The formats of ``--format`` are registry entries."""

import errno
import io
import os

import pytest

from analyzer.errors import OutputError, StdoutError
from analyzer.writers import FORMATS, open_format
from analyzer.writers.base import FileWriter, wrote
from analyzer.writers.jsonl import JsonLinesWriter
from analyzer.writers.text import TextWriter
from dissectors.event import NOISE, Event


class Lines(FileWriter):
    """One line per ``write``; ``fail_at_end`` makes finishing the format fail."""

    noun = "lines"

    def __init__(self, path=None, info=None, *, fail_at_end=False, **kw):
        self.fail_at_end = fail_at_end
        super().__init__(path, info, **kw)

    def begin(self):
        self.file.write(b"head\n")

    def write(self, text):
        with self.writes:
            self.file.write(text.encode() + b"\n")
        self.count += 1

    def finish(self):
        if self.fail_at_end:
            raise OutputError("the end could not be written")


def leftovers(folder):
    return sorted(os.listdir(folder))


def test_a_path_appears_only_when_the_run_ends_well(tmp_path):
    out = tmp_path / "out.txt"
    with Lines(str(out)) as w:
        w.write("one")
        w.on_stop()                       # the runner stops it: still under its temporary name
        assert not out.exists() and len(leftovers(tmp_path)) == 1
    assert out.read_bytes() == b"head\none\n"
    assert leftovers(tmp_path) == ["out.txt"]


def test_a_failed_run_leaves_no_file_and_the_old_one_intact(tmp_path):
    out = tmp_path / "out.txt"
    out.write_bytes(b"old\n")
    with pytest.raises(RuntimeError), Lines(str(out)) as w:
        w.write("new")
        raise RuntimeError("reading failed")
    assert out.read_bytes() == b"old\n"
    assert leftovers(tmp_path) == ["out.txt"]


def test_a_format_that_fails_to_end_is_removed(tmp_path):
    w = Lines(str(tmp_path / "out.txt"), fail_at_end=True)
    with pytest.raises(OutputError):
        w.on_stop()
    assert leftovers(tmp_path) == []


def test_without_with_the_file_is_whole_when_the_writer_stops(tmp_path):
    out = tmp_path / "out.txt"
    w = Lines(str(out))
    w.write("one")
    w.on_stop()
    w.on_stop()                            # twice (export's discard): nothing more
    assert out.read_bytes() == b"head\none\n"


def test_in_place_is_there_from_the_start_and_kept_after_a_failure(tmp_path):
    out = tmp_path / "live.jsonl"
    ev = Event("A", 0, NOISE, b"\x00")
    ev.number = 1
    with pytest.raises(RuntimeError), JsonLinesWriter(str(out), atomic=False, flush_each=True) as w:
        assert out.exists()
        w.write(ev)
        assert out.read_bytes().count(b"\n") == 1   # flushed: a killed process keeps it
        raise RuntimeError("killed")
    assert out.read_bytes().count(b"\n") == 1
    assert leftovers(tmp_path) == ["live.jsonl"]


def test_a_path_that_cannot_be_written_is_one_line(tmp_path):
    for atomic in (True, False):
        with pytest.raises(OutputError, match=r"nowhere/out.txt: cannot write: no such file or directory"):
            Lines(str(tmp_path / "nowhere" / "out.txt"), atomic=atomic)


def test_a_failing_start_leaves_nothing(tmp_path):
    class Refused(Lines):
        def begin(self):
            super().begin()
            raise OutputError("no header")

    with pytest.raises(OutputError):
        Refused(str(tmp_path / "out.txt"))
    assert leftovers(tmp_path) == []


def test_a_given_file_is_flushed_and_left_open():
    buf = io.BytesIO()
    w = Lines(file=buf)
    w.write("one")
    w.on_stop()
    assert not buf.closed and buf.getvalue() == b"head\none\n"


class Full(io.RawIOBase):
    """A file on a full disk."""

    name = "full.bin"

    def writable(self):
        return True

    def write(self, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_failed_write_names_the_target_once_and_writing_stops():
    w = JsonLinesWriter(file=Full(), flush_each=True)
    ev = Event("A", 0, NOISE, b"\x00")
    ev.number = 1
    with pytest.raises(OutputError, match=r"^full.bin: cannot write: no space left on device$"):
        w.write(ev)
    assert w.broken
    w.write(ev)                             # nothing more is written, nor said
    w.on_stop()


def test_standard_output_is_named_in_errors(monkeypatch):
    out = io.TextIOWrapper(Full(), encoding="utf-8", write_through=True)
    monkeypatch.setattr("sys.stdout", out)
    w = TextWriter(flush_each=True)
    assert w.name == "standard output"
    ev = Event("A", 0, NOISE, b"\x00")
    ev.number, ev.t = 1, 0.0
    with pytest.raises(StdoutError, match=r"^standard output: cannot write: no space left on device$"):
        w.write(ev)


def test_a_reader_gone_stays_a_broken_pipe():
    class Gone(Full):
        def write(self, data):
            raise BrokenPipeError(errno.EPIPE, os.strerror(errno.EPIPE))

    w = JsonLinesWriter(file=Gone(), flush_each=True)
    ev = Event("A", 0, NOISE, b"\x00")
    ev.number = 1
    with pytest.raises(BrokenPipeError):
        w.write(ev)


def test_every_writer_says_what_it_wrote_in_one_line(tmp_path):
    out = tmp_path / "out.txt"
    with Lines(str(out)) as w:
        w.write("one")
        w.write("two")
    assert w.summary() == f"wrote 2 lines to {out}"
    assert wrote({"events": 1024, "transactions": 1, "findings": 0}, "ds") == \
        "wrote 1,024 events, 1 transaction, 0 findings to ds"


def test_the_formats_are_registry_entries_to_standard_output(capsysbinary):
    assert list(FORMATS) == ["text", "jsonl", "csv"]   # the first is decode's default
    w = open_format("jsonl", None)
    assert isinstance(w, JsonLinesWriter) and w.name == "standard output"
    ev = Event("A", 0, NOISE, b"\x00")
    ev.number = 1
    w.write(ev)
    w.on_stop()
    line = capsysbinary.readouterr().out
    assert line.endswith(b"\n") and line.count(b"\n") == 1
    assert w.summary() == "wrote 1 event to standard output"
    assert isinstance(open_format("text", None, color=False), TextWriter)


def test_the_text_output_is_no_file_of_its_own(tmp_path):
    with pytest.raises(ValueError):
        TextWriter(str(tmp_path / "out.txt"))
