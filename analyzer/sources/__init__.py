"""Capture inputs behind one interface, and detection of which one a file is."""

from __future__ import annotations

from .base import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Source
from .files import open_input
from .rawdump import RawDumpSource
from .socatlog import SocatLogSource, looks_like_socat

MCAP_MAGIC = b"\x89MCAP"


def detect(paths: list[str], byte_time: float) -> Source:
    """Pick the source for ``paths``: a socat log, one raw dump, or two raw dumps."""
    if not paths:
        raise CaptureError("no input given")
    if len(paths) > 2:
        raise CaptureError(f"{len(paths)} inputs given: expected one capture file, or two raw dumps "
                           "(line A then line B)")
    heads = []
    for p in paths:
        with open_input(p) as f:
            try:
                heads.append(f.read(65536))
            except OSError as e:
                raise CaptureError(f"{p}: cannot read: {e.strerror or e}") from None
    for p, head in zip(paths, heads):
        if p.lower().endswith(".mcap") and not head.startswith(MCAP_MAGIC):
            # named a recording but not one: a damaged file, not a raw dump to decode as noise
            raise CaptureError(f"{p}: not an MCAP file (it does not start with the MCAP magic bytes)")
    mcaps = [p for p, head in zip(paths, heads) if head.startswith(MCAP_MAGIC)]
    if mcaps:
        if len(paths) != 1:
            raise CaptureError(f"{mcaps[0]}: an MCAP recording carries all its lines; give it on its own")
        from .mcapfile import McapSource
        return McapSource(paths[0])
    kinds = [looks_like_socat(h) for h in heads]
    if any(kinds):
        if len(paths) != 1:
            bad = paths[kinds.index(True)]
            raise CaptureError(f"{bad}: a socat log carries both lines; give it on its own")
        return SocatLogSource(paths[0], byte_time)
    for p, head in zip(paths, heads):
        _reject_text(p, head)
    return RawDumpSource(paths)


def _reject_text(path: str, head: bytes) -> None:
    """A raw dump of this protocol has start bytes (F8) or simple responses; a file of
    printable text without any is something else given by mistake."""
    if not head:
        return
    if any(b in head for b in (b"\xf8", b"\x06", b"\x15")):
        return
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        return
    if "\n" in text and all(c.isprintable() or c in "\r\n\t" for c in text):
        first = text.splitlines()[0][:60] if text.splitlines() else ""
        raise CaptureError(f"{path}: a text file that is not a socat -x -v log "
                           f"(line 1: {first!r}); raw dumps are binary")


__all__ = ["CaptureError", "Chunk", "LINE_A", "LINE_AB", "LINE_B", "RawDumpSource", "Source",
           "SocatLogSource", "detect", "open_input"]
