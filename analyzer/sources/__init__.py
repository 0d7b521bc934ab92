"""Capture inputs behind one interface, and detection of which one a file is."""

from __future__ import annotations

import codecs
import os

from .base import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Source
from .files import STDIN, Input, open_input
from .rawdump import RawDumpSource
from .socatlog import SocatLogSource, looks_like_socat

MCAP_MAGIC = b"\x89MCAP"


def detect(paths: list[str], byte_time: float) -> Source:
    """Pick the source for ``paths``: an MCAP recording, a socat log, one raw dump,
    or two raw dumps. Each input is opened once (``-`` is standard input); its
    head, decompressed if need be, tells what it is."""
    if not paths:
        raise CaptureError("no input given")
    if len(paths) > 2:
        raise CaptureError(f"{len(paths)} inputs given: expected one capture file, or two raw dumps "
                           "(line A then line B)")
    if paths.count(STDIN) > 1:
        raise CaptureError("standard input (-) given twice: it can be read only once")
    inputs: list[Input] = []
    try:
        for p in paths:
            inputs.append(Input(p))
        return _source_for(inputs, byte_time)
    except BaseException:
        for i in inputs:
            i.close()
        raise


def _source_for(inputs: list[Input], byte_time: float) -> Source:
    for i in inputs:
        if i.path.lower().endswith(".mcap") and not i.head.startswith(MCAP_MAGIC):
            # named a recording but not one: a damaged file, not a raw dump to decode as noise
            raise CaptureError(f"{i.name}: not an MCAP file (it does not start with the MCAP magic bytes)")
    mcaps = [i for i in inputs if i.head.startswith(MCAP_MAGIC)]
    if mcaps:
        if len(inputs) != 1:
            raise CaptureError(f"{mcaps[0].name}: an MCAP recording carries all its lines; give it on its own")
        return _mcap_source(inputs[0])
    socat = [i for i in inputs if looks_like_socat(i.head)]
    if socat:
        if len(inputs) != 1:
            raise CaptureError(f"{socat[0].name}: a socat log carries both lines; give it on its own")
        return SocatLogSource(inputs[0], byte_time)
    for i in inputs:
        _reject_text(i.name, i.head)
    return RawDumpSource(inputs)


def _mcap_source(inp: Input) -> Source:
    """An MCAP recording is read with random access (surveyed, then read, large ones
    by a second process): one that arrives through a pipe or compressed is copied
    to a temporary file first, removed when the source closes or the run ends."""
    from .mcapfile import McapSource

    path, temporary = inp.as_regular_file()
    problem = inp.problem
    inp.close()
    try:
        source = McapSource(path, name=inp.name)
    except BaseException:
        if temporary:
            _remove(path)
        raise
    if temporary:
        source.on_close(lambda: _remove(path))
        source.description = inp.describe("MCAP")   # the user's name, not the copy's
    if problem:
        source.warn_later(problem)
    return source


def _remove(path: str) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def _reject_text(name: str, head: bytes) -> None:
    """A raw dump of this protocol has start bytes (F8) or simple responses; a file of
    printable text without any (one line or many, with a final newline or not) is
    something else given by mistake."""
    if not head:
        return
    if any(b in head for b in (b"\xf8", b"\x06", b"\x15")):
        return
    try:
        # a head cut inside a UTF-8 character is still text
        text = codecs.getincrementaldecoder("utf-8")().decode(head, final=False)
    except UnicodeDecodeError:
        return
    if text and all(c.isprintable() or c in "\r\n\t" for c in text):
        lines = text.splitlines()
        first = lines[0][:60] if lines else ""
        raise CaptureError(f"{name}: a text file that is not a socat -x -v log "
                           f"(line 1: {first!r}); raw dumps are binary")


__all__ = ["CaptureError", "Chunk", "Input", "LINE_A", "LINE_AB", "LINE_B", "RawDumpSource", "Source",
           "SocatLogSource", "detect", "open_input"]
