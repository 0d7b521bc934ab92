"""The status bar's first line on a logic capture: its input named once and
whole (``stdin: logic samples at 1 MHz, 8 channels``), then each line's channel
and the rate and format its software UART measured, "measuring" until it has;
a serial port's line as before. Driven with Textual's Pilot on real captures: a
sample stream written as ``sigrok-cli -O binary`` writes one (tests/waveforms.py)
and opened as ``live --samples FILE --samplerate 1MHz`` opens it, and a VCD
viewed; the narrow widths on a feed of the test's own.

The rates expected are worked out from the clocks the waveforms were made with:
line A's sender runs 3 % fast, 9600 × 1.03 = 9,888 bit/s; line B's at 9,600.
The UART measures a bit time from edges sampled every microsecond (a bit is
about a hundred samples), so its rate may be off by a fraction of a per cent:
0.5 % is allowed, a sixth of what sets the two lines apart."""

from __future__ import annotations

import os
import re
import sys
import threading

import numpy as np
import pytest

import analyzer
from analyzer.capture import Options, open_samples
from analyzer.info import CaptureInfo
from analyzer.physical.report import LineReport
from analyzer.tui.app import GimbalscopeApp
from analyzer.tui.feed import FeedBatch, LineStatus
from analyzer.tui.model import CaptureModel
from analyzer.tui.model.sampled import LineMeasure, SampledInput, split_description
from analyzer.tui.run import make_app, stop_feed
from tests.conftest import frame
from tests.ui.test_pilot import exchange, live_on_ptys, run, settle
from tests.ui.test_status_bar import StillFeed
from tests.ui.test_status_fit import rows
from tests.waveforms import back_to_back, pack, uart_levels

RATE = 1_000_000                 # samples a second
A_BAUD = 9600 * 1.03             # a sender whose clock is 3 % fast
B_BAUD = 9600
A_EXPECTED, B_EXPECTED = 9888, 9600
TOLERANCE = 0.005
COMMAND = frame((1, 1, 1), 0, b"P?")
RESULT = frame((0, 1, 1), 1, b"0FA0FC18")
PERIOD = 0.100                   # seconds: one exchange, command then ACK and result
EXCHANGES = 8

# one line's part of the header: "A D0 9,888 bit/s 8N1" (" bit/s" and the channel go when short of room)
LINE = r"{line}(?: (?P<ch{line}>\S+))? (?P<rate{line}>\d{{1,3}}(?:,\d{{3}})*)(?P<unit{line}> bit/s)? 8N1"
LINES = re.compile(LINE.format(line="A") + "  " + LINE.format(line="B"))


def samples() -> bytes:
    """Eight exchanges at 1 MHz, channel 0 line A (3 % fast), channel 1 line B,
    as sigrok-cli's binary output has them (a byte a sample, channel N at bit N)."""
    a = uart_levels(back_to_back(COMMAND, 0.010, A_BAUD), RATE, A_BAUD, PERIOD)
    b = uart_levels(back_to_back(b"\x06", 0.030, B_BAUD) + back_to_back(RESULT, 0.034, B_BAUD), RATE, B_BAUD,
                    PERIOD)
    return pack(a, b) * EXCHANGES


def live_samples_app(path: str, given: str | None = None) -> GimbalscopeApp:
    """The TUI as ``live --samples PATH --samplerate 1MHz`` opens it (cli/live.py:
    ``run_samples``, then ``tap``)."""
    capture = open_samples(path, RATE, 1, Options(), given=given)
    info = CaptureInfo.of(capture, command="live")
    return make_app(capture, mode="live", ports=list(info.inputs), info=info)


def check_lines(wire: str, unit: bool = True, channels: tuple[str, str] | None = ("D0", "D1")) -> None:
    """Each line's measure in ``wire``, near the rate its clock was made at."""
    m = LINES.search(wire)
    assert m is not None, wire
    for line, expected in (("A", A_EXPECTED), ("B", B_EXPECTED)):
        rate = int(m[f"rate{line}"].replace(",", ""))
        assert abs(rate - expected) <= TOLERANCE * expected, (line, rate, wire)
        assert bool(m[f"unit{line}"]) == unit, wire
    if channels is not None:
        assert (m["chA"], m["chB"]) == channels, wire


