"""Hostile instrument captures: sigrok sessions, VCD, Saleae Logic 2 exports
(digital CSV, Async Serial table, binary) and USB captures (usbmon, USBPcap),
damaged every way a file gets damaged or written wrong, and a line of noise.

The corpus is made here from small valid captures of the same conversation (the
test helpers' writers, and sigrok-cli for the .sr) by a mutator with fixed seeds:
files cut at many points, bits flipped, bytes inserted and deleted, and, format
by format, what a writer gets wrong (a sample rate of 0, 3 bytes a sample, 1000
probes, members missing, twice or out of order, a time scale of kiloseconds,
times that go back, identifiers never declared, numbers of 25 digits, NaN,
packet lengths of 4 GB, link types that are no USB's).

Every mutant is read by ``decode`` and ``doctor``, each in a process of its own
(tests/forked_cli.py) with a timeout that catches a hang, and must end as the
command promises: exit 0, 1 or 2 (``doctor``: 3 too, its status for error
findings, docs/doctor.md), no traceback, nothing on standard error but
``gimbalscope:`` lines (one printable line each: names from the file cannot
break it), one error line when it refuses (2), and a few hundred MB of memory at
most for inputs of a few KB.

Then noise a software UART must survive, read by the console command itself: a
burst of 1,500 pulses of a third of a bit in a row (each a start bit that fails)
in a session, a million of them in a session and in a sample stream (``live
--samples``), and a stream of random samples.
"""

from __future__ import annotations

import gzip
import io
import itertools
import json
import lzma
import os
import random
import re
import shutil
import struct
import subprocess
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import frame, run_cli
from tests.forked_cli import run_many
from tests.integration.test_logic_formats import (
    RATE,
    conversation,
    edges,
    sigrok_vcd,
    write_binary,
    write_digital_csv,
    write_table,
    write_vcd,
)
from tests.integration.test_logic_sigrok import session
from tests.integration.test_usb_captures import WRITERS, ftdi_conversation
from tests.usb_captures import FT232R, UsbCapture
from tests.waveforms import back_to_back, pack, uart_levels

HAS_SIGROK = shutil.which("sigrok-cli") is not None
needs_sigrok = pytest.mark.skipif(not HAS_SIGROK, reason="sigrok-cli is not installed")

RUN_TIMEOUT = 30          # seconds: a run of a few-KB input takes well under one; over this it hangs
MEMORY_LIMIT_MB = 600     # a few-KB input read in blocks: the command's own size and a little more
DECODE_CODES = {0, 1, 2}
DOCTOR_CODES = {0, 1, 2, 3}   # 3: error findings (docs/doctor.md, "Exit status")
ONE_LINE = re.compile(r"^gimbalscope: (error|warning): .+$")


@dataclass
class Mutant:
    name: str
    files: list[tuple[str, bytes]]              # (file name, bytes), given in this order
    args: tuple[str, ...] = field(default=())


# ------------------------------------------------------------------ the mutator

# Options that take the reader down other paths (a rate given: no measuring; the
# lines named: no choosing), given in turn to the mutants of bytes
SAMPLED_ARGS = ((), ("--baud", "9600"), ("--channels", "A=1,B=0"))
# A channel the capture does not have: the error lists the file's channel names
NO_SUCH_CHANNEL = ("--channels", "A=zzz")


