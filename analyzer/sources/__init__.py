"""Capture inputs behind one interface, and detection of which one a file is
(the formats and how each is recognised: analyzer/sources/registry.py)."""

from __future__ import annotations

from ..errors import CaptureError
from ..lines import LINE_A, LINE_AB, LINE_B, Chunk
from . import registry
from .base import InstrumentSettings, Reader, ReadSettings, Source
from .files import STDIN, Input, open_input
from .rawdump import RawDumpSource
from .registry import formats
from .socatlog import SocatLogSource


def detect(paths: list[str], settings: ReadSettings | float) -> Source:
    """Pick the source for ``paths``: the first reader in ``registry.READERS`` that
    recognises them (MCAP recordings of one tap, a socat log, one raw dump, or two
    raw dumps). Each input is opened once (``-`` is standard input); its head,
    decompressed if need be, tells what it is, and so whether more inputs than a
    fixed-count format reads are acceptable (recordings in parts). ``settings``:
    how to read them (``ReadSettings``), or just the byte time."""
    if not paths:
        raise CaptureError("no input given")
    if len(paths) > registry.most_inputs() and not registry.any_count_read():
        raise CaptureError(registry.TOO_MANY.format(count=len(paths)))
    if paths.count(STDIN) > 1:
        raise CaptureError("standard input (-) given twice: it can be read only once")
    inputs: list[Input] = []
    try:
        for p in paths:
            inputs.append(Input(p))
        return registry.source_for(inputs, ReadSettings.of(settings))
    except BaseException:
        for i in inputs:
            i.close()
        raise


__all__ = [
    "LINE_A",
    "LINE_AB",
    "LINE_B",
    "CaptureError",
    "Chunk",
    "Input",
    "InstrumentSettings",
    "RawDumpSource",
    "ReadSettings",
    "Reader",
    "SocatLogSource",
    "Source",
    "detect",
    "formats",
    "open_input",
    "registry",
]