@pytest.mark.parametrize("width", [120, 80])
def test_a_sample_stream_names_its_file_once_and_each_lines_measured_rate(tmp_path, monkeypatch, width):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "samples.bin").write_bytes(samples())
    app = live_samples_app("samples.bin")

    async def drive():
        async with app.run_test(size=(width, 24)) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.model.row_count >= 3 * EXCHANGES)
            await pilot.pause()
            wire = rows(app)[0].rstrip()
            assert len(wire) <= width - 2
            # the input once and whole, the way the sources describe it no more
            assert wire.startswith("samples.bin: logic samples at 1 MHz, 8 channels  A "), wire
            assert wire.count("samples.bin") == 1 and "(logic samples" not in wire and "…" not in wire, wire
            # no default settings beside the measures ("9600 8N1"), no port states
            assert "9600 8N1" not in wire and " open" not in wire, wire
            # at 80 columns each line loses its " bit/s", then (a longer name than stdin) its channel
            check_lines(wire, unit=width >= 100, channels=("D0", "D1") if width >= 100 else None)
            assert app.last.sampled is not None and [m.line for m in app.last.sampled.lines] == ["A", "B"]
        stop_feed(app)

    run(drive())


def test_a_sample_stream_on_standard_input_is_stdin(monkeypatch):
    """``sigrok-cli … -O binary | gimbalscope live --samples - …``: the samples come
    down a pipe on standard input, and the header says "stdin", whole at 80 columns."""
    read, write = os.pipe()
    data = samples()

    def sender():
        with os.fdopen(write, "wb") as f:
            f.write(data)
    threading.Thread(target=sender, daemon=True).start()
    stdin = os.fdopen(read, "rb")
    monkeypatch.setattr(sys, "stdin", stdin)
    app = live_samples_app("-")

    async def drive():
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.model.row_count >= 3 * EXCHANGES)
            await pilot.pause()
            wire = rows(app)[0].rstrip()
            assert wire.startswith("stdin: logic samples at 1 MHz, 8 channels  A "), wire
            assert wire.count("logic samples") == 1 and "standard input" not in wire, wire
            check_lines(wire, unit=False)
        stop_feed(app)

    try:
        run(drive())
    finally:
        stdin.close()


def write_vcd(path) -> str:
    """The same lines as a VCD (a microsecond a time step): wires ``tx`` (line A)
    and ``rx`` (line B), as a simulation or a logic analyser's export has them."""
    a = uart_levels(back_to_back(COMMAND, 0.010, A_BAUD), RATE, A_BAUD, PERIOD)
    b = uart_levels(back_to_back(b"\x06", 0.030, B_BAUD) + back_to_back(RESULT, 0.034, B_BAUD), RATE, B_BAUD,
                    PERIOD)
    a, b = np.tile(a, EXCHANGES), np.tile(b, EXCHANGES)
    changes: dict[int, list[str]] = {}
    for ident, levels in (("!", a), ('"', b)):
        for s in np.flatnonzero(np.diff(levels.astype(np.int8))) + 1:
            changes.setdefault(int(s), []).append(f"{levels[s]}{ident}")
    text = ["$timescale 1 us $end\n$scope module tap $end\n$var wire 1 ! tx $end\n$var wire 1 \" rx $end\n",
            "$upscope $end\n$enddefinitions $end\n#0\n$dumpvars\n1!\n1\"\n$end\n"]
    text += [f"#{t}\n" + "\n".join(changes[t]) + "\n" for t in sorted(changes)]
    text.append(f"#{len(a)}\n")
    with open(path, "w") as f:
        f.write("".join(text))
    return str(path)


@pytest.mark.parametrize("width", [120, 80])
def test_a_logic_file_viewed_names_its_input_once_and_each_lines_measure(tmp_path, monkeypatch, width):
    """``view rig.vcd``: decoded in a process of its own (decode_process.py), whose
    batches carry the lines' measures too."""
    monkeypatch.chdir(tmp_path)
    write_vcd(tmp_path / "rig.vcd")
    app = make_app(analyzer.open("rig.vcd"), mode="view")

    async def drive():
        async with app.run_test(size=(width, 24)) as pilot:
            await settle(pilot, app, lambda a: a.model.done and a.status_bar.sampled is not None)
            await pilot.pause()
            wire = rows(app)[0].rstrip()
            assert len(wire) <= width - 2 and wire.count("rig.vcd") == 1, wire
            assert re.match(r"rig\.vcd: VCD, 2 channels  loaded \d+\.\d kB  A ", wire), wire
            check_lines(wire, unit=width >= 100, channels=("tx", "rx") if width >= 100 else None)
        stop_feed(app)

    run(drive())