def byte_mutants(label: str, filename: str, data: bytes, rng: random.Random,
                 others: list[tuple[str, bytes]] = (), arg_sets=SAMPLED_ARGS) -> list[Mutant]:
    """``data`` cut at several points, bits flipped, bytes inserted and deleted
    (``others``: files given with it, kept whole), each read with the options of
    ``arg_sets`` in turn."""
    n = len(data)
    out: list[tuple[str, bytes]] = []
    for cut in sorted({1, n // 3, 2 * n // 3, n - 1, rng.randrange(2, n - 1)}):
        out.append((f"cut at {cut} of {n}", data[:cut]))
    for flips in (1, 16):
        b = bytearray(data)
        for _ in range(flips):
            b[rng.randrange(n)] ^= 1 << rng.randrange(8)
        out.append((f"{flips} bits flipped", bytes(b)))
    at = rng.randrange(n)
    out.append((f"8 bytes inserted at {at}", data[:at] + bytes(rng.randrange(256) for _ in range(8)) + data[at:]))
    at = rng.randrange(n - 37)
    out.append((f"37 bytes deleted at {at}", data[:at] + data[at + 37:]))
    return [Mutant(f"{label}: {what}" + (f" ({' '.join(args)})" if args else ""), [(filename, d), *others], args)
            for (what, d), args in zip(out, itertools.cycle(arg_sets))]


def text_mutants(label: str, filename: str, text: str, edits: list[tuple]) -> list[Mutant]:
    """``edits``: (what, the text edited) or (what, the text, options to read it with)."""
    return [Mutant(f"{label}: {what}", [(filename, t.encode())], tuple(args[0]) if args else ())
            for what, t, *args in edits if t != text]


def swap_lines(text: str, i: int, j: int) -> str:
    lines = text.splitlines(keepends=True)
    lines[i], lines[j] = lines[j], lines[i]
    return "".join(lines)


def insert_line(text: str, at: int, line: str) -> str:
    lines = text.splitlines(keepends=True)
    lines.insert(at, line + "\n")
    return "".join(lines)


def replace_line(text: str, at: int, line: str) -> str:
    lines = text.splitlines(keepends=True)
    lines[at] = line + "\n"
    return "".join(lines)


# ------------------------------------------------------------------ sigrok sessions

def zip_of(members: list[tuple[str, bytes]], method: int = zipfile.ZIP_DEFLATED) -> bytes:
    buf = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")            # a duplicated member is the point, not a mistake here
        with zipfile.ZipFile(buf, "w", method) as z:
            for name, data in members:
                z.writestr(name, data)
    return buf.getvalue()


def with_meta(meta: str, key: str, value: str | None) -> str:
    """``meta`` with ``key`` of its device section set to ``value`` (None: removed)."""
    lines = [ln for ln in meta.splitlines() if ln.split("=", 1)[0].strip() != key]
    if value is not None:
        at = next(i for i, ln in enumerate(lines) if ln.strip().startswith("[device")) + 1
        lines.insert(at, f"{key}={value}")
    return "\n".join(lines) + "\n"


DOS_DATE_TIME = ((2026 - 1980) << 9 | 1 << 5 | 5) << 16   # a zip's modification time: 5 Jan 2026, 00:00


def patch_member(data: bytes, member: str, local_at: int, central_at: int, fmt: str, value: int) -> bytes:
    """A zip with a field of ``member``'s local header and central directory entry
    set to ``value`` (offsets in the headers)."""
    z = zipfile.ZipFile(io.BytesIO(data))
    out = bytearray(data)
    struct.pack_into(fmt, out, z.getinfo(member).header_offset + local_at, value)
    at = z.start_dir
    while out[at:at + 4] == b"PK\x01\x02":
        name_len, extra_len, comment_len = struct.unpack_from("<HHH", out, at + 28)
        if out[at + 46:at + 46 + name_len] == member.encode():
            struct.pack_into(fmt, out, at + central_at, value)
        at += 46 + name_len + extra_len + comment_len
    return bytes(out)


def sigrok_mutants(sr: bytes, rng: random.Random) -> list[Mutant]:
    z = zipfile.ZipFile(io.BytesIO(sr))
    members = [(i.filename, z.read(i)) for i in z.infolist()]
    named = dict(members)
    meta = named["metadata"].decode()
    logic = [n for n, _ in members if n.startswith("logic-1")]

    def remeta(text: str | bytes) -> bytes:
        body = text.encode() if isinstance(text, str) else text
        return zip_of([(n, body if n == "metadata" else d) for n, d in members])

    settings = [
        ("samplerate", "0"), ("samplerate", "-1 MHz"), ("samplerate", "1 Hz"),
        ("samplerate", "9" * 40 + " GHz"), ("samplerate", "fast"), ("samplerate", ""), ("samplerate", None),
        ("unitsize", "3"), ("unitsize", "0"), ("unitsize", "8"), ("unitsize", "x"),
        ("unitsize", "9" * 30), ("unitsize", "2"), ("unitsize", "4"),
        ("total probes", "1000"),
        ("probe0", "zero"), ("probe1000", "far"), ("probe9", "ninth"), ("probe" + "9" * 25, "huge"),
        ("probe1", None), ("probe2", "0"), ("probe1", ""), ("probe1", "\x1b[31mTX\x07"),
        ("capturefile", None), ("capturefile", "nothere"), ("capturefile", "metadata"),
        ("capturefile", "version"), ("capturefile", ""),
    ]
    out = [Mutant(f"sigrok: metadata {k}={v!r}", [("cap.sr", remeta(with_meta(meta, k, v)))],
                  NO_SUCH_CHANNEL if "\x1b" in (v or "") else ()) for k, v in settings]
    no_probes = meta
    for k in [ln.split("=", 1)[0] for ln in meta.splitlines() if ln.startswith("probe")]:
        no_probes = with_meta(no_probes, k, None)
    out += [Mutant(f"sigrok: metadata {what}", [("cap.sr", remeta(text))]) for what, text in [
        ("with no probes", no_probes),
        ("with no device section", meta.replace("[device 1]", "[global 2]")),
        ("of device 99 only", meta.replace("[device 1]", "[device 99]")),
        ("empty", ""),
        ("of random bytes", bytes(rng.randrange(256) for _ in range(300))),
        ("not UTF-8", meta.encode() + b"probe3=\xff\xfe\xc3\n"),
        ("of 1 MB of keys", meta + "".join(f"key{i}=value\n" for i in range(60_000))),
        ("with its lines indented and spaced", "\n".join("   " + ln.replace("=", " = ") for ln in meta.splitlines())),
    ]]
    out += [Mutant(f"sigrok: version {what}", [("cap.sr", zip_of([(n, v if n == "version" else d)
                                                                   for n, d in members]))])
            for what, v in [("99", b"99"), ("empty", b""), ("random bytes", bytes(range(200, 256)))]]
    first_chunk = logic[0]
    chunk = named[first_chunk]
    head = [(n, d) for n, d in members if not n.startswith("logic")]
    member_edits = [
        ("no metadata", [(n, d) for n, d in members if n != "metadata"]),
        ("no version", [(n, d) for n, d in members if n != "version"]),
        ("no logic chunks", head),
        ("the chunk renamed logic-1-2", head + [("logic-1-2", chunk)]),
        ("chunks logic-1-0 and logic-1-<25 digits>",
         head + [("logic-1-0", chunk[:999]), ("logic-1-" + "9" * 25, chunk)]),
        ("the chunk named logic-1-007", head + [("logic-1-007", chunk)]),
        ("the chunk named logic-1 as version 1 has it", head + [("logic-1", chunk)]),
        ("metadata twice", members + [("metadata", b"[device 1]\ncapturefile=logic-1\nsamplerate=0\n")]),
        ("the chunk twice", members + [(first_chunk, chunk[::-1])]),
        ("metadata before version",
         [m for m in members if m[0] == "metadata"] + [m for m in members if m[0] != "metadata"]),
        ("the chunk first", [(first_chunk, chunk)] + [m for m in members if m[0] != first_chunk]),
        ("a chunk of an odd length", [(n, d[:-1] if n == first_chunk else d) for n, d in members]),
        ("a chunk of one byte", [(n, d[:1] if n == first_chunk else d) for n, d in members]),
        ("an empty chunk", [(n, b"" if n == first_chunk else d) for n, d in members]),
        ("a directory member", members + [("logic-1-9/", b"")]),
    ]
    out += [Mutant(f"sigrok: members: {what}", [("cap.sr", zip_of(ms))]) for what, ms in member_edits]
    out.append(Mutant("sigrok: members stored, not deflated", [("cap.sr", zip_of(members, zipfile.ZIP_STORED))]))
    # header fields no writer should set: (what, local offset, central offset, format, value)
    stored = zip_of(members, zipfile.ZIP_STORED)
    for what, member, local_at, central_at, fmt, value in [
        ("compression method 99", first_chunk, 8, 10, "<H", 99),
        ("compression method bzip2 on stored bytes", first_chunk, 8, 10, "<H", 12),
        ("compression method deflate on stored bytes", first_chunk, 8, 10, "<H", 8),
        ("metadata of compression method 99", "metadata", 8, 10, "<H", 99),
        ("the encrypted flag", first_chunk, 6, 8, "<H", 1),
        ("metadata with the encrypted flag", "metadata", 6, 8, "<H", 1),
        ("a wrong CRC", first_chunk, 14, 16, "<I", 0x12345678),
        ("metadata with a wrong CRC", "metadata", 14, 16, "<I", 0x12345678),
        ("a size of 4 GB", first_chunk, 18, 20, "<I", 0xFFFFFFF0),
        ("an uncompressed size of 4 GB", first_chunk, 22, 24, "<I", 0xFFFFFFF0),
    ]:
        out.append(Mutant(f"sigrok: {what}", [("cap.sr", patch_member(stored, member, local_at, central_at, fmt,
                                                                          value))]))
    # no central directory: walked by local headers, with fields that cannot be
    cut = stored[:zipfile.ZipFile(io.BytesIO(stored)).start_dir]
    chunk_at = zipfile.ZipFile(io.BytesIO(stored)).getinfo(first_chunk).header_offset
    for what, at, fmt, value in [("no central directory", None, None, None),
                                 ("no central directory, a size of 4 GB", chunk_at + 18, "<I", 0xFFFFFFF0),
                                 ("no central directory, sizes after the data", chunk_at + 6, "<H", 0x08),
                                 ("no central directory, method 99", chunk_at + 8, "<H", 99),
                                 ("no central directory, a name of 65535 bytes", chunk_at + 26, "<H", 0xFFFF),
                                 ("no central directory, an extra field of 65535 bytes", 28, "<H", 0xFFFF)]:
        b = bytearray(cut)
        if at is not None:
            struct.pack_into(fmt, b, at, value)
        out.append(Mutant(f"sigrok: {what}", [("cap.sr", bytes(b))]))
    packed = gzip.compress(sr)
    out.append(Mutant("sigrok: gzip cut in half", [("cap.sr.gz", packed[:len(packed) // 2])]))
    return out + byte_mutants("sigrok", "cap.sr", sr, rng)


# ------------------------------------------------------------------ VCD

def vcd_mutants(sim: str, by_sigrok: str | None, rng: random.Random) -> list[Mutant]:
    lines = sim.splitlines()
    times = [i for i, ln in enumerate(lines) if ln.startswith("#")]
    mid = times[len(times) // 2]
    edits = [
        *[(f"$timescale {ts!r}", sim.replace("$timescale 1 ns $end", f"$timescale {ts} $end"))
          for ts in ("1000 ns", "1 ks", "0 ns", "-1 ns", "", "100 s", "10\n us")],
        ("no $timescale", sim.replace("$timescale 1 ns $end", "")),
        ("times going back", swap_lines(sim, times[10], times[12])),
        ("the last time before the first", sim + "#1\n1!\n"),
        ("every change of tx to an undeclared id", sim.replace("1!\n", "1?\n").replace("0!\n", "0?\n")),
        ("changes of undeclared ids", insert_line(sim, mid + 1, "1}\n0~\nx@@@@@@@@@@@@@@")),
        ("no 1-bit variable", re.sub(r"\$var (wire|reg) 1 .*\n", "", sim)),
        ("a time of 18 digits", insert_line(sim, mid, "#" + "9" * 18)),
        ("a time of 18 digits at the end", sim + "#" + "9" * 18 + "\n"),
        ("a time of 25 digits", insert_line(sim, mid, "#" + "9" * 25)),
        ("a time of -5", insert_line(sim, mid, "#-5")),
        ("a bare #", insert_line(sim, mid, "#")),
        ("a time of 1e9", insert_line(sim, mid, "#1e9")),
        ("a value for a time of 18 digits, at 1 fs", (sim + "#" + "9" * 18 + "\n0!\n").replace("1 ns", "1 fs")),
        ("identifiers of 11 characters", sim.replace(" ! tx", " abcdefghijk tx").replace("!\n", "abcdefghijk\n")),
        ("5000 variables", sim.replace("$upscope $end\n$enddefinitions",
                                       "".join(f"$var wire 1 v{i} n{i} $end\n" for i in range(5000))
                                       + "$upscope $end\n$enddefinitions", 1)),
        ("a $scope never closed", sim.replace("$upscope $end\n", "", 2)),
        ("an $upscope too many", sim.replace("$enddefinitions", "$upscope $end\n$upscope $end\n$enddefinitions")),
        ("a $scope without a name", sim.replace("$scope module uart $end", "$scope $end")),
        ("a $var without its parts", sim.replace("$var reg 1 rx_ rx $end", "$var reg 1 $end")),
        ("a variable named with control characters", sim.replace(" ! tx $end", " ! t\x1b[2J\x07x\x0c $end"),
         NO_SUCH_CHANNEL),
        ("no $enddefinitions", sim.replace("$enddefinitions $end", "")),
        ("$enddefinitions without $end", sim.replace("$enddefinitions $end", "$enddefinitions")),
        ("a $comment never closed in the body", insert_line(sim, mid, "$comment this goes on")),
        ("a vector change without its identifier at the end", sim + "b1010"),
        ("a lone value", insert_line(sim, mid, "1")),
        ("a value 9", insert_line(sim, mid, "9!")),
        ("CRLF line ends", sim.replace("\n", "\r\n")),
        ("NUL bytes in a line", replace_line(sim, mid + 1, lines[mid + 1] + "\0\0\0")),
        ("everything on one line", " ".join(sim.split())),
        ("no whitespace after the header", sim.split("$enddefinitions $end")[0] + "$enddefinitions $end"
         + "".join(sim.split("$enddefinitions $end")[1].split())),
        ("a 100 kB token at the end", sim + "x" * 100_000),
        ("only the header", sim.split("#0")[0]),
        ("$dumpoff with no $end", insert_line(sim, mid, "$dumpoff")),
    ]
    out = text_mutants("vcd", "sim.vcd", sim, edits)
    packed = gzip.compress(sim.encode())
    out += [Mutant("vcd: gzip cut in half", [("sim.vcd.gz", packed[:len(packed) // 2])]),
            Mutant("vcd: xz with junk after it", [("sim.vcd.xz", lzma.compress(sim.encode()) + b"junk")])]
    out += byte_mutants("vcd", "sim.vcd", sim.encode(), rng)
    if by_sigrok is not None:
        rate = re.search(r"channels at ([0-9.]+ ?[kMG]?Hz)", by_sigrok)
        out += text_mutants("vcd (sigrok-cli)", "cap.vcd", by_sigrok, [
            *[(f"sampled at {r!r}", by_sigrok.replace(rate.group(1), r))
              for r in ("0 Hz", "1 Hz", "99999999999999 GHz", "1.5.5 MHz")],
            ("sampled at 1 THz with a time of 18 digits", by_sigrok.replace(rate.group(1), "999999 GHz")
             + "#" + "9" * 18 + "\n"),
        ])
        out += byte_mutants("vcd (sigrok-cli)", "cap.vcd", by_sigrok.encode(), rng)
    return out


# ------------------------------------------------------------------ Saleae digital CSV and table

def csv_mutants(text: str, rng: random.Random) -> list[Mutant]:
    lines = text.splitlines()
    k = len(lines) // 2
    row = lines[k].split(",")
    edits = [
        *[(f"a time of {t!r}", replace_line(text, k, ",".join([t, *row[1:]])))
          for t in ("abc", "nan", "inf", "1e400", "-1e8", "", "1,5")],
        ("the rows reversed", "\n".join(lines[:1] + lines[1:][::-1]) + "\n"),
        ("two rows swapped", swap_lines(text, k, k + 1)),
        ("every time the same",
         "\n".join(lines[:1] + ["0.5," + ",".join(ln.split(",")[1:]) for ln in lines[1:]]) + "\n"),
        ("a row with a column more", replace_line(text, k, lines[k] + ",1")),
        ("the header with a column more", text.replace("RX\n", "RX,Extra\n", 1)),
        ("a row with a column less", replace_line(text, k, ",".join(row[:-1]))),
        ("a row of X", replace_line(text, k, ",".join([row[0], "X", "X"]))),
        ("every level X", "\n".join(lines[:1] + [ln.split(",")[0] + ",X,X" for ln in lines[1:]]) + "\n"),
        ("a level of 2", replace_line(text, k, ",".join([row[0], "2", row[2]]))),
        ("a level of -1", replace_line(text, k, ",".join([row[0], "-1", row[2]]))),
        ("no channel column", "Time [s]\n" + "\n".join(ln.split(",")[0] for ln in lines[1:]) + "\n"),
        ("the header alone", lines[0] + "\n"),
        ("the header without a line end", lines[0]),
        ("blank lines among the rows", insert_line(insert_line(text, k, ""), k, "   ")),
        ("a BOM and CRLF", "\ufeff" + text.replace("\n", "\r\n")),
        ("quoted cells", "\n".join(lines[:1] + ['"' + ln.replace(",", '","') + '"' for ln in lines[1:]]) + "\n"),
        ("a row of 1 MB", replace_line(text, k, row[0] + "," + "1" * (1 << 20))),
        ("1000 channels", "Time [s]," + ",".join(f"Channel {i}" for i in range(1000)) + "\n"
         + "".join(f"{i / 1000:.6f}," + ",".join(str((i + c) % 2) for c in range(1000)) + "\n" for i in range(30))),
        ("two channels of one name", text.replace("Channel 0,RX", "Channel 0,Channel 0", 1)),
        ("channels named by numbers of 25 digits", text.replace("Channel 0,RX", f"Channel {'9' * 25},Channel -1", 1)),
        ("a header of control characters", text.replace("RX", "R\x1b[2J\x0bX\x0c", 1), NO_SUCH_CHANNEL),
    ]
    return text_mutants("saleae csv", "digital.csv", text, edits) + \
        byte_mutants("saleae csv", "digital.csv", text.encode(), rng)


def table_mutants(text: str, rng: random.Random) -> list[Mutant]:
    lines = text.splitlines()
    k = len(lines) // 2
    header = lines[0].split(",")
    col = {name: i for i, name in enumerate(header)}

    def cell(name: str, value: str, at: int = k) -> str:
        cells = lines[at].split(",")
        cells[col[name]] = value
        return replace_line(text, at, ",".join(cells))

    def every(name: str, value) -> str:
        out = [lines[0]]
        for i, ln in enumerate(lines[1:]):
            cells = ln.split(",")
            cells[col[name]] = value(i, cells[col[name]])
            out.append(",".join(cells))
        return "\n".join(out) + "\n"

    edits = [
        *[(f"data {v!r}", cell("data", v)) for v in ("0x1FF", "", "0xZZ", "\\x", '"""')],
        *[(f"start_time {v!r}", cell("start_time", v)) for v in ("nan", "inf", "1e400", "abc")],
        ("every start_time nan", every("start_time", lambda i, v: "nan")),
        ("start times going back", every("start_time", lambda i, v: f"{1 - i / 100:.6f}")),
        *[(f"every duration {v!r}", every("duration", lambda i, v, d=v: d))
          for v in ("nan", "inf", "-1", "0", "1e300")],
        *[(f"type {v!r}", cell("type", v)) for v in ('"DATA"', '"error"', "")],
        ("every name empty", every("name", lambda i, v: "")),
        ("a header without data", text.replace(",data,", ",datum,", 1)),
        ("a header of the same column twice", text.replace("error,address", "data,data", 1)),
        ("an unterminated quote", cell("name", '"Async Serial [RX]')),
        ("a field of 200 kB", cell("name", '"' + "x" * 200_000 + '"')),
        ("a field of 200 kB in the first row", cell("name", '"' + "x" * 200_000 + '"', at=1)),
        ("a NUL byte", cell("name", '"Async\0Serial"')),
        ("the header alone", lines[0] + "\n"),
        ("five analyzers", every("name", lambda i, v: f'"Async Serial [{i % 5}]"')),
        ("every error every fault", every("error", lambda i, v: '"framing parity break overrun"')),
        ("an error of control characters", cell("error", '"\x1b[31mno\x07"')),
        ("analyzers named with control characters", every("name", lambda i, v: v.replace("[", "\x1b[2J\x0b")),
         ("--channels", "A=zzz")),
        ("CRLF line ends", text.replace("\n", "\r\n")),
        ("a row with a column more", replace_line(text, k, lines[k] + ",extra")),
        ("every row short", "\n".join(lines[:1] + [",".join(ln.split(",")[:3]) for ln in lines[1:]]) + "\n"),
    ]
    return text_mutants("saleae table", "table.csv", text, edits) + \
        byte_mutants("saleae table", "table.csv", text.encode(), rng,
                     arg_sets=((), ("--baud", "9600"), ("--channels", "A=Async Serial [RX]")))


# ------------------------------------------------------------------ Saleae binary

def saleae_file(version: int, levels: np.ndarray, rate: float, *, kind: int = 0, chunks: int | None = None,
                state: int | None = None, sample_rate: float | None = None, begin: float = 0.0,
                end: float = 0.06, count: int | None = None, times: np.ndarray | None = None,
                version_field: int | None = None) -> bytes:
    """One channel's export with any of its fields as given (Saleae's Binary
    Export Format, versions 0 and 1)."""
    t = edges(levels) / rate if times is None else times
    state = int(levels[0]) if state is None else state
    n = t.size if count is None else count
    head = b"<SALEAE>" + struct.pack("<ii", version if version_field is None else version_field, kind)
    if version == 0:
        head += struct.pack("<Iddq", state, begin, end, n)
    else:
        head += struct.pack("<q", 1 if chunks is None else chunks)
        head += struct.pack("<Idddq", state, rate if sample_rate is None else sample_rate, begin, end, n)
    return head + np.asarray(t, dtype="<f8").tobytes()


def binary_mutants(seeds: dict, rng: random.Random) -> list[Mutant]:
    a, _b = conversation()
    whole = {v: seeds[f"saleae binary v{v}"] for v in (0, 1)}
    # the fields this test writes are the helper's, where it writes them
    assert all(saleae_file(v, a, RATE) == whole[v][0] for v in (0, 1))
    ta = edges(a) / RATE

    def two(label: str, first: bytes, v: int = 1) -> Mutant:
        return Mutant(f"saleae binary v{v}: {label}", [("digital_0.bin", first), ("digital_1.bin", whole[v][1])])

    def times_with(k: int, value: float) -> np.ndarray:
        t = ta.copy()
        t[k] = value
        return t

    out = [two(what, saleae_file(1, a, RATE, **kw)) for what, kw in [
        ("version 2", {"version_field": 2}), ("version -1", {"version_field": -1}),
        ("analog", {"kind": 1}), ("type 7", {"kind": 7})]]
    for v in (0, 1):
        out += [two(what, saleae_file(v, a, RATE, **kw), v) for what, kw in [
            ("0 transitions", {"count": 0}), ("-1 transitions", {"count": -1}),
            ("2**62 transitions", {"count": 2 ** 62}), ("one transition more than written", {"count": ta.size + 1}),
            ("a NaN time", {"times": times_with(5, float("nan"))}),
            ("an infinite time", {"times": times_with(5, float("inf"))}),
            ("a time of 1e300", {"times": times_with(5, 1e300)}),
            ("a time going back", {"times": times_with(5, ta[2])}),
            ("every time the same", {"times": np.full(ta.size, 0.01)}),
            ("a begin time of NaN", {"begin": float("nan")}), ("an end time of NaN", {"end": float("nan")}),
            ("the end before the begin", {"begin": 0.05, "end": -0.05}), ("an end of 1e300", {"end": 1e300}),
            ("a begin of -1e300", {"begin": -1e300}), ("an initial state of 2**32-1", {"state": 0xFFFFFFFF}),
        ]]
    out += [two(what, saleae_file(1, a, RATE, **kw)) for what, kw in [
        ("0 chunks", {"chunks": 0}), ("-1 chunks", {"chunks": -1}), ("2**62 chunks", {"chunks": 2 ** 62}),
        ("2 chunks, one written", {"chunks": 2}),
        *[(f"a sample rate of {r!r}", {"sample_rate": r})
          for r in (0.0, -1.0, float("nan"), float("inf"), 1e300, 1e-300, 1.0, 1e12)],
    ]]
    second = saleae_file(1, a, RATE, begin=0.07, end=0.09, times=ta + 0.07)
    out.append(two("a second chunk", saleae_file(1, a, RATE, chunks=2) + second[16 + 8:]))
    out.append(two("a second chunk before the first ends", saleae_file(1, a, RATE, chunks=2) + second[16 + 8:]
                   .replace(struct.pack("<d", 0.07), struct.pack("<d", 0.001), 1)))
    out += [
        Mutant("saleae binary: the header alone", [("digital_0.bin", whole[1][0][:16])]),
        Mutant("saleae binary: the magic alone", [("digital_0.bin", b"<SALEAE>")]),
        Mutant("saleae binary: three files", [("digital_0.bin", whole[1][0]), ("digital_1.bin", whole[1][1]),
                                              ("digital_2.bin", whole[1][1])]),
        Mutant("saleae binary: versions 0 and 1 together", [("digital_0.bin", whole[0][0]),
                                                           ("digital_1.bin", whole[1][1])]),
        Mutant("saleae binary: with a file that is none", [("digital_0.bin", whole[1][0]),
                                                          ("digital_1.bin", b"not a Saleae export\n")]),
        Mutant("saleae binary: one channel, the same file twice", [("digital_0.bin", whole[1][0]),
                                                                  ("digital_0b.bin", whole[1][0])]),
    ]
    for v in (0, 1):
        out += byte_mutants(f"saleae binary v{v}", "digital_0.bin", whole[v][0], rng,
                            others=[("digital_1.bin", whole[v][1])])
    return out


# ------------------------------------------------------------------ USB captures

def pcap_records(data: bytes, endian: str = "<") -> list[int]:
    """The offsets of a pcap file's records."""
    at, out = 24, []
    while at + 16 <= len(data):
        out.append(at)
        at += 16 + struct.unpack_from(endian + "I", data, at + 8)[0]
    return out


def pcapng_blocks(data: bytes) -> list[tuple[int, int]]:
    """(offset, type) of a little-endian pcapng file's blocks."""
    at, out = 0, []
    while at + 12 <= len(data):
        kind, total = struct.unpack_from("<II", data, at)
        out.append((at, kind))
        at += total
    return out


def setp(data: bytes, at: int, fmt: str, value) -> bytes:
    b = bytearray(data)
    struct.pack_into(fmt, b, at, value)
    return bytes(b)


def usb_mutants(forms: dict[str, bytes], rng: random.Random) -> list[Mutant]:
    mon = forms["usbmon mmapped pcap"]
    be = forms["usbmon pcap, big endian, ns"]
    png = forms["usbmon pcapng"]
    upc = forms["USBPcap"]
    recs = pcap_records(mon)
    k = len(recs) // 2
    out = []

    def each(data: bytes, offset: int, fmt: str, value, every: int = 1, records=recs) -> bytes:
        for r in records[::every]:
            data = setp(data, r + 16 + offset, fmt, value)
        return data

    pcap_edits = [
        *[(f"link type {lt}", setp(mon, 20, "<I", lt)) for lt in (1, 0xFFFF, 189, 249)],
        ("the byte order of the other kind", b"\xa1\xb2\xc3\xd4" + mon[4:]),
        ("a snap length of 0", setp(mon, 16, "<I", 0)),
        ("a record of 4 GB", setp(mon, recs[k] + 8, "<I", 0xFFFFFFFF)),
        ("a record of 64 MB in a small file", setp(mon, recs[k] + 8, "<I", 1 << 26)),
        ("a record one byte longer", setp(mon, recs[k] + 8, "<I", struct.unpack_from("<I", mon, recs[k] + 8)[0] + 1)),
        ("every record empty", b"".join([mon[:24]] + [setp(mon[r:r + 16], 8, "<I", 0) for r in recs])),
        ("a microsecond field of 2**32-1", setp(mon, recs[k] + 4, "<I", 0xFFFFFFFF)),
        ("every time 0", b"".join([mon[:24]] + [setp(mon[r:r2], 0, "<Q", 0)
                                                for r, r2 in zip(recs, recs[1:] + [len(mon)])])),
        ("the records in reverse", mon[:24] + b"".join(mon[r:r2] for r, r2 in
                                                      reversed(list(zip(recs, recs[1:] + [len(mon)]))))),
        ("every transfer isochronous with 2**32-1 descriptors",
         each(each(mon, 9, "<B", 0), 60, "<I", 0xFFFFFFFF)),
        ("every event a submission error", each(mon, 8, "<B", ord("E"))),
        ("every status -32", each(mon, 28, "<i", -32)),
        ("every endpoint 0x8f", each(mon, 10, "<B", 0x8F)),
        ("every device 0 on bus 65535", each(each(mon, 11, "<B", 0), 12, "<H", 0xFFFF)),
        ("every URB id the same", each(mon, 0, "<Q", 7)),
        ("every URB length 2**32-1", each(mon, 32, "<I", 0xFFFFFFFF)),
        ("every transfer type 9", each(mon, 9, "<B", 9, every=3)),
        ("setup packets of 0xff", each(mon, 40, "<Q", 2 ** 64 - 1)),
    ]
    # the enumeration's answers: a configuration whose descriptors say lengths of 0 and packets of 0
    conf = mon.find(bytes([9, 2]))
    if conf > 0:
        pcap_edits.append(("a configuration descriptor of length 0", setp(mon, conf, "<B", 0)))
        ep = mon.find(bytes([7, 5, 0x81]), conf)
        if ep > 0:
            pcap_edits.append(("an endpoint of packet size 0", setp(mon, ep + 4, "<H", 0)))
            pcap_edits.append(("an endpoint of packet size 2047", setp(mon, ep + 4, "<H", 0x7FF)))
    dev = mon.find(bytes([18, 1, 0, 2]))
    if dev > 0:
        pcap_edits.append(("a device descriptor of another vendor", setp(mon, dev + 8, "<H", 0x1234)))
    out += [Mutant(f"usbmon pcap: {what}", [("ctl-pc.pcap", d)]) for what, d in pcap_edits]

    brecs = pcap_records(be, ">")
    out += [Mutant(f"usbmon pcap, big endian: {what}", [("ctl-pc.pcap", d)]) for what, d in [
        ("a record of 4 GB", setp(be, brecs[len(brecs) // 2] + 8, ">I", 0xFFFFFFFF)),
        ("the header of the other byte order", b"\xd4\xc3\xb2\xa1" + be[4:]),
    ]]

    blocks = pcapng_blocks(png)
    idb = next(at for at, kind in blocks if kind == 1)
    epbs = [at for at, kind in blocks if kind == 6]
    e = epbs[len(epbs) // 2]
    tsresol = png.find(b"\x09\x00\x01\x00", idb)
    png_edits = [
        ("a block of length 0xfffffff0", setp(png, e + 4, "<I", 0xFFFFFFF0)),
        ("a block of length 13", setp(png, e + 4, "<I", 13)),
        ("a block of length 8", setp(png, e + 4, "<I", 8)),
        ("a block of length 0", setp(png, e + 4, "<I", 0)),
        ("a block longer than the file", setp(png, e + 4, "<I", len(png) * 4)),
        ("a section header of no byte order", setp(png, 8, "<I", 0xDEADBEEF)),
        ("a section header of the other byte order", setp(png, 8, ">I", 0x1A2B3C4D)),
        *[(f"if_tsresol {v:#x}", setp(png, tsresol + 4, "<B", v)) for v in (0x7F, 0xFF, 0x80, 200, 0)],
        ("a packet of interface 99", setp(png, e + 8, "<I", 99)),
        ("a packet of 4 GB captured", setp(png, e + 20, "<I", 0xFFFFFFFF)),
        ("a time of 2**64-1", setp(setp(png, e + 12, "<I", 0xFFFFFFFF), e + 16, "<I", 0xFFFFFFFF)),
        ("an option of 65535 bytes", setp(png, tsresol + 2, "<H", 0xFFFF)),
        ("the interface of link type 1", setp(png, idb + 8, "<H", 1)),
        ("a second section", png + png),
        ("a second section of big-endian bytes", png + b"\x0a\x0d\x0d\x0a" + png[4:8] + b"\x1a\x2b\x3c\x4d"
         + png[12:blocks[1][0]]),
        ("no interface", png[:idb] + png[blocks[2][0]:]),
    ]
    out += [Mutant(f"usbmon pcapng: {what}", [("ctl-pc.pcapng", d)]) for what, d in png_edits]

    urecs = pcap_records(upc)
    out += [Mutant(f"USBPcap: {what}", [("ctl-pc.pcap", d)]) for what, d in [
        ("header lengths of 0", each(upc, 0, "<H", 0, records=urecs)),
        ("header lengths of 65535", each(upc, 0, "<H", 0xFFFF, records=urecs)),
        ("transfer type 9", each(upc, 22, "<B", 9, records=urecs)),
        ("every info byte 0xff", each(upc, 16, "<B", 0xFF, records=urecs)),
        ("data lengths of 2**32-1", each(upc, 23, "<I", 0xFFFFFFFF, records=urecs)),
    ]]
    for form, name in (("usbmon mmapped pcap", "ctl-pc.pcap"), ("usbmon pcapng", "ctl-pc.pcapng"),
                       ("USBPcap", "ctl-pc.pcap")):
        out += byte_mutants(form, name, forms[form], rng,
                            arg_sets=((), ("--baud", "9600"), ("--adapter", "cp210x"), ("--usb-device", "3.7")))
    return out


# ------------------------------------------------------------------ the seeds

@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> dict:
    """The valid captures the corpus is made from: the same conversation (a
    position query, its ACK and its result) in every format."""
    d = tmp_path_factory.mktemp("seeds")
    out: dict = {}
    if HAS_SIGROK:
        # sigrok-cli stamps the zip's members and the VCD with the time it ran: fixed
        # here, so the corpus is the same bytes every run
        sr = Path(session(d, *conversation())).read_bytes()
        for name in zipfile.ZipFile(io.BytesIO(sr)).namelist():
            sr = patch_member(sr, name, 10, 12, "<I", DOS_DATE_TIME)
        out["sigrok"] = sr
        out["vcd (sigrok-cli)"] = re.sub(r"\$date .*? \$end", "$date Mon Jan  5 10:00:00 2026 $end",
                                         Path(sigrok_vcd(d)).read_text())
    out["vcd"] = Path(write_vcd(d / "sim.vcd", "1 ns", 1e-9)).read_text()
    out["saleae csv"] = Path(write_digital_csv(d / "digital.csv")).read_text()
    out["saleae table"] = Path(write_table(d / "table.csv")).read_text()
    for v in (0, 1):
        folder = d / f"v{v}"
        folder.mkdir()
        out[f"saleae binary v{v}"] = tuple(Path(p).read_bytes() for p in write_binary(folder, v))
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    ftdi_conversation(c, answer_status=b"\x01\x68")     # a framing error reported on the answer
    for form, write in WRITERS.items():
        write(c, d / "usb")
        out[form] = (d / "usb").read_bytes()
    return out


def family(name: str, seeds: dict) -> list[Mutant]:
    rng = random.Random(f"instrument corpus {name}")     # a fixed seed: the same corpus every run
    empty = {"sigrok": "cap.sr", "vcd": "sim.vcd", "saleae csv": "digital.csv", "saleae table": "table.csv",
             "saleae binary": "digital_0.bin", "usb": "ctl-pc.pcapng"}[name]
    out = [Mutant(f"{name}: an empty file", [(empty, b"")])]
    if name == "sigrok":
        if "sigrok" not in seeds:
            pytest.skip("sigrok-cli is not installed (it writes the session the corpus starts from)")
        out += sigrok_mutants(seeds["sigrok"], rng)
    elif name == "vcd":
        out += vcd_mutants(seeds["vcd"], seeds.get("vcd (sigrok-cli)"), rng)
    elif name == "saleae csv":
        out += csv_mutants(seeds["saleae csv"], rng)
    elif name == "saleae table":
        out += table_mutants(seeds["saleae table"], rng)
    elif name == "saleae binary":
        out += binary_mutants(seeds, rng)
    else:
        out.append(Mutant("usb: an empty .pcap", [("ctl-pc.pcap", b"")]))
        out += usb_mutants({form: seeds[form] for form in WRITERS}, rng)
    return out


# ------------------------------------------------------------------ running them

def run_corpus(mutants: list[Mutant], tmp_path) -> list[str]:
    """Every mutant through ``decode`` and ``doctor``; what went wrong, one line a run."""
    jobs, where = [], {}
    for n, m in enumerate(mutants):
        folder = tmp_path / f"{n:03d}"
        folder.mkdir()
        paths = []
        for filename, data in m.files:
            (folder / filename).write_bytes(data)
            paths.append(str(folder / filename))
        for command in ("decode", "doctor"):
            job_id = f"{n:03d} {command}"
            jobs.append({"id": job_id, "argv": [command, *paths, *m.args], "timeout": RUN_TIMEOUT,
                         "stdout": str(folder / f"{command}.out"), "stderr": str(folder / f"{command}.err")})
            where[job_id] = (m, command, folder / f"{command}.err")
    results = run_many(jobs, tmp_path)
    failures = []
    for job_id, (m, command, err_path) in where.items():
        r = results[job_id]
        err = err_path.read_text(errors="replace")
        why = judge(command, r, err)
        if why:
            last = err.strip().splitlines()[-1:] or [""]
            failures.append(f"{m.name!r} {command}: {why}: {last[0][:300]}")
    return failures


def judge(command: str, result: dict, err: str) -> str | None:
    """What is wrong with one run, or None."""
    if result["timed_out"]:
        return f"hangs (killed after {RUN_TIMEOUT} s)"
    if "Traceback" in err:
        return "a traceback"
    allowed = DOCTOR_CODES if command == "doctor" else DECODE_CODES
    if result["code"] not in allowed:
        return f"exit {result['code']}"
    lines = err.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    stray = [ln for ln in lines if not (ONE_LINE.match(ln) and ln.isprintable())]
    if stray:
        return f"stderr line that is no gimbalscope line: {stray[0][:200]!r}"
    errors = [ln for ln in lines if ln.startswith("gimbalscope: error: ")]
    if result["code"] == 2 and len(errors) != 1:
        return f"exit 2 with {len(errors)} error lines"
    if result["max_rss_mb"] > MEMORY_LIMIT_MB:
        return f"{result['max_rss_mb']:.0f} MB of memory"
    return None


FAMILIES = ["sigrok", "vcd", "saleae csv", "saleae table", "saleae binary", "usb"]


def test_every_seed_is_a_capture_of_the_conversation(seeds, tmp_path):
    """The corpus starts from captures that decode: the command, its ACK and its
    result, with no warning but the simulator VCD's note on its bus and real
    (so every damage the corpus finds is a mutant's)."""
    ext = {"sigrok": ".sr", "vcd (sigrok-cli)": ".vcd", "vcd": ".vcd", "saleae csv": ".csv",
           "saleae table": ".csv"}
    jobs = []
    for n, (name, data) in enumerate(seeds.items()):
        parts = data if isinstance(data, tuple) else (data,)      # a Saleae binary export: a file a channel
        paths = []
        for k, part in enumerate(parts):
            paths.append(tmp_path / f"seed{n}_{k}{ext.get(name, '.bin' if 'binary' in name else '.pcap')}")
            paths[-1].write_bytes(part.encode() if isinstance(part, str) else part)
        jobs.append({"id": name, "argv": ["decode", *map(str, paths), "--format", "jsonl"], "timeout": RUN_TIMEOUT,
                     "stdout": str(tmp_path / f"{n}.out"), "stderr": str(tmp_path / f"{n}.err")})
    results = run_many(jobs, tmp_path)
    for n, (name, r) in enumerate(zip(seeds, (results[j["id"]] for j in jobs))):
        err = (tmp_path / f"{n}.err").read_text()
        assert r["code"] == 0, (name, err)
        assert all("2 variables wider than 1 bit left out" in w for w in err.splitlines()), (name, err)
        rows = [json.loads(x) for x in (tmp_path / f"{n}.out").read_text().splitlines()]
        assert [(e["kind"], e["command"]) for e in rows[:3]] == [("command", "P?"), ("ack", None),
                                                                  ("result", "P?")], name


@pytest.mark.parametrize("name", FAMILIES)
def test_damaged_captures_end_in_one_line_never_a_traceback_or_a_hang(seeds, tmp_path, name):
    mutants = family(name, seeds)
    assert len({m.name for m in mutants}) == len(mutants)   # each names its damage once
    failures = run_corpus(mutants, tmp_path)
    assert not failures, f"{len(failures)} of {2 * len(mutants)} runs:\n" + "\n".join(failures)


def test_the_forked_runs_are_the_console_command_s_runs(seeds, tmp_path):
    """The corpus runs forked from one process (tests/forked_cli.py): a run there
    ends as the console command's own run ends, status, stdout and stderr."""
    csv = seeds["saleae csv"]
    cases = {"damaged.csv": replace_line(csv, len(csv.splitlines()) * 2 // 3, "abc,1,1").encode(),   # a warning
             "whole.csv": csv.encode(),                                       # no warning
             "header.csv": b"Time [s]\n"}                                      # refused in one line
    jobs = []
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
        for command in ("decode", "doctor"):
            jobs.append({"id": f"{name} {command}", "argv": [command, str(tmp_path / name)], "timeout": RUN_TIMEOUT,
                         "stdout": str(tmp_path / f"{name}.{command}.out"),
                         "stderr": str(tmp_path / f"{name}.{command}.err")})
    results = run_many(jobs, tmp_path)
    codes = set()
    for job in jobs:
        real = run_cli(*job["argv"])
        forked = results[job["id"]]
        assert forked["code"] == real.returncode, job["id"]
        assert Path(job["stdout"]).read_text() == real.stdout, job["id"]
        assert Path(job["stderr"]).read_text() == real.stderr, job["id"]
        codes.add(real.returncode)
    assert {0, 2} <= codes


def test_a_vcd_body_without_times_is_read_in_bounded_memory(tmp_path):
    """Changes at one time are not split between blocks, so a body with no #time
    was held whole and tokenised at once: 70 MB of changes took 3.4 GB and 24 s.
    Past 64 MB without a #time the reading stops there, and says so."""
    path = tmp_path / "untimed.vcd"
    with open(path, "w") as f:
        f.write("$timescale 1 ns $end\n$scope module top $end\n$var wire 1 ! tx $end\n$upscope $end\n"
                "$enddefinitions $end\n#0\n1!\n#1000\n0!\n#2000\n1!\n")
        f.write("1! 0! " * (12 << 20))
    jobs = [{"id": "decode", "argv": ["decode", str(path)], "timeout": 120, "stdout": str(tmp_path / "out"),
             "stderr": str(tmp_path / "err")}]
    result = run_many(jobs, tmp_path)["decode"]
    err = (tmp_path / "err").read_text()
    assert judge("decode", result, err) is None, err
    assert f"{path}: line 10: 64 MB without a #time from there: read up to there" in err


# ------------------------------------------------------------------ noise
# The software UART takes an edge from idle as a start bit and samples it at its
# middle; a pulse back at idle by then is a false start, and the UART looks for
# the next start from the edge after it. Pulses of a third of a bit are no
# glitch (those are under a quarter, removed before): every one is a false start.

BAUD = 9600
QUERY = frame((1, 1, 1), 0, b"P?")
ACK = b"\x06"
ANSWER = frame((0, 1, 1), 1, b"0FA0FC18")
LIVE_LINE = re.compile(r"^gimbalscope( live)?: ")   # live says where it listens, then as every command


def exchanges(rate: float, starts: list[float], duration: float) -> tuple[np.ndarray, np.ndarray]:
    """Lines A and B: at each start a position query, its ACK 10 ms later and
    its result 4 ms after that (done 30 ms after the start: the next query comes
    after it, so no time depends on how two lines sending at once are placed)."""
    a_chars, b_chars = [], []
    for t in starts:
        a_chars += back_to_back(QUERY, t, BAUD)
        b_chars += back_to_back(ACK, t + 0.010, BAUD) + back_to_back(ANSWER, t + 0.014, BAUD)
    return uart_levels(a_chars, rate, BAUD, duration), uart_levels(b_chars, rate, BAUD, duration)


def false_starts(line: np.ndarray, start: int, count: int, low: int, period: int) -> None:
    """``count`` pulses of ``low`` samples at the active level, one every ``period``
    samples from sample ``start``: each is a start bit's edge, and each is back at
    idle before the start bit's middle, so a UART sees a start that fails."""
    span = line[start:start + count * period].reshape(count, period)
    span[:, :low] = 0


def a_million_false_starts() -> tuple[np.ndarray, np.ndarray, list[float]]:
    """96 kHz, 10 samples a bit: three exchanges, then on line A pulses of 3
    samples every 6, a million in a row (6 MB of samples), then an exchange."""
    rate = 96_000
    noise_from, count, period = 11_520, 1_000_000, 6     # from 120 ms, after the three exchanges
    after = (noise_from + count * period) / rate + 0.010
    starts = [0.004, 0.044, 0.084, after]
    a, b = exchanges(rate, starts, after + 0.030)
    false_starts(a, noise_from, count, 3, period)
    return a, b, starts


def decoded(run: subprocess.CompletedProcess) -> list[dict]:
    assert "Traceback" not in run.stderr, run.stderr[-3000:]
    assert run.returncode == 0, run.stderr
    return [json.loads(x) for x in run.stdout.splitlines()]


def check_exchanges(rows: list[dict], starts: list[float]) -> None:
    """Every query, before the noise and after it, read at its time and answered,
    and nothing else: false starts carry no byte."""
    assert [r["kind"] for r in rows] == ["command", "ack", "result"] * len(starts)
    commands = [r for r in rows if r["kind"] == "command"]
    assert [(c["command"], c["status"]) for c in commands] == [("P?", "ok")] * len(starts)
    assert [c["t"] for c in commands] == pytest.approx(starts, abs=1e-6)
    assert [r["request"] for r in rows if r["kind"] == "result"] == [c["number"] for c in commands]


def doctor_survives(path) -> None:
    run = run_cli("doctor", path, timeout=120)
    assert "Traceback" not in run.stderr and run.returncode in DOCTOR_CODES, run.stderr[-3000:]


def live_samples(path, rate: str) -> subprocess.CompletedProcess:
    """``live --samples`` of a file of samples, printing events: it ends at the file's end."""
    run = run_cli("live", "--samples", path, "--samplerate", rate, "--no-tui", "--format", "jsonl", timeout=120)
    assert "Traceback" not in run.stderr, run.stderr[-3000:]
    assert all(LIVE_LINE.match(line) for line in run.stderr.splitlines()), run.stderr
    return run


@needs_sigrok
def test_a_burst_of_false_starts_is_noise_between_exchanges(tmp_path):
    # 1 MHz, 104 samples a bit: pulses of 35 samples every 70, 1,500 in a row
    # between 125 and 230 ms
    rate = 1_000_000
    starts = [0.005, 0.045, 0.085, 0.250, 0.290]
    a, b = exchanges(rate, starts, 0.330)
    false_starts(a, 125_000, 1_500, 35, 70)
    path = session(tmp_path, a, b, samplerate=rate)
    check_exchanges(decoded(run_cli("decode", path, "--format", "jsonl", timeout=120)), starts)
    doctor_survives(path)


@needs_sigrok
def test_a_million_false_starts_in_a_session_end_in_time(tmp_path):
    a, b, starts = a_million_false_starts()
    path = session(tmp_path, a, b, samplerate=96_000)
    assert os.path.getsize(path) < 4 << 20            # sigrok deflates the pulses to a few KB
    check_exchanges(decoded(run_cli("decode", path, "--format", "jsonl", timeout=120)), starts)
    doctor_survives(path)


def test_a_million_false_starts_in_a_sample_stream_end_in_time(tmp_path):
    a, b, starts = a_million_false_starts()
    path = tmp_path / "samples.bin"
    path.write_bytes(pack(a, b))
    check_exchanges(decoded(live_samples(path, "96k")), starts)


def test_a_stream_of_random_samples_is_noise_not_a_failure(tmp_path):
    # every one of 8 channels toggling at random, sample by sample: no rate, no byte
    path = tmp_path / "noise.bin"
    path.write_bytes(np.random.default_rng(20).integers(0, 256, 400_000, dtype=np.uint8).tobytes())
    run = live_samples(path, "1MHz")
    # said (refused, or a warning with nothing decoded), never a byte made of noise
    assert run.returncode in (0, 2) and run.stdout == "", run.stderr
    assert "under 4 samples a bit" in run.stderr
