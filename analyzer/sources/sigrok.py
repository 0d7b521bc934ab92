"""sigrok sessions (``.sr``): what PulseView and ``sigrok-cli -o cap.sr`` save
(docs/instruments.md, "sigrok and PulseView").

A session is a zip: ``version`` ("1" or "2"), ``metadata`` (an ini text: a
``[device 1]`` section with ``samplerate``, ``unitsize``, ``total probes`` and
``probeN=name`` for the logic channels, N counting from 1 and skipping unused
probes), and the samples, ``unitsize`` bytes each with probe N at bit N-1: one
member ``logic-1`` (version 1) or chunks ``logic-1-1``, ``logic-1-2``, …
(version 2). Old files indent lines and put spaces around ``=``; both are read.

The chunks are read in order and streamed (a capture of minutes at MHz rates is
hundreds of megabytes of samples). A damaged zip is read as far as its members
go: a file cut short (no central directory) is walked by its local headers, and
what came before the damage is decoded, the damage said in one line. A file cut
before anything can be read of it (in its metadata, or before the samples show
a character) is an error that says it is cut short, and where.
"""

from __future__ import annotations

import contextlib
import os
import re
import struct
import zipfile
import zlib
from collections.abc import Iterator
from typing import BinaryIO

from ..errors import CaptureError
from ..physical.edges import Block, PackedSamples
from ..words import counted
from .base import ReadSettings, Source
from .files import BLOCK, Input
from .signatures import CENTRAL, LOCAL

_RATE = re.compile(r"^\s*([0-9]+(?:\.[0-9]+)?)\s*([kKmMgG]?)(?:Hz|hz|HZ)?\s*$")
_SCALE = {"": 1.0, "k": 1e3, "m": 1e6, "g": 1e9}


def parse_samplerate(text: str) -> float:
    """``"625 kHz"``, ``"1.5 MHz"``, ``"250 Hz"``, ``"1000000"`` → samples a second."""
    m = _RATE.match(text)
    if not m:
        raise ValueError(text)
    return float(m.group(1)) * _SCALE[m.group(2).lower()]


def parse_metadata(text: str) -> dict[str, dict[str, str]]:
    """Sections of the ini text, keys and values stripped (indented lines and
    ``key = value`` of old sessions too)."""
    sections: dict[str, dict[str, str]] = {}
    current: dict[str, str] = sections.setdefault("", {})
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith(("#", ";")):
            continue
        if line.startswith("[") and line.endswith("]"):
            current = sections.setdefault(line[1:-1].strip(), {})
            continue
        key, sep, value = line.partition("=")
        if sep:
            current[key.strip()] = value.strip()
    return sections