# ------------------------------------------------------------ narrow terminals, and before the measure
def stream(*lines: LineMeasure) -> SampledInput:
    return SampledInput("stdin", "logic samples at 1 MHz, 8 channels", lines)


A = LineMeasure("A", "D0", 9887.7, 9600, format="8N1")
B = LineMeasure("B", "D1", 9599.7, 9600, format="8N1")


def still_stream_app():
    feeds: list[StillFeed] = []

    def make_feed(deliver) -> StillFeed:
        feeds.append(StillFeed(deliver))
        return feeds[-1]
    app = GimbalscopeApp(CaptureModel(follow=True), make_feed, mode="live", source="-", settings="9600 8N1")
    return app, feeds


def batch(sampled: SampledInput | None, **kw) -> FeedBatch:
    desc = "standard input (logic samples at 1 MHz, 8 channels)"
    return FeedBatch([], [], [LineStatus("A", desc), LineStatus("B", desc)], settings="9600 8N1", sampled=sampled,
                     **kw)


@pytest.mark.parametrize("width, expected", [
    (120, "stdin: logic samples at 1 MHz, 8 channels  A D0 9,888 bit/s 8N1  B D1 9,600 bit/s 8N1  00:00:00"),
    (96, "stdin: logic samples at 1 MHz, 8 channels  A D0 9,888 bit/s 8N1  B D1 9,600 bit/s 8N1"),
    (80, "stdin: logic samples at 1 MHz, 8 channels  A D0 9,888 8N1  B D1 9,600 8N1"),
    (60, "stdin: logic samples at 1 MHz…  A 9,888 8N1  B 9,600 8N1"),
    (50, "stdin: logic samples…  A 9,888 8N1  B 9,600 8N1"),
    (40, "stdin  A 9,888 8N1  B 9,600 8N1"),
    (30, "stdin  A 9,888  B 9,600"),
])
def test_short_of_room_the_lines_shorten_alike_and_the_input_is_cut_between_words(width, expected):
    app, feeds = still_stream_app()

    async def drive():
        async with app.run_test(size=(width, 24)) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            feeds[0].deliver(batch(stream(A, B)))
            await pilot.pause()
            assert rows(app)[0].rstrip() == expected

    run(drive())


def test_a_line_not_measured_yet_says_so_until_it_is():
    app, feeds = still_stream_app()

    async def drive():
        async with app.run_test(size=(120, 24)) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            feeds[0].deliver(batch(stream(A, LineMeasure("B", "D1"))))
            await pilot.pause()
            assert "A D0 9,888 bit/s 8N1  B D1 measuring  00:00:0" in rows(app)[0], rows(app)
            feeds[0].deliver(batch(stream(A, B)))
            await pilot.pause()
            assert "A D0 9,888 bit/s 8N1  B D1 9,600 bit/s 8N1  00:00:0" in rows(app)[0], rows(app)
            # a last word without the measures (a process that failed) keeps them
            feeds[0].deliver(batch(None, done=True, error="OSError: gone"))
            await pilot.pause()
            assert "B D1 9,600 bit/s 8N1" in rows(app)[0] and "capture ended" in rows(app)[1], rows(app)

    run(drive())


def test_a_capture_that_ended_before_a_line_was_measured_says_no_rate():
    app, feeds = still_stream_app()

    async def drive():
        async with app.run_test(size=(120, 24)) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            feeds[0].deliver(batch(stream(A, LineMeasure("B", "D1")), done=True))
            await pilot.pause()
            assert "B D1 no rate" in rows(app)[0] and "measuring" not in rows(app)[0], rows(app)

    run(drive())


def test_an_inverted_line_and_a_channel_named_by_its_number():
    app, feeds = still_stream_app()
    a = LineMeasure("A", "0", 9887.7, 9600, format="8N1", inverted=True)

    async def drive():
        async with app.run_test(size=(120, 24)) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            feeds[0].deliver(batch(SampledInput("rig.sr", "sigrok session (version 2, 2 channels)", (a,))))
            await pilot.pause()
            assert rows(app)[0].startswith("rig.sr: sigrok session (version 2, 2 channels)  A ch0 9,888 bit/s 8N1 "
                                           "inverted  00:00:0"), rows(app)

    run(drive())


