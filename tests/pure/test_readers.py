"""Input detection as a registry walk (analyzer/sources/registry.py): each sample
capture is picked by the right reader, plain or gzip-compressed; a reader's own
rules (a .mcap name, text given as a raw dump, inputs that must come alone) are
its declaration's; and a new format is one ``Reader`` in ``READERS``."""

from __future__ import annotations

import gzip
import json
import os
import subprocess
import sys
from collections.abc import Iterator

import pytest
from mcap.writer import Writer

import analyzer
from analyzer.runner import TapRunner
from analyzer.sources import (
    LINE_AB,
    CaptureError,
    Chunk,
    Input,
    RawDumpSource,
    Reader,
    ReadSettings,
    SocatLogSource,
    Source,
    detect,
    formats,
    registry,
)
from analyzer.sources.mcapfile import McapSource
from analyzer.sources.pcapngfile import PcapngSource
from tests.conftest import BUS, CTL, DEV, ROOT, SOCAT_LOG

BT = 10 / 9600

CMD = bytes.fromhex("f80101010002503f94")   # a P? command
ACK = b"\x06"


def write_mcap(path) -> str:
    """A single-line recording of a command and its ACK, written with the mcap
    library (not gimbalscope's recorder) in the shape of our raw topic."""
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="", library="test_readers")
        cid = w.register_channel("/serial/AB/raw", "json", w.register_schema("raw", "jsonschema", b"{}"))
        offset = 0
        for data, t in ((CMD, 0.0), (ACK, 0.02)):
            payload = json.dumps({"line": "AB", "offset": offset, "t": t, "data": data.hex()}).encode()
            w.add_message(cid, log_time=1_795_000_000_000_000_000 + int(t * 1e9), data=payload, publish_time=0)
            offset += len(data)
        w.finish()
    return str(path)


def write_pcapng(path) -> str:
    """A single-line pcapng of a command and its ACK as gimbalscope packets:
    exported-PDU tags naming "gimbal", the header (analyzer/formats/pdu.py)
    with no problems, then the wire bytes; written block by block here."""
    import struct

    def block(kind: int, body: bytes) -> bytes:
        return struct.pack("<II", kind, 12 + len(body)) + body + struct.pack("<I", 12 + len(body))

    def packet(ns: int, wire: bytes, kind: int) -> bytes:
        tags = struct.pack(">HH", 12, 8) + b"gimbal\0\0" + struct.pack(">HH", 0, 0)
        header = bytes((1, kind, 0, 0)) + bytes(14) + bytes((2, 255)) + bytes(8) + bytes(2) + b"\xff\xff" \
            + bytes(2) + bytes(3) + bytes((0,)) + bytes((0,))
        data = tags + header + wire
        data += bytes(-len(data) % 4)
        return block(6, struct.pack("<IIIII", 0, ns >> 32, ns & 0xFFFFFFFF, len(tags + header + wire),
                                    len(tags + header + wire)) + data)

    name = b"AB"
    idb_opts = struct.pack("<HH", 2, 2) + name + b"\0\0" + struct.pack("<HH", 9, 1) + b"\x09\0\0\0" \
        + struct.pack("<HH", 0, 0)
    out = block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))
    out += block(1, struct.pack("<HHI", 252, 0, 0) + idb_opts)
    t0 = 1_795_000_000_000_000_000
    out += packet(t0, CMD, 1) + packet(t0 + 20_000_000, ACK, 3)
    with open(path, "wb") as f:
        f.write(out)
    return str(path)


def gzipped(tmp_path, path: str) -> str:
    out = tmp_path / (os.path.basename(path) + ".gz")
    with open(path, "rb") as f:
        out.write_bytes(gzip.compress(f.read()))
    return str(out)


def samples(tmp_path) -> dict[str, list[str]]:
    return {"socat": [SOCAT_LOG], "one raw": [BUS], "two raw": [CTL, DEV],
            "mcap": [write_mcap(tmp_path / "rec.mcap")], "pcapng": [write_pcapng(tmp_path / "cap.pcapng")]}


EXPECTED = {   # sample -> (reader name, source class, lines)
    "socat": ("socat -x -v log", SocatLogSource, ("A", "B")),
    "one raw": ("raw dump", RawDumpSource, (LINE_AB,)),
    "two raw": ("raw dump", RawDumpSource, ("A", "B")),
    "mcap": ("MCAP recording", McapSource, (LINE_AB,)),
    "pcapng": ("pcapng (gimbalscope packets)", PcapngSource, (LINE_AB,)),
}


def reader_name(paths: list[str]) -> str:
    inputs = [Input(p) for p in paths]
    try:
        return registry.reader_for(inputs).name
    finally:
        for i in inputs:
            i.close()


@pytest.mark.parametrize("packed", [False, True], ids=["plain", "gzip"])
@pytest.mark.parametrize("sample", list(EXPECTED))
def test_each_sample_is_picked_by_its_reader(tmp_path, sample, packed):
    paths = samples(tmp_path)[sample]
    if packed:
        paths = [gzipped(tmp_path, p) for p in paths]
    name, kind, lines = EXPECTED[sample]
    assert reader_name(paths) == name
    with detect(paths, BT) as src:
        assert type(src) is kind
        assert src.lines == lines
        assert next(iter(src.chunks())).data   # it reads


# every format, most specific first (docs/inputs.md, docs/instruments.md)
FORMATS = ["MCAP recording", "USB capture (usbmon, USBPcap)", "pcapng (gimbalscope packets)", "sigrok session",
           "VCD", "Saleae CSV export", "Saleae binary export", "socat -x -v log", "logic sample stream", "raw dump"]


