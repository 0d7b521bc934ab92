"""A bare stream of logic samples: what ``sigrok-cli --continuous -O binary``
writes to a pipe, read live (``gimbalscope live --samples - --samplerate 1MHz``;
docs/instruments.md, "A live logic analyser").

The stream has no header: ``unitsize`` bytes a sample, channel N at bit N, at
the rate given. It is read as it comes (each read returns what the pipe holds,
so the view keeps up), and decoded like a sigrok session's samples.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterator

from ..errors import CaptureError
from ..physical.edges import PackedSamples
from ..words import counted
from .base import ReadSettings
from .files import STDIN, Input
from .sampled import SampledSource, hz

READ = 1 << 20   # at most a read; a pipe gives what it holds


def _reads(fd: int, name: str) -> Iterator[bytes]:
    while True:
        try:
            data = os.read(fd, READ)
        except OSError as e:
            raise CaptureError(f"{name}: cannot read: {e.strerror or e}") from None
        if not data:
            return
        yield data


def open_sample_file(inputs: list[Input], settings: ReadSettings) -> SampledSource:
    """A stream of samples saved to a file (``sigrok-cli -O binary > f.bin``), read
    as ``live --samples`` reads it, at the rate given (``--samplerate``): the
    registry's reader for an input given with a sample rate."""
    inp = inputs[0]
    inst = settings.instrument
    rate, unitsize = float(inst.samplerate or 0), inst.unitsize
    waveform = _packed(inp.blocks(READ), unitsize, rate, inp.name)
    waveform.start_time = _start_time(inp, rate, unitsize)
    return SampledSource(waveform, settings, inp.describe(_kind(rate, unitsize)), samplerate_given=True)


def _packed(blocks: Iterator[bytes], unitsize: int, rate: float, name: str) -> PackedSamples:
    """The samples of ``blocks``, channel N at bit N, named D0… (or 0…) by bit."""
    waveform = PackedSamples(blocks, unitsize, [f"D{i}" for i in range(unitsize * 8)], rate, name=name)
    waveform.numbers = [str(i) for i in range(unitsize * 8)]
    return waveform


def _kind(rate: float, unitsize: int) -> str:
    """What the stream is, as its description says."""
    return f"logic samples at {hz(rate)}, {counted(unitsize * 8, 'channel')}"


def _start_time(inp: Input, rate: float, unitsize: int) -> float:
    """When the first sample was taken, as a raw dump's first byte is dated: the
    file's modification time less its duration at the rate given (docs/time.md)."""
    try:
        st = os.stat(inp.path)
    except OSError:
        return time.time()
    if inp.compression is not None or not inp.regular:
        return st.st_mtime
    return st.st_mtime - st.st_size / unitsize / rate


def open_sample_stream(path: str, samplerate: float, unitsize: int, settings: ReadSettings,
                       shown: str | None = None) -> SampledSource:
    """The source reading samples from ``path`` (``-``: standard input); ``shown``:
    its name in messages, if not the path."""
    if path == STDIN:
        fd, name, own = sys.stdin.fileno(), "standard input", False
    else:
        try:
            fd, name, own = os.open(path, os.O_RDONLY), shown or path, True
        except OSError as e:
            raise CaptureError(f"{path}: cannot open: {e.strerror or e}") from None
    waveform = _packed(_reads(fd, name), unitsize, samplerate, name)
    waveform.start_time = time.time()
    if own:
        waveform.close = lambda: os.close(fd)   # type: ignore[method-assign]
    source = SampledSource(waveform, settings, f"{name} ({_kind(samplerate, unitsize)})", samplerate_given=True)
    source.live = True
    return source
