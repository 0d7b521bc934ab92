"""Real UART captures from the sigrok project's example dumps
(tests/data/sigrok-dumps/README.md), read by our software UART with nothing
told: no rate, no format, no polarity, and channels only where the file has
other toggling channels besides the ones its README names as the UART.

Each case's truth (rate, data bits, parity, stop bits, polarity, channel) comes
from the capture's README and file name, checked by reading it with sigrok-cli's
own ``uart`` decoder told those settings: readable text or valid frames, no
framing or parity error (where a README is wrong, the table says so and why).
Against that truth, for every case:

- our bytes on the line are sigrok-cli's bytes (the ``glitch_*`` files: the
  character the file's name says was sent; docs/instruments.md, "Glitches");
- the nominal rate we report is the true rate;
- the format and polarity we report are the true ones.

The expectations never come from our own output.
"""

from __future__ import annotations

import functools
import os
import shutil
import subprocess
from dataclasses import dataclass

import pytest

import analyzer
from tests.conftest import ROOT

pytestmark = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")

DUMPS = os.path.join(ROOT, "tests", "data", "sigrok-dumps")


@dataclass(frozen=True)
class Truth:
    file: str
    channel: str                      # as the file names it (sigrok-cli --show)
    baud: int
    data_bits: int = 8
    parity: str = "N"
    stop_bits: float = 1
    inverted: bool = False            # idle low: RS-232 polarity
    # --channels, only where channels the README does not name as the UART toggle too
    channels: tuple[tuple[str, str], ...] = ()
    sent: bytes | None = None         # glitch files: the characters their names say were sent
    # bytes sigrok-cli reads in a burst of junk before the traffic, which we take as
    # glitches (docs/instruments.md, "Glitches"): ours are sigrok-cli's from there on
    theirs_from: int = 0

    @property
    def format(self) -> str:
        return f"{self.data_bits}{self.parity}{self.stop_bits:g}"

    @property
    def id(self) -> str:
        return f"{self.file}:{self.channel}"


def hello(rate: int, fmt: str = "8n1") -> Truth:
    # uart/hello_world/README: "Hello World!\r\n" repeated, USART1.TX of an STM32
    # (probe 0, named TX in the files), in the format and at the rate of the name
    return Truth(f"hello_world_{fmt}_{rate}.sr", "TX", rate, int(fmt[0]), fmt[1].upper(), int(fmt[2]))


def counter(bits: int) -> Truth:
    # uart/counter/README: an ATmega328P counting at 19200 in 5n1 ... 9n1 on "tx";
    # "ch" toggles too (high while a frame is sent) and "rx" is idle, so the line is named
    return Truth(f"uart_count_19200_{bits}n1.sr", "tx", 19200, bits, channels=(("A", "tx"),))