class SigrokSession(PackedSamples):
    """A session's logic channels as packed samples."""

    def __init__(self, inp: Input) -> None:
        self.input = inp
        self.members = _Members(inp)
        try:
            self._read_metadata(inp)
        except BaseException:
            self.members.close()
            raise

    def _read_metadata(self, inp: Input) -> None:
        """The session's metadata: its channels, rate and the sample files' names."""
        self.exhausted = False      # the samples were read to their end (or to the damage)
        self.edges_seen = 0
        meta_text = self.members.read("metadata")
        if meta_text is None:
            if self.members.cut:
                raise CaptureError(self.cut_short("before sigrok's metadata: nothing to read"))
            raise CaptureError(f"{inp.name}: a zip without sigrok's metadata: not a sigrok session")
        meta = parse_metadata(meta_text.decode("utf-8", "replace"))
        device = next((s for name, s in meta.items() if name.startswith("device") and "capturefile" in s), None)
        if device is None:
            raise CaptureError(f"{inp.name}: the sigrok metadata names no capture file ([device 1] capturefile=)")
        try:
            rate = parse_samplerate(device.get("samplerate", ""))
        except ValueError:
            raise CaptureError(f"{inp.name}: the sigrok metadata's sample rate {device.get('samplerate')!r} "
                               "is not a rate (e.g. 1 MHz)") from None
        if rate <= 0:
            raise CaptureError(f"{inp.name}: the sigrok metadata gives no sample rate")
        given = device.get("unitsize", "1") or "1"
        if given not in ("1", "2", "4"):
            raise CaptureError(f"{inp.name}: unitsize {given[:40]!r} (1, 2 or 4 bytes a sample are read)")
        unitsize = int(given)
        probes = sorted((int(k[5:]), v) for k, v in device.items() if re.fullmatch(r"probe\d+", k))
        if not probes:
            raise CaptureError(f"{inp.name}: the session has no logic channels")
        if probes[0][0] < 1:   # bit N-1 of a sample: probe0 would be bit -1
            raise CaptureError(f"{inp.name}: probe{probes[0][0]} in the metadata (sigrok numbers probes from 1)")
        too_high = [n for n, _ in probes if n > unitsize * 8]
        if too_high:
            raise CaptureError(f"{inp.name}: probe{too_high[0]} is beyond the {unitsize * 8} bits of a sample")
        capturefile = device["capturefile"]
        super().__init__(self._samples(capturefile), unitsize, [name for _, name in probes], rate,
                         bits=[n - 1 for n, _ in probes], name=inp.name)
        self.numbers = [str(n - 1) for n, _ in probes]   # sigrok-cli numbers channels from 0
        self.version = (self.members.read("version") or b"?").strip().decode("ascii", "replace")

    def cut_short(self, where: str) -> str:
        """The one line of a session cut short (``where``: where, and what that leaves)."""
        return f"{self.input.name}: cut short at byte {self.members.size:,}, {where}"

    def blocks(self) -> Iterator[Block]:
        # the edges are counted: a session cut before any shows nothing to decode
        for block in super().blocks():
            self.edges_seen += sum(int(e.ticks.size) for e in block.edges.values())
            yield block

    def _samples(self, capturefile: str) -> Iterator[bytes]:
        try:
            yield from self._members_of(capturefile)
        finally:
            self.exhausted = True

    def _members_of(self, capturefile: str) -> Iterator[bytes]:
        names = self.members.names
        parts = sorted((int(n[len(capturefile) + 1:]), n) for n in names
                       if n.startswith(capturefile + "-") and n[len(capturefile) + 1:].isdigit())
        order = [n for _, n in parts] or ([capturefile] if capturefile in names else [])
        if not order:
            self.problem = (self.cut_short("before the samples") if self.members.cut
                            else f"{self.name}: no samples ({capturefile} is not in the session)")
            return
        for name in order:
            try:
                yield from self.members.stream(name)
            except Unreadable as e:
                self.problem = f"{self.name}: {name} {e}: read up to there"
                return
            except Cut:
                self.problem = self.cut_short(f"in {name}: read up to there")
                return
            except DAMAGE as e:
                self.problem = f"{self.name}: {name} is damaged ({e}): read up to there"
                return
        if self.members.problem:
            self.problem = self.members.problem

    def close(self) -> None:
        self.members.close()
        self.input.close()


