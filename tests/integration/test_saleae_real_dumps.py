"""The Saleae analyzer on real UART traffic nobody here made: the sigrok project's
example dumps (tests/data/sigrok-dumps/README.md), their bytes and times as
sigrok-cli's own uart decoder reads them told each dump's true settings
(tests/integration/test_sigrok_dumps_real.py's table). None of it is this protocol:
text, NMEA, MIDI, NFC frames, a scale's packets, a boot log. Fed to the analyzer as
Logic 2's Async Serial would give them, on one wire, its messages must be
gimbalscope's decode of the same bytes as Logic 2's data table export, one for one; and it
must never raise.

Logic 2 never tells an analyzer that the data has ended, so what only the end
decides (the last run of noise, a frame cut short at the end) is not shown
(docs/instruments.md, "The Saleae analyzer"): gimbalscope's last event may be
missing from the analyzer's messages, and nothing else.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess

import pytest

import analyzer
from analyzer.saleae.extension import analyzer_source
from tests.integration.test_sigrok_dumps_real import DUMPS, TRUTH, Truth
from tests.pure.test_saleae_analyzer import LINE, expected, flat, got
from tests.saleae_logic import Byte, Logic, async_serial_table

pytestmark = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")

# eight data bits (sigrok-cli writes a nine-bit character as two bytes), one per file
CASES = [pytest.param(t, id=t.file, marks=pytest.mark.xfail(
            strict=True, reason="a known difference: the analyzer shows none of the noise runs gimbalscope "
                                "cuts at this counter's silences")) if t.file == "uart_count_19200_8n1.sr"
         else pytest.param(t, id=t.file)
         for t in {t.file: t for t in TRUTH if t.data_bits == 8}.values()]


@pytest.fixture(scope="module")
def logic() -> Logic:
    return Logic(analyzer_source())


def sigrok_cli_characters(t: Truth) -> list[Byte]:
    """Each character sigrok-cli's uart decoder reads (told the truth's settings),
    with its start and end in seconds, on one wire."""
    parity = {"N": "none", "E": "even", "O": "odd"}[t.parity]
    opts = f"uart:baudrate={t.baud}:data_bits={t.data_bits}:parity={parity}:stop_bits=1.0:rx={t.channel}"
    if t.inverted:
        opts += ":invert_rx=yes"
    path = os.path.join(DUMPS, t.file)
    shown = subprocess.run(["sigrok-cli", "-i", path, "--show"], check=True, capture_output=True, text=True,
                           timeout=120).stdout
    rate = int(re.search(r"Samplerate: (\d+)", shown).group(1))
    out = subprocess.run(["sigrok-cli", "-i", path, "-P", opts, "-A", "uart=rx-data", "--protocol-decoder-samplenum"],
                         check=True, capture_output=True, text=True, timeout=120).stdout
    return [Byte("AB", int(a) / rate, int(b) / rate, int(value, 16))
            for a, b, value in re.findall(r"^(\d+)-(\d+) uart-1: ([0-9A-F]{2})$", out, re.MULTILINE)]


@pytest.mark.parametrize("truth", CASES)
def test_real_uart_dumps_read_as_gimbalscope_reads_them(logic, truth, tmp_path):
    characters = sigrok_cli_characters(truth)
    assert characters, truth.file
    table = tmp_path / "async-serial.csv"
    async_serial_table(table, characters, {"AB": "Async Serial"})
    # at the dump's own rate and format, as the Async Serial analyzer was set
    events = list(analyzer.open(str(table), baud=truth.baud, data_bits=truth.data_bits, parity=truth.parity,
                                stop_bits=truth.stop_bits))
    assert sum(len(ev.raw) for ev in events) == len(characters)
    frames = logic.run(characters, line=LINE["AB"])
    assert len(events) - 1 <= len(frames) <= len(events)   # the last one, decided by the end, may not show
    # the same messages; their times are Logic's measured ones, where gimbalscope's
    # reader places bytes at the nominal rate (docs/time.md), so they differ by
    # microseconds (a device's clock off its nominal rate) and are not compared here
    assert [got(f) for f in frames] == [flat(expected(ev)) for ev in events[:len(frames)]]
