"""One capture into a Parquet dataset folder (docs/dataset.md): its events,
transactions (analyzer/analysis/transactions.py) and the wiring doctor's findings
(analyzer/analysis/doctor.py) as the tables of ``analyzer.formats.parquet_schema``, partitioned
by the UTC date of each row.

A capture's files are named by its key (``capture_key``: its files' real
paths), so exporting it again replaces its own files and nothing else. The new
files are written beside the old ones under a name readers skip
(``*.parquet.tmp``) and take their place on ``commit()``, once the capture has
been read to its end: an export that fails or is stopped leaves the dataset as
it was (``abort()``). That commit of many files is this writer's own, so it is
no ``FileWriter`` (analyzer/writers/base.py); it says what it wrote as they do
(``summary()``).
"""

from __future__ import annotations

import hashlib
import os
import re
from typing import Any

import pyarrow.parquet as pq

from dissectors.event import Event

from .. import uris
from ..analysis.doctor import Invocation, WiringDoctor
from ..analysis.transactions import TransactionRows
from ..formats import parquet_schema as S
from ..formats.marks import MarksError, read_marks
from ..formats.parquet_rows import EventBatches, TransactionBatches, day_of, findings_batch, marks_batch, partitions
from ..info import CaptureInfo
from ..outfile import show
from ..runner import Listener, TapRunner
from .base import wrote
from .dataset_folder import folder_of

ROWS_PER_GROUP = 32 * 1024   # rows per row group: a few MB of Python rows per table at a time (memory stays flat)
TMP = ".tmp"


def capture_key(paths: list[str] | tuple[str, ...]) -> str:
    """The file name stem of a capture's files: its first file's name (readable)
    and a hash of its files' real paths (unique). A ``file://`` URI is its path;
    a remote URI (``s3a://…``) is itself, its real path."""
    real = "\0".join(_real(p) for p in paths)
    digest = hashlib.sha1(real.encode("utf-8", "surrogateescape")).hexdigest()[:12]
    name = paths[0].rstrip("/").rsplit("/", 1)[-1] if uris.scheme(paths[0]) else os.path.basename(paths[0])
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", name)[:60] or "capture"
    return f"{stem}-{digest}"


def _real(path: str) -> str:
    local = uris.local_path(path)
    return os.path.realpath(local) if local is not None else path