TRUTH = [
    # --- rates: the same text from 1200 to 921600 bit/s (uart/hello_world/8n1)
    *(hello(r) for r in (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600)),
    # --- parities (uart/hello_world/{7e1,7o1,8e1,8o1})
    hello(115200, "7e1"), hello(115200, "7o1"), hello(115200, "8e1"), hello(115200, "8o1"),
    # --- 5 to 9 data bits (uart/counter)
    *(counter(b) for b in (5, 6, 7, 8, 9)),
    # --- two stop bits. uart/errors has no README: "AMPEL 64\n" in the format of the
    # name; its characters start 11 bits apart, back to back with two stop bits
    Truth("ampel64_4800_8n2_ok.sr", "TX", 4800, stop_bits=2),
    Truth("ampel64_4800_8n1_ok.sr", "TX", 4800),
    # the same sender with framing errors: sigrok-cli keeps their bytes, as we do
    Truth("ampel64_4800_8n1_frame_errors.sr", "TX", 4800),
    # uart/kern_ew_6200-2nm/README: the scale sends at "1200/8n2 per default. Some of
    # the dumps use 9600/8o2 though (see filename)". Its probe 0 (the scale's TX) is
    # named RX in these files. The scale's clock runs 1.7 % fast (a bit is 819.2 us,
    # 102.4 us): nominally 1200 and 9600; its characters start 11 and 12 bits apart
    Truth("kern_ew_6200-2nm_tare.sr", "RX", 1200, stop_bits=2),
    Truth("kern_ew_6200-2nm_402_95g_15byte_packet_unstable_9600_8o2.sr", "RX", 9600, parity="O", stop_bits=2),
    Truth("kern_ew_6200-2nm_2014_8ct_15byte_packet_unstable_9600_8o2.sr", "RX", 9600, parity="O", stop_bits=2),
    # --- an RS-232 transceiver (uart/maxim_max3232e/README): 57600 8n1, "Hello world\r\n";
    # DOUT1 is at RS-232 polarity (inverted), DIN1 at logic polarity
    Truth("max3232e_hello_world_57600_8n1.sr", "MAX3232E DOUT1", 57600, inverted=True),
    Truth("max3232e_hello_world_57600_8n1.sr", "MAX3232E DIN1", 57600),
    # --- glitches (uart/errors, "EMC-induced glitches", no README): one character each
    # (three in the last), 2 MHz, a bit 17.4 samples: 115200 8n1, as sigrok-cli reads the
    # named characters where no glitch falls on its sampling point. Where one does
    # (0x0a, 0x45_2, 0x4f_2 and the 0x0a of the last), sigrok-cli reads 0x0e, 0xc5,
    # 0x5f and 0x85 (a framing error): we are to read what was sent
    Truth("glitch_0x45.sr", "RX", 115200, sent=b"\x45"),
    Truth("glitch_0x0a.sr", "RX", 115200, sent=b"\x0a"),
    Truth("glitch_0x45_2.sr", "RX", 115200, sent=b"\x45"),
    Truth("glitch_0x4f_2.sr", "RX", 115200, sent=b"\x4f"),
    Truth("glitch_0x4f_0x4b_0x0a.sr", "TX", 115200, sent=b"\x4f\x4b\x0a"),
    # --- instruments and boot logs
    # uart/gps/mtk3339/README: NMEA at 9600 8N1, 200 kHz
    Truth("mtk3339_8n1_9600.sr", "TX", 9600),
    # uart/cyrustek_es51978/README says "2400 baud, with 7e1 settings". Corrected to 7o1:
    # told parity=even, sigrok-cli flags every one of the 66 characters with a parity
    # error; told parity=odd, none, and they read "506793002\r\n" (the meter's 11-byte
    # packets). libsigrok's serial-dmm driver opens this meter (ISO-TECH IDM103N) at
    # "2400/7o1" too
    Truth("es51978.sr", "RX", 2400, 7, "O"),
    # uart/trekstor_ebr30_a/README: boot log at 115200 8n1, sampled at 1 MHz (8.7 samples
    # a bit). Its first 6 ms are a 200 kHz burst (pulses of 2 and 3 samples) and a 29 ms
    # break before "HELLO! BOOT0 is starting!": sigrok-cli reads no character in the
    # burst but one 0x00 (a framing error) where it ends
    Truth("trekstor_ebr30_a_uart.sr", "TX", 115200, theirs_from=1),
    # uart/midi/rockband_wireless_keyboard_wii/README: MIDI (31250 8n1, the MIDI 1.0
    # specification's; uart/midi/artifically_generated/README says so too), 1 MHz.
    # Bytes: active sensing 0xFE, note on 0x90 kk vv, note off 0x80 kk vv
    Truth("midi_multiple_keys.sr", "RX", 31250),
    # uart/nfc/pn532/README says "a baud rate of 106000 8N1". Corrected to 115200: the
    # bits are 8.68 samples at 1 MHz (9.43 at 106000), and at 115200 both lines are
    # valid PN532 frames (00 00 FF LEN LCS D4/D5 ... DCS 00, ACKs 00 00 FF 00 FF 00),
    # where at 106000 sigrok-cli reads framing errors. 115200 is the PN532's default
    # host-link rate; 106 kbit/s is the ISO/IEC 14443A radio rate libnfc's log names.
    # RX carries the PN532's answers (D5), TX the host's commands (D4): the capture
    # starts in the middle of a TX character (three framing errors at its start)
    Truth("mifare_3d99c723_8n1_106000.sr", "RX", 115200),
    Truth("mifare_3d99c723_8n1_106000.sr", "TX", 115200),
    # uart/amulet_lcd/README: 115200/8n1 at 10 MHz between an Amulet LCD and a video
    # mixer's CPU; probe 0 ("Pin 1" in the file) is the display's RX, probe 1 ("Pin 3")
    # its TX. "Pin 3" is low until 0.72 s, then pulses of 1 to 20 samples (the CPU
    # starting: sigrok-cli reads framing errors, breaks and 00 FF 00 FF C0) come
    # before its characters; "Pin 1" first toggles 19 s in, past what a reader looks at
    # before choosing its channels: named here, as sigrok-cli needs them named.
    # The README says 8n1; "Pin 3"'s characters start 11 bits apart every time, back
    # to back: one stop bit and a bit of idle, which is what two stop bits look like
    # on the wire (and reads the same bytes): we say what the wire shows
    Truth("bootup.sr", "Pin 1", 115200, channels=(("A", "Pin 1"), ("B", "Pin 3"))),
    Truth("bootup.sr", "Pin 3", 115200, stop_bits=2, channels=(("A", "Pin 1"), ("B", "Pin 3")), theirs_from=4),
    # uart/tondaj_sl-814/README: "9600 baud, 8e1", RX and TX (a dozen characters each)
    Truth("sl-814_uart_run.sr", "RX", 9600, parity="E"),
    Truth("sl-814_uart_run.sr", "TX", 9600, parity="E"),
    # uart/panasonic_pan1321/README: 115200 8n1 at 500 kHz (4.3 samples a bit); TX is
    # the AT commands the README lists, RX the module's "ROK" and "OK"s
    Truth("panasonic_pan1321_init.sr", "TX", 115200),
    Truth("panasonic_pan1321_init.sr", "RX", 115200),
    # uart/v_and_a_va18b_cable/README: 2400 8n1 at 16 MHz; the PL2303's RX is the meter's
    # data (14-byte packets 0x1? 0x2? ... 0xE?). The IR LED and the USB lines toggle too
    Truth("v_and_a_va18b_cable_ir_serial_usb.sr", "RX", 2400, channels=(("A", "RX"),)),
    # uart/unitsize (no README): "uart_a", 115200 on channel B4 of a 4-byte sample;
    # one character, "A"
    Truth("zp_b4_uart_a_115200_unitsize4.sr", "B4", 115200),
    # uart/toim4243/README: ten bytes 0x11 ... 0xaa at 57600 into the TOIM4232's TD_232
    # (the part is named TOIM4243 in the file); the chip's other pins toggle too
    Truth("toim4243_10byte_send_snippet.sr", "TOIM4243 TD_232", 57600, channels=(("A", "TOIM4243 TD_232"),)),
]


