"""The captures an export's INPUTs name (docs/dataset.md, "Inputs"), listed once on
the machine that starts the export (the driver, with ``--spark``), so a local
export and a Spark export of the same INPUTs export the same captures.

- ``a+b``: the files of one capture (two raw dumps; the parts of a recording),
  unless a file is named so.
- The parts of one recording given as files of their own, in any order: one
  capture, by the ``capture_id`` their metadata names (``by_recording``).
- A folder: each capture in it, in name order. The numbered parts of a recording
  in parts (``tap-0001.mcap``, ``tap-0002.mcap``, as ``live --record --split``
  names them) are one capture; every other file is one. Hidden files and an
  unfinished export's ``*.tmp`` are left out.
- A pattern (``site-*/day-*.log``) that names no file as it is: the files it
  matches, listed as a folder's are. A shell has usually expanded it already;
  quoted, it reaches us, which is how a remote folder is matched.
- Anything else is one capture, and says what is wrong with it when it is read.

Remote URIs (``hdfs://``, ``s3a://``) are listed through pyarrow's filesystems.
"""

from __future__ import annotations

import fnmatch
import glob
import os
import re

from .. import uris
from ..errors import UsageError

# a recording's numbered part: name-0001.mcap (analyzer/writers/mcap_recorder.py, part_path)
_PART = re.compile(r"^(?P<stem>.*)-(?P<n>\d{4,})\.mcap$", re.IGNORECASE)
_PATTERN = re.compile(r"[*?[]")


def split_input(text: str) -> tuple[str, ...]:
    """One INPUT's files: the name itself when it exists (a '+' in a file name),
    else its parts between '+'."""
    if "+" not in text or (not uris.is_remote(text) and os.path.exists(uris.local_path(text) or text)):
        return (text,)
    return tuple(text.split("+"))


def captures_of(inputs: list[str]) -> list[tuple[str, ...]]:
    """Each capture the INPUTs name, as the tuple of its files, in the INPUTs' order."""
    out: list[tuple[str, ...]] = []
    for text in inputs:
        paths = split_input(text)
        if "-" in paths or "" in paths:
            raise UsageError(f"{text}: export reads capture files (standard input is for decode, stats "
                             "and convert)")
        if len(paths) > 1:
            out.append(paths)
            continue
        listed = _listing(text)
        out += [(text,)] if listed is None else grouped(listed)
    return by_recording(out)


def by_recording(captures: list[tuple[str, ...]]) -> list[tuple[str, ...]]:
    """``captures`` with the parts of one recording given as files of their own
    (``tap-0001.mcap tap-0002.mcap``, in any order) made one capture: those whose
    metadata names the same ``capture_id`` (one per run of a tap) and a part
    number, in part order, at the place of the first. Parts of other recordings,
    and files that say nothing of it, stay apart."""
    runs: dict[str, list[tuple[int, str]]] = {}
    out: list[tuple[str, ...] | list[tuple[int, str]]] = []
    for capture in captures:
        run = _part_of(capture[0]) if len(capture) == 1 else None
        if run is None:
            out.append(capture)
            continue
        capture_id, number = run
        if capture_id not in runs:
            runs[capture_id] = []
            out.append(runs[capture_id])   # its place: where its first part is
        runs[capture_id].append((number, capture[0]))
    return [tuple(p for _, p in sorted(c)) if isinstance(c, list) else c for c in out]


def _part_of(path: str) -> tuple[str, int] | None:
    """(capture_id, part number) of a local MCAP file that is a part of a recording
    in parts (its ``gimbalscope`` metadata says both), else None."""
    local = uris.local_path(path)
    if local is None or not local.lower().endswith(".mcap"):
        return None
    from ..sources.mcapfile import read_metadata  # a light reader: no decoding

    try:
        with open(local, "rb") as f:
            meta, _why = read_metadata(f, os.fstat(f.fileno()).st_size)
    except OSError:
        return None   # the export says what is wrong with it when it reads it
    if not meta or not meta.get("capture_id") or not meta.get("part", "").isdigit():
        return None
    return meta["capture_id"], int(meta["part"])


def _listing(text: str) -> list[str] | None:
    """The files a folder or a pattern names, sorted (None: ``text`` is one file).
    A folder or pattern with no capture in it is refused in one line."""
    local = uris.local_path(text)
    if local is None:   # a remote URI
        names = _remote_listing(text)
        if names is None:
            return None
    elif os.path.isdir(local):
        names = sorted(os.path.join(text, n) for n in os.listdir(local) if _wanted(n)
                       and os.path.isfile(os.path.join(local, n)))
    elif not os.path.exists(local) and _PATTERN.search(local):
        prefix = text[:len(text) - len(local)]   # "file://" kept on what it matched
        names = sorted(prefix + p for p in glob.glob(local) if os.path.isfile(p) and _wanted(os.path.basename(p)))
        if not names:
            raise UsageError(f"{text}: no file matches")
    else:
        return None
    if not names:
        raise UsageError(f"{text}: no capture in this folder")
    return names


def _remote_listing(uri: str) -> list[str] | None:
    from pyarrow import fs

    head, tail = uri.rsplit("/", 1) if "/" in uri.split("://", 1)[1] else (uri, "")
    pattern = _PATTERN.search(tail) is not None
    folder = head if pattern else uri
    try:
        filesystem, path = uris.arrow_filesystem(folder)
        if not pattern and filesystem.get_file_info(path).type != fs.FileType.Directory:
            return None   # a file, or nothing: the export says which when it reads it
        found = filesystem.get_file_info(fs.FileSelector(path, allow_not_found=True))
    except (OSError, ValueError) as e:
        raise UsageError(f"{uri}: cannot list it: {uris.failure(e)}") from None
    base = folder.rstrip("/")
    names = sorted(f"{base}/{f.base_name}" for f in found if f.type == fs.FileType.File and _wanted(f.base_name)
                   and (not pattern or fnmatch.fnmatchcase(f.base_name, tail)))
    if pattern and not names:
        raise UsageError(f"{uri}: no file matches")
    return names


def _wanted(name: str) -> bool:
    return not name.startswith(".") and not name.endswith(".tmp")


def grouped(names: list[str]) -> list[tuple[str, ...]]:
    """``names`` (sorted) as captures: the numbered parts of one recording
    together, in their number order, at the place of the first; the rest alone."""
    out: list[tuple[str, ...] | list[tuple[int, str]]] = []
    parts: dict[str, list[tuple[int, str]]] = {}
    for name in names:
        m = _PART.match(name)
        if m is None:
            out.append((name,))
            continue
        stem = m.group("stem")
        if stem not in parts:
            parts[stem] = []
            out.append(parts[stem])   # its place: where its first part is
        parts[stem].append((int(m.group("n")), name))
    return [tuple(n for _, n in sorted(c)) if isinstance(c, list) else c for c in out]
