"""Bytes read of the inputs' size, for the progress bar: counted where input
files are opened (analyzer/sources/files.open_input), by the files' offsets."""

import gzip
import os

import pytest

from analyzer.sources.files import Input, open_input
from analyzer.sources.meter import READS, ReadMeter


@pytest.fixture
def meter():
    READS.clear()
    yield READS
    READS.clear()


def test_a_file_counts_its_size_and_its_offset(tmp_path, meter):
    path = tmp_path / "bus.bin"
    path.write_bytes(bytes(10_000))
    with open_input(str(path)) as f:
        assert meter.total() == 10_000 and meter.done() == 0
        f.seek(1234)
        assert meter.done() == 1234
        f.seek(0, os.SEEK_END)
        assert meter.done() == 10_000
    assert meter.done() == 10_000            # closed: where it was last seen


def test_parts_count_together_and_a_file_opened_again_counts_once(tmp_path, meter):
    a, b = tmp_path / "rec-0001.mcap", tmp_path / "rec-0002.mcap"
    a.write_bytes(bytes(3000))
    b.write_bytes(bytes(5000))
    fa, fb = open_input(str(a)), open_input(str(b))
    fa.seek(3000)
    fb.seek(1000)
    assert meter.total() == 8000 and meter.done() == 4000
    again = open_input(str(a))               # read from the start once more
    assert meter.total() == 8000 and meter.done() == 1000
    for f in (fa, fb, again):
        f.close()


def test_a_compressed_input_counts_its_compressed_bytes(tmp_path, meter):
    path = tmp_path / "bus.bin.gz"
    path.write_bytes(gzip.compress(os.urandom(200_000)))
    size = path.stat().st_size
    inp = Input(str(path))
    assert inp.compression == "gzip"
    data = inp.stream().read()
    assert len(data) == 200_000
    assert meter.total() == size and meter.done() == size
    inp.close()


def test_a_pipe_has_no_total(meter):
    r, w = os.pipe()
    os.write(w, b"x" * 100)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        meter.track(f)
        f.read()
        assert meter.total() is None


def test_nothing_opened_has_no_total():
    assert ReadMeter().total() is None and ReadMeter().done() == 0


def test_a_file_read_by_another_process_counts_what_it_reports(tmp_path, meter):
    path = tmp_path / "big.mcap"
    path.write_bytes(bytes(1000))
    with open_input(str(path)) as f:
        f.read(10)                               # this process's handle: a survey of the head
        meter.report(str(path), 600)             # the reader process: 600 bytes so far
        assert meter.total() == 1000 and meter.done() == 600
        meter.report(str(path), 400)             # a late, older report does not go back
        assert meter.done() == 600
    meter.report(str(tmp_path / "gone.mcap"), 5)   # a file that is not there: nothing
    assert meter.done() == 600