def test_the_fallback_comes_last_and_the_names_are_listed():
    assert formats() == FORMATS
    assert registry.most_inputs() == 2


# ------------------------------------------------------------ each reader's own rules

def test_a_mcap_name_without_the_magic_is_refused(tmp_path):
    p = tmp_path / "rec.mcap"
    p.write_bytes(b"\xf8\x01\x01\x01\x00\x02P?\x94")   # a raw dump would take it
    with pytest.raises(CaptureError) as e:
        detect([str(p)], BT)
    assert str(e.value) == f"{p}: not an MCAP file (it does not start with the MCAP magic bytes)"


@pytest.mark.parametrize("alone, message", [
    ("socat", "{path}: a socat log carries both lines; give it on its own"),
    # several recordings are one tap's parts (docs/time.md, "Parts"); anything else is refused
    ("mcap", "{bus}: not an MCAP recording; several inputs must all be recordings of one tap"),
])
def test_formats_that_carry_every_line_come_alone(tmp_path, alone, message):
    path = samples(tmp_path)[alone][0]
    for paths in ([path, BUS], [BUS, path]):
        with pytest.raises(CaptureError) as e:
            detect(paths, BT)
        assert str(e.value) == message.format(path=path, bus=BUS)


def test_text_is_no_raw_dump(tmp_path):
    p = tmp_path / "note.txt"
    p.write_bytes(b"remember to check the cable\n")
    with pytest.raises(CaptureError) as e:
        detect([BUS, str(p)], BT)
    assert str(e.value) == (f"{p}: a text file that is not a socat -x -v log "
                            "(line 1: 'remember to check the cable'); raw dumps are binary")


def test_three_inputs_are_refused_as_before():
    with pytest.raises(CaptureError) as e:
        detect([CTL, DEV, BUS], BT)
    assert str(e.value) == "3 inputs given: expected one capture file, or two raw dumps (line A then line B)"


def test_detecting_does_not_import_the_mcap_package():
    code = ("import sys; from analyzer.sources import detect\n"
            f"for paths in ([{SOCAT_LOG!r}], [{BUS!r}], [{CTL!r}, {DEV!r}]):\n"
            "    detect(paths, 0.001).close()\n"
            "print(sorted(m for m in sys.modules if 'mcap' in m))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=60,
                         check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


# ------------------------------------------------------------ a new format

TOY_MAGIC = b"TOYCAP"


class ToySource(Source):
    """TOYCAP, then the bytes of a single-line tap."""

    lines = (LINE_AB,)

    def __init__(self, inp: Input) -> None:
        super().__init__()
        self.input = inp
        self.on_close(inp.close)

    def chunks(self) -> Iterator[Chunk]:
        yield Chunk(LINE_AB, self.input.stream().read()[len(TOY_MAGIC):])


def open_toy(inputs: list[Input], settings: ReadSettings) -> ToySource:
    inp, = inputs
    return ToySource(inp)


TOY = Reader("toy capture", open_toy, magic=TOY_MAGIC)


@pytest.fixture
def toy_registered():
    """The toy reader registered as a new format would be: one line in READERS."""
    saved = list(registry.READERS)
    registry.READERS.insert(0, TOY)
    try:
        yield
    finally:
        registry.READERS[:] = saved


@pytest.mark.parametrize("packed", [False, True], ids=["plain", "gzip"])
def test_a_registered_reader_is_found_with_no_other_change(tmp_path, toy_registered, packed):
    p = tmp_path / "bus.toy"
    p.write_bytes(TOY_MAGIC + CMD + ACK)
    path = gzipped(tmp_path, str(p)) if packed else str(p)
    assert "toy capture" in formats()
    with detect([path], BT) as src:
        assert type(src) is ToySource
        assert [c.data for c in src.chunks()] == [CMD + ACK]
    # the samples still go to their own readers
    assert reader_name([SOCAT_LOG]) == "socat -x -v log"
    assert reader_name([CTL, DEV]) == "raw dump"


def test_a_registered_reader_that_takes_one_input_refuses_two(tmp_path, toy_registered):
    p = tmp_path / "bus.toy"
    p.write_bytes(TOY_MAGIC + CMD)
    with pytest.raises(CaptureError) as e:
        detect([BUS, str(p)], BT)
    assert str(e.value) == f"{p}: a toy capture is one input; give it on its own"


def test_a_new_format_that_declares_nothing_more_is_read_as_a_file_of_bytes(tmp_path, toy_registered):
    # what the capture, the runner and CaptureInfo may ask of any source is declared
    # on Source, each with a file's answer: the toy declares none of it
    p = tmp_path / "bus.toy"
    p.write_bytes(TOY_MAGIC + CMD + ACK)
    capture = analyzer.open(str(p))
    src = capture.source
    assert not src.live and not src.input_per_line and not src.carries_metadata
    assert (src.physical, src.metadata, src.metadata_problem, src.faults) == (None, None, None, None)
    assert dict(src.state) == {} and src.measured_settings() == {} and src.time_origin == ""
    src.stop()   # a file ends by itself
    runner = TapRunner(capture)
    assert runner.run() == 2
    assert not runner.live and runner.line_states() == {} and runner.physical is None and runner.faults is None
    assert not runner.info.live and runner.info.time_origin == "" and not runner.info.line_errors
    assert capture.warnings == []   # no metadata record is missed: it is no recording


def test_the_registry_is_restored_after_the_toy():
    assert TOY not in registry.READERS
    assert formats() == FORMATS


def test_a_reader_must_say_how_it_recognises_its_input():
    with pytest.raises(ValueError):
        Reader("shapeless", open_toy)