class ParquetDatasetWriter(Listener):
    """The writer of a dataset folder ``path`` (the registry's folder entry)."""

    def __init__(self, path: str, info: CaptureInfo, *, capture: str | None = None,
                 site: str | None = None, key: str | None = None) -> None:
        self.root = path
        self.folder = folder_of(path)
        self.info = info
        self.capture = capture if capture is not None else "+".join(info.inputs)
        self.site = site
        self.key = key or capture_key(info.inputs)
        # the rows waiting for their row group: events and transactions, from the first event
        self._batches: tuple[EventBatches, TransactionBatches] | None = None
        self._txns = TransactionRows()
        self._writers: dict[tuple[str, str], pq.ParquetWriter] = {}
        self.doctor: WiringDoctor | None = None
        self.first_t: float | None = None
        self.last_t: float | None = None
        self.rows = {table: 0 for table in S.TABLES}
        self._start_time = info.start_time   # what dates an undated row: the capture's start
        self.committed = False
        self.warnings: list[str] = []   # what to say beside the rows (a marks sidecar that does not read)

    # ------------------------------------------------------------ the runner's calls
    def on_start(self, runner: TapRunner) -> None:
        info = runner.info
        self.doctor = WiringDoctor(runner.lines, runner.ack_timeout,
                                   Invocation(info.inputs, info.live, info.command, False, baud=info.baud))
        self.doctor.physical = runner.physical

    def on_events(self, events: list[Event]) -> None:
        if not events:
            return
        if self._batches is None:
            origin = events[0].origin
            start = origin.start_time if origin is not None else self.info.start_time
            self._batches = (EventBatches(self.capture, self.site, start),
                             TransactionBatches(self.capture, self.site, start))
        rows, txn_rows = self._batches
        assert self.doctor is not None   # made on_start, before any event
        add, txn_add, doctor_add = rows.add, txn_rows.add, self.doctor.add
        txns = self._txns
        for ev in events:
            add(ev)
            doctor_add(ev)
            done = txns.add(ev)
            if done is not None:
                txn_add(done)
        t = events[-1].t
        if t is not None:
            if self.first_t is None:
                self.first_t = events[0].t
            self.last_t = max(t, self.last_t or t)
        if len(rows) >= ROWS_PER_GROUP:
            self._write("events", rows.batch())
        if len(txn_rows) >= ROWS_PER_GROUP:
            self._write("transactions", txn_rows.batch())

    def on_stop(self) -> None:
        """The end of the run: the last rows and the findings are written and the
        files closed. They take the place of the capture's old ones only on
        ``commit()``: the runner stops its listeners after a failure too."""
        try:
            if self._batches is not None:
                self._write_last(*self._batches)
            for writer in self._writers.values():
                writer.close()
        except BaseException:
            self.abort()
            raise

    def _write_last(self, rows: EventBatches, txn_rows: TransactionBatches) -> None:
        """The rows still waiting, and the doctor's findings."""
        done = self._txns.finish()
        if done is not None:
            txn_rows.add(done)
        if len(rows):
            self._write("events", rows.batch())
        if len(txn_rows):
            self._write("transactions", txn_rows.batch())
        assert self.doctor is not None   # made on_start, before any event
        findings = self.doctor.findings()
        if findings:
            # an untimed capture's span is unknown, its start is not (t = 0)
            first = self.first_t if self.first_t is not None else 0.0
            self._write("findings", findings_batch(findings, self.capture, self.site,
                                                   rows.start_time, first, self.last_t))
        self._write_marks(rows.start_time)

    # ------------------------------------------------------------ rows made elsewhere
    def write_rows(self, table: str, batch: Any) -> None:
        """Rows of ``table`` made without events (``formats/parquet_columns.py``:
        a recording's stored columns), written as this writer's own."""
        self._write(table, batch)

    def write_findings(self, findings: list, start_time: float | None, first_t: float | None,
                       last_t: float | None) -> None:
        """The doctor's ``findings`` of a capture whose rows ``write_rows`` wrote
        (``first_t``, ``last_t``: its first and last event's times), then the
        files closed, as ``on_stop`` does for one read event by event (and as it
        does, none for a capture without events: no findings, no marks)."""
        try:
            if self.rows["events"]:
                if findings:
                    self._write("findings", findings_batch(findings, self.capture, self.site, start_time,
                                                           first_t if first_t is not None else 0.0, last_t))
                self._write_marks(start_time)
            for writer in self._writers.values():
                writer.close()
        except BaseException:
            self.abort()
            raise

    def _write_marks(self, start_time: float | None) -> None:
        """The events marked while the capture was watched (its sidecar, its
        recording's /marks); a sidecar that does not read is said (``warnings``)."""
        try:
            marks = read_marks(self.info.inputs)
        except MarksError as e:
            self.warnings.append(f"{e}: exported without its marks")
            return
        if marks:
            self._write("marks", marks_batch(marks, self.capture, self.site, start_time))

    # ------------------------------------------------------------ files
    def _file(self, table: str, day: str) -> str:
        return self.folder.file(table, f"{S.PARTITION}={day}", self.key + ".parquet")

    def _write(self, table: str, batch: Any) -> None:
        # findings are dated by the capture's start (their rows carry no time of their own)
        column = "start" if table == "findings" else "ts"
        undated = day_of(self._batches[0].start_time if self._batches is not None else self._start_time)
        for day, rows in partitions(batch, column, undated):
            writer = self._writers.get((table, day))
            if writer is None:
                writer = self._writers[(table, day)] = self._open(table, day)
            writer.write(rows, row_group_size=ROWS_PER_GROUP)   # a batch, or a table of batches
            self.rows[table] += rows.num_rows

    def _open(self, table: str, day: str) -> pq.ParquetWriter:
        """A new file of ``table`` for ``day``, under its temporary name."""
        return self.folder.writer(self._file(table, day) + TMP, S.TABLES[table])

    def summary(self) -> str:
        """What was written, one line: ``wrote 1,024 events, 12 transactions, 0 findings to DIR``."""
        return wrote(self.rows, show(self.root))

    def old_files(self) -> list[str]:
        """The capture's files in the dataset now (and any left by a failed export)."""
        name = self.key + ".parquet"
        return (self.folder.files_named(S.TABLES, S.PARTITION, name)
                + self.folder.files_named(S.TABLES, S.PARTITION, name + TMP))

    def commit(self) -> None:
        """The new files take the place of the capture's old ones (after ``on_stop``)."""
        new = {self._file(table, day) for table, day in self._writers}
        vacated = set()
        for old in self.old_files():
            final = old.removesuffix(TMP)
            if final not in new:   # a day the capture no longer has, or a failed export's leftover
                self.folder.remove(old)
                vacated.add(os.path.dirname(old))
        for final in new:
            self.folder.replace(final + TMP, final)
        # the partitions this capture left, if that left them empty; only those: an
        # empty folder elsewhere may be another capture's, about to get its file
        for folder in vacated:
            self.folder.drop_if_empty(folder)
        self.committed = True

    def abort(self) -> None:
        """Drop what this export wrote; the capture's old files stay."""
        for writer in self._writers.values():
            try:
                writer.close()
            except Exception:   # noqa: BLE001, S110 - the export failed already: that error is the one told
                pass
        for table, day in self._writers:
            self.folder.remove(self._file(table, day) + TMP)
        self._writers.clear()