class _Members:
    """The zip's members by name: through its central directory, or, in a file cut
    short, by walking its local headers."""

    def __init__(self, inp: Input) -> None:
        self.inp = inp
        self.problem: str | None = None
        self.cut = False       # the file ends inside the zip: it was cut short
        path, self.temporary = inp.as_regular_file()   # a pipe's or a compressed file's copy: removed on close
        self.path = path
        self.zip: zipfile.ZipFile | None = None
        try:
            self.size = os.path.getsize(path)
            self.zip = zipfile.ZipFile(path)
            self.names = self.zip.namelist()
            self.local: dict[str, tuple[int, int, int, int]] = {}
        except zipfile.BadZipFile:
            self.zip = None
            self.local, self.cut = _walk_local_headers(path)
            self.names = list(self.local)
            self.problem = f"{inp.name}: the zip is cut short or damaged (no central directory): read up to there"
        except OSError as e:
            self.close()
            raise CaptureError(f"{inp.name}: cannot read: {e.strerror or e}") from None
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Close the zip, and remove the copy that stood in for a pipe or a compressed file."""
        if self.zip is not None:
            self.zip.close()
        if self.temporary:
            self.temporary = False
            with contextlib.suppress(OSError):
                os.unlink(self.path)

    def read(self, name: str) -> bytes | None:
        if name not in self.names:
            return None
        try:
            return b"".join(self.stream(name))
        except Unreadable as e:
            raise CaptureError(f"{self.inp.name}: {name} {e}") from None
        except Cut:
            raise CaptureError(f"{self.inp.name}: cut short at byte {self.size:,}, in {name}: nothing to "
                               "read") from None
        except DAMAGE as e:
            raise CaptureError(f"{self.inp.name}: {name} is damaged ({e})") from None

    def stream(self, name: str) -> Iterator[bytes]:
        """The member's bytes; Unreadable for one no sigrok writer makes (encrypted,
        or compressed by a method zipfile cannot undo), DAMAGE as it is read."""
        if self.zip is not None:
            info = self.zip.getinfo(name)
            _readable(info.flag_bits, info.compress_type, _ZIP_METHODS)
            with self.zip.open(name) as f:
                while True:
                    data = f.read(BLOCK * 4)
                    if not data:
                        return
                    yield data
        at, size, method, flags = self.local[name]
        _readable(flags, method, (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED))   # what _inflate undoes
        with open(self.path, "rb") as f:
            f.seek(at)
            yield from _inflate(f, size, method)


def _walk_local_headers(path: str) -> tuple[dict[str, tuple[int, int, int, int]], bool]:
    """name → (data offset, compressed size, method, flags) of every member whose
    local header is whole; and whether the walk ran into the file's end (a local
    header, or the central directory, cut short) rather than bytes that are no
    header (damage)."""
    found: dict[str, tuple[int, int, int, int]] = {}
    end = os.path.getsize(path)
    with open(path, "rb") as f:
        at = 0
        while True:
            f.seek(at)
            head = f.read(30)
            if len(head) < 30 or not head.startswith(LOCAL):
                # what is left is the start of a header, or the central directory
                # (whole, it would have been read as the zip's)
                return found, at >= end or (len(head) < 30 and _starts(head, LOCAL)) or _starts(head, CENTRAL)
            flags, method, size, name_len, extra_len = (struct.unpack_from("<H", head, 6)[0],
                                                        struct.unpack_from("<H", head, 8)[0],
                                                        struct.unpack_from("<I", head, 18)[0],
                                                        *struct.unpack_from("<HH", head, 26))
            raw_name = f.read(name_len)
            data_at = at + 30 + name_len + extra_len
            if len(raw_name) < name_len or data_at > end:   # the file ends in the header
                return found, True
            name = raw_name.decode("utf-8", "replace")
            if flags & 0x08:     # sizes after the data: read to the end of what is there
                found[name] = (data_at, -1, method, flags)
                return found, False
            found[name] = (data_at, size, method, flags)
            at = data_at + size


def _starts(head: bytes, signature: bytes) -> bool:
    """Does ``head`` start with ``signature``, or is it the start of one, cut?"""
    n = min(len(head), len(signature))
    return n > 0 and head[:n] == signature[:n]


class Cut(EOFError):
    """A member's data ends with the file before its size (or its deflate
    stream) does: the file was cut short."""


class Unreadable(Exception):
    """A member no sigrok writer makes, whose bytes cannot be had: the message
    says why, after the member's name."""


# What reading a member can raise on damaged bytes (zipfile raises BadZipFile for a
# bad CRC or header, zlib.error for bad deflate data, EOFError for a cut one).
DAMAGE = (zipfile.BadZipFile, zlib.error, EOFError, OSError, struct.error)
_ZIP_METHODS = (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED, zipfile.ZIP_BZIP2, zipfile.ZIP_LZMA)


def _readable(flags: int, method: int, methods: tuple[int, ...]) -> None:
    """Unreadable for an encrypted member (zipfile would ask for a password) or
    a compression method not in ``methods`` (zipfile would raise
    NotImplementedError; sigrok deflates)."""
    if flags & 0x01:
        raise Unreadable("is encrypted (sigrok never encrypts a session)")
    if method not in methods:
        raise Unreadable(f"is compressed by zip method {method}, which cannot be read (sigrok deflates)")


def _inflate(f: BinaryIO, size: int, method: int) -> Iterator[bytes]:
    left = size if size >= 0 else 1 << 62
    d = zlib.decompressobj(-15) if method == 8 else None
    while left > 0:
        data = f.read(min(BLOCK * 4, left))
        if not data:
            if size < 0 and d is None:   # stored, its size after the data: its end is the file's
                return
            raise Cut()
        left -= len(data)
        out = d.decompress(data) if d is not None else data
        if out:
            yield out
        if d is not None and d.eof:
            return


def open_sigrok(inputs: list[Input], settings: ReadSettings) -> Source:
    from .sampled import SampledSource
    session = SigrokSession(inputs[0])
    try:
        source = SampledSource(session, settings, inputs[0].describe(
            f"sigrok session (version {session.version}, {counted(len(session.channels), 'channel')})"))
    except CaptureError:
        # a session cut before its samples show an edge: the cut is why, not the probes
        if session.members.cut and session.exhausted and not session.edges_seen:
            session.close()
            raise CaptureError(session.cut_short("before the samples show any traffic")) from None
        raise
    if session.members.cut and session.exhausted and not any(r.nominal for r in source.physical.values()):
        # all that was left was looked at while opening, and no line shows a rate in it
        source.close()
        raise CaptureError(session.cut_short(f"after {counted(session.edges_seen, 'edge')}: too few to read"))
    return source