def test_a_long_path_loses_whole_folders_never_part_of_a_word():
    app, feeds = still_stream_app()
    path = "/home/operator/captures/site-north/gimbal-rig-7/samples.bin"

    async def drive():
        async with app.run_test(size=(60, 24)) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            feeds[0].deliver(batch(SampledInput(path, "logic samples at 1 MHz, 8 channels", (A, B))))
            await pilot.pause()
            wire = rows(app)[0].rstrip()
            assert wire.startswith("…/") and wire.endswith("/samples.bin  A 9,888 8N1  B 9,600 8N1"), wire
            kept = wire[1:].split(" ")[0]
            assert path.endswith(kept) and path[-len(kept) - 1] != "/", wire   # whole folders from a slash on
            assert len(wire) <= 58, wire

    run(drive())


def test_a_long_path_with_a_recording_keeps_the_file_name_and_the_rates():
    """80 columns, a long input's path and a recording: what is left out is left
    out whole; the rates, the file's name and the recording stay."""
    app, feeds = still_stream_app()
    path = "/home/operator/captures/site-north/gimbal-rig-7/samples.bin"
    recording = "/home/operator/captures/site-north/gimbal-rig-7/2024-05-17T08-31-02.mcap"

    async def drive():
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot, app, lambda a: bool(feeds))
            feeds[0].deliver(batch(SampledInput(path, "logic samples at 1 MHz, 8 channels", (A, B)),
                                   recording=recording, recording_bytes=12_300_000))
            await pilot.pause()
            wire = rows(app)[0].rstrip()
            assert len(wire) <= 78 and "/samples.bin" in wire and "A 9,888" in wire and "B 9,600" in wire, wire
            assert "● REC" in wire and wire.endswith(".mcap 12.3 MB"), wire

    run(drive())


def test_the_sources_descriptions_split_into_name_and_kind():
    assert split_description("standard input (logic samples at 1 MHz, 8 channels)") == (
        "stdin", "logic samples at 1 MHz, 8 channels")
    assert split_description("rig (copy).sr (sigrok session (version 2, 8 channels), gzip)") == (
        "rig (copy).sr", "sigrok session (version 2, 8 channels), gzip")
    kind = "Saleae binary export, version 1"
    assert split_description(f"digital_0.bin ({kind}) + digital_1.bin ({kind})") == (
        "digital_0.bin + digital_1.bin", kind)
    assert split_description("tap.vcd") == ("tap.vcd", "")


def test_swapped_lines_name_the_channel_each_line_is_read_from_now():
    """``--swap-lines`` (the live ``x`` key): channel D0 is read as line B."""
    a, b = LineReport("A", "D0", measured=9887.7, nominal=9600), LineReport("B", "D1")
    desc = "standard input (logic samples at 1 MHz, 8 channels)"
    assert [(m.line, m.channel, m.rate()) for m in SampledInput.of(desc, [a, b]).lines] == [
        ("A", "D0", "9,888"), ("B", "D1", None)]
    assert [(m.line, m.channel, m.rate()) for m in SampledInput.of(desc, [a, b], swapped=True).lines] == [
        ("A", "D1", None), ("B", "D0", "9,888")]
    # a rate given (--baud) and no clock measured yet: the rate given
    assert LineMeasure.of(LineReport("AB", "D0", nominal=19200, given=True)).rate() == "19,200"


def test_a_serial_ports_header_is_as_it_was():
    """Two ports: each named, its state and bytes/s, then the settings and the
    clock; no measures."""
    app, ma, mb = live_on_ptys()

    async def drive():
        async with app.run_test(size=(120, 24)) as pilot:
            exchange(ma, mb)
            await settle(pilot, app, lambda a: a.model.row_count >= 2)
            wire = rows(app)[0].rstrip()
            assert re.fullmatch(r"A /dev/pts/\d+ open \d+ B/s  B /dev/pts/\d+ open \d+ B/s  9600 8N1  00:00:\d\d",
                                wire), wire
            assert app.last.sampled is None and app.status_bar.sampled is None
        stop_feed(app)

    run(drive())
