"""Capture inputs behind one interface, and detection of which one a file is
(the formats and how each is recognised: analyzer/sources/registry.py)."""

from __future__ import annotations

from . import registry
from .base import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Reader, Source
from .files import STDIN, Input, open_input
from .rawdump import RawDumpSource
from .registry import formats
from .socatlog import SocatLogSource


def detect(paths: list[str], byte_time: float) -> Source:
    """Pick the source for ``paths``: the first reader in ``registry.READERS`` that
    recognises them (an MCAP recording, a socat log, one raw dump, or two raw
    dumps). Each input is opened once (``-`` is standard input); its head,
    decompressed if need be, tells what it is."""
    if not paths:
        raise CaptureError("no input given")
    if len(paths) > registry.most_inputs():
        raise CaptureError(f"{len(paths)} inputs given: expected one capture file, or two raw dumps "
                           "(line A then line B)")
    if paths.count(STDIN) > 1:
        raise CaptureError("standard input (-) given twice: it can be read only once")
    inputs: list[Input] = []
    try:
        for p in paths:
            inputs.append(Input(p))
        return registry.source_for(inputs, byte_time)
    except BaseException:
        for i in inputs:
            i.close()
        raise


__all__ = ["CaptureError", "Chunk", "Input", "LINE_A", "LINE_AB", "LINE_B", "RawDumpSource", "Reader", "Source",
           "SocatLogSource", "detect", "formats", "open_input", "registry"]