# ------------------------------------------------------------------ sigrok-cli, told the truth
def sigrok_cli_bytes(t: Truth) -> bytes:
    """What sigrok-cli's uart decoder reads on the truth's channel with its settings.
    Its stop_bits option stops at 1.5: two stop bits are read as one and idle.
    Nine data bits: it writes each character as two bytes, high first."""
    parity = {"N": "none", "E": "even", "O": "odd"}[t.parity]
    opts = f"uart:baudrate={t.baud}:data_bits={t.data_bits}:parity={parity}:stop_bits=1.0:rx={t.channel}"
    if t.inverted:
        opts += ":invert_rx=yes"
    got = subprocess.run(["sigrok-cli", "-i", os.path.join(DUMPS, t.file), "-P", opts, "-B", "uart=rx"],
                         check=True, capture_output=True, timeout=120)
    return got.stdout


# ------------------------------------------------------------------ ours, told nothing
@dataclass
class Read:
    lines: dict              # line -> bytes
    physical: dict           # line -> LineReport
    error: Exception | None = None


def our_read(file: str, channels: tuple[tuple[str, str], ...]) -> Read:
    try:
        cap = analyzer.open(os.path.join(DUMPS, file), **({"channels": dict(channels)} if channels else {}))
        out: dict[str, bytearray] = {}
        for ev in cap:
            if ev.raw:
                out.setdefault(ev.line, bytearray()).extend(ev.raw)
        return Read({line: bytes(b) for line, b in out.items()}, dict(cap.source.physical))
    except Exception as e:  # noqa: BLE001 - said in each test of the file, not as an error of the fixture
        return Read({}, {}, e)


@pytest.fixture(scope="module")
def reads():
    """Each file read once by us and each (file, channel) once by sigrok-cli."""
    return functools.cache(our_read), functools.cache(sigrok_cli_bytes)


def line_of(t: Truth, read: Read):
    """Our line on the truth's channel, and its report."""
    if read.error is not None:
        pytest.fail(f"{t.file}: {type(read.error).__name__}: {read.error}")
    for line, report in read.physical.items():
        if report.channel == t.channel:
            return line, report
    chosen = {line: r.channel for line, r in read.physical.items()}
    pytest.fail(f"{t.file}: channel {t.channel!r} is not read (lines chosen: {chosen})")


def first_difference(a: bytes, b: bytes) -> str:
    n = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    return (f"ours {len(a)} bytes, expected {len(b)}; first difference at byte {n}: "
            f"ours {a[n:n + 12].hex(' ') or '(end)'}, expected {b[n:n + 12].hex(' ') or '(end)'}")


CASES = [pytest.param(t, id=t.id) for t in TRUTH]


@pytest.mark.parametrize("t", CASES)
def test_the_bytes_are_the_ones_sent(t: Truth, reads):
    ours_of, theirs_of = reads
    read = ours_of(t.file, t.channels)
    line, _report = line_of(t, read)
    ours = read.lines.get(line, b"")
    if t.sent is not None:
        # a glitch on a bit's middle changes sigrok-cli's byte; we drop pulses under a
        # quarter bit first (docs/instruments.md, "Glitches") and read the one sent
        expected = t.sent
    else:
        expected = theirs_of(t)[t.theirs_from:]
        assert len(expected) >= 1       # the truth reads something
    assert ours == expected, first_difference(ours, expected)


@pytest.mark.parametrize("t", CASES)
def test_the_rate_is_the_true_one(t: Truth, reads):
    ours_of, _ = reads
    _line, report = line_of(t, ours_of(t.file, t.channels))
    assert report.nominal == t.baud, f"measured {report.measured} bit/s"


@pytest.mark.parametrize("t", CASES)
def test_the_format_and_polarity_are_the_true_ones(t: Truth, reads):
    ours_of, _ = reads
    _line, report = line_of(t, ours_of(t.file, t.channels))
    assert (report.format, report.inverted) == (t.format, t.inverted)


def test_every_capture_in_the_folder_has_a_truth():
    # a dump added to tests/data/sigrok-dumps is to be checked here too
    files = {f for f in os.listdir(DUMPS) if f.endswith(".sr")}
    assert files == {t.file for t in TRUTH}
