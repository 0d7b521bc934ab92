"""Output formats, like python-can's ``MESSAGE_WRITERS``: files by suffix
(``WRITERS``, ``convert -o OUT.suffix``), what is printed on standard output by
name (``FORMATS``, ``--format``).

A writer is a listener of the tap runner (analyzer/runner.py) that writes what it
hears: ``Writer(path, info, file=...)``, with ``info`` the run's ``CaptureInfo``,
built on ``base.FileWriter``, which opens the target (``path`` atomically, an
open ``file``, or standard output for ``path=None``), closes it and says what was
written. A new format is one module here and one line in ``WRITERS`` (or
``FORMATS``). Entries name their class as ``module:Class`` so that a command
imports only the writer it uses (MCAP pulls in the mcap and zstd packages).
Every writer keeps the time model of docs/time.md: capture times, not the time
of writing.
"""

from __future__ import annotations

import importlib
import os
from typing import TYPE_CHECKING, Any

from ..info import CaptureInfo
from ..outfile import OutputRefused, show

if TYPE_CHECKING:   # the registry stays light: a command imports only the writer it uses
    from .base import EventLines, FileWriter

# a folder output: a dataset of tables rather than one file (``gimbalscope export``)
FOLDER_WRITER = "analyzer.writers.parquet:ParquetDatasetWriter"

WRITERS: dict[str, str] = {
    ".mcap": "analyzer.writers.mcap:McapWriter",
    ".jsonl": "analyzer.writers.jsonl:JsonLinesWriter",
    ".ndjson": "analyzer.writers.jsonl:JsonLinesWriter",
    ".pcapng": "analyzer.writers.pcapng:PcapngWriter",
    ".csv": "analyzer.writers.csv_table:CsvWriter",
}


# what decode, live and replay print on standard output (--format), first the default
FORMATS: dict[str, str] = {
    "text": "analyzer.writers.text:TextWriter",
    "jsonl": "analyzer.writers.jsonl:JsonLinesWriter",
    "csv": "analyzer.writers.csv_table:CsvWriter",
}


def suffixes() -> list[str]:
    return list(WRITERS)


def writer_class(path: str) -> type[FileWriter]:
    """The writer for ``path``'s suffix; any other suffix is refused, naming those there are."""
    suffix = os.path.splitext(path)[1].lower()
    entry = WRITERS.get(suffix)
    if entry is None:
        what = f"unknown output format {show(suffix)!r}" if suffix else "no suffix to choose the output format"
        raise OutputRefused(f"{show(path)}: {what}; use one of {', '.join(WRITERS)}")
    return _load(entry)


def _load(entry: str) -> Any:
    """The class ``entry`` names (``module:Class``), its module imported now."""
    module, _, name = entry.partition(":")
    return getattr(importlib.import_module(module), name)


def open_writer(path: str, info: CaptureInfo, **options: Any) -> FileWriter:
    """A writer of ``path``'s format; ``options`` are the writer base's (``file``:
    an open file to write into instead of ``path``) and the format's own (MCAP's
    ``lean``)."""
    return writer_class(path)(path, info, **options)


def open_format(name: str, info: CaptureInfo, **options: Any) -> EventLines:
    """A writer of the format ``name`` (``FORMATS``) to standard output;
    ``options`` are the format's own (the text's ``color``, ``flush_each``)."""
    kind: type[EventLines] = _load(FORMATS[name])
    return kind(None, info, **options)


def file_output(path: str) -> bool:
    """Does ``path`` name one file of a registry format (by its suffix), rather
    than a dataset folder (``FOLDER_WRITER``)?"""
    return os.path.splitext(path.rstrip("/" + os.sep))[1].lower() in WRITERS and not os.path.isdir(path)


def holds_many_captures(path: str) -> bool:
    """Can one file of ``path``'s format (or of the suffix ``path``) hold several
    captures (``export``)?"""
    suffix = path.lower() if path.startswith(".") else os.path.splitext(path)[1].lower()
    entry = WRITERS.get(suffix)
    if entry is None:
        return False
    kind: type[FileWriter] = _load(entry)
    return kind.many_captures


def folder_output(path: str) -> str:
    """``path`` as the folder of a dataset (``FOLDER_WRITER``): refused when it is a
    file, or when a new folder's name ends in a file suffix (``-o out.txt`` meant a
    file, and a folder of that name would only puzzle); an existing folder is taken
    as it is named."""
    many = ", ".join(s for s in WRITERS if holds_many_captures(s))
    if os.path.exists(path) and not os.path.isdir(path):
        raise OutputRefused(f"{show(path)}: is a file; export writes a dataset folder or a {many} file")
    suffix = os.path.splitext(path.rstrip("/" + os.sep))[1]
    if suffix and not os.path.isdir(path):
        raise OutputRefused(f"{show(path)}: {show(suffix)} is a file's suffix; export writes a dataset folder "
                            f"(a name without one, or a folder made beforehand) or a {many} file")
    return path
