"""One recording exported from the decoded columns it carries (docs/dataset.md,
"Exporting a recording"): its events and transactions made column by column
(``formats/parquet_columns.py``), the doctor's findings from what the recorder
kept, the warnings a decoding run gives said the same way. Nothing is decoded.

Where decoding would say more than the columns know, the recording is decoded
instead, as ``stats`` does (cli/stored_stats.py): two clocks (their skew is
estimated as it decodes) and rate changes (following one warns as it goes).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from ..analysis.doctor import Invocation
from ..capture import Capture
from ..capture.stored import stored_events
from ..formats.parquet_columns import StoredRows, Tables, TablesSoFar, stored_batches
from ..formats.store import StoreChunk
from ..formats.store_ipc import ColumnsError, Joiner, sets_a_rate
from ..info import CaptureInfo
from ..listeners.wiring_check import warning_text, wiring_findings
from ..writers.parquet import ROWS_PER_GROUP, ParquetDatasetWriter


class Undecodable(Exception):
    """The columns cannot stand for decoding: the job decodes (``why``: None, silently)."""

    def __init__(self, why: str | None = None) -> None:
        super().__init__(why)
        self.why = why


@dataclass
class Exported:
    events: int
    warnings: list[str] = field(default_factory=list)


class _WrittenBehind:
    """Rows gathered into row groups as the event by event writer makes them
    (``ROWS_PER_GROUP``) and written by a thread of their own while the next
    are made: writing Parquet lets go of the interpreter, so on two cores the
    writing and the making overlap. At most two row groups wait."""

    def __init__(self, writer: ParquetDatasetWriter) -> None:
        self.writer = writer
        self.pool = ThreadPoolExecutor(1, thread_name_prefix="gimbalscope-parquet")
        self.waiting: deque[Future[None]] = deque()
        self.held: dict[str, list[pa.RecordBatch]] = {}

    def add(self, table: str, batch: pa.RecordBatch) -> None:
        held = self.held.setdefault(table, [])
        held.append(batch)
        if sum(b.num_rows for b in held) >= ROWS_PER_GROUP:
            self._send(table)

    def _send(self, table: str) -> None:
        batches = self.held.pop(table, [])
        if not batches:
            return
        # the batches as one table, not copied into one batch: a row group is written from them as they are
        rows = pa.Table.from_batches(batches)
        self.waiting.append(self.pool.submit(self.writer.write_rows, table, rows))
        while len(self.waiting) > 2:
            self.waiting.popleft().result()   # a write's error is raised here

    def close(self) -> None:
        """Everything written (or the first write's error raised)."""
        try:
            for table in list(self.held):
                self._send(table)
            while self.waiting:
                self.waiting.popleft().result()
        finally:
            self.pool.shutdown()

    def cancel(self) -> None:
        """Stop: the writes under way end, the rest are dropped (the writer is then aborted)."""
        self.held.clear()
        self.pool.shutdown(wait=True, cancel_futures=True)


def export_stored(capture: Capture, info: CaptureInfo, writer: ParquetDatasetWriter, name: str) -> Exported:
    """Write the recording's rows with ``writer`` (not committed); raises
    ``Undecodable`` when it is to be decoded instead (the writer then aborted),
    with the line saying why when there is one to say."""
    stored, why = stored_events(capture)
    if stored is None or capture.clocks > 1:
        writer.abort()
        raise Undecodable(why)
    lines = tuple(capture.lines)
    invocation = Invocation(info.inputs, info.live, info.command, False, baud=info.baud)
    doctor = stored.doctor(lines, capture.options.timeouts.ack, invocation)
    signs = stored.signs(lines)
    if doctor is None or signs is None:
        writer.abort()
        raise Undecodable()
    doctor.physical = capture.source.physical
    start_time = capture.origin.start_time
    rows = StoredRows(writer.capture, writer.site, start_time)
    joiner = Joiner()
    first_t: float | None = None
    last_t: float | None = None

    def chunks() -> Iterator[tuple[StoreChunk, Tables, tuple[np.ndarray, np.ndarray]]]:
        """The chunks with their tables and positions, as the joiner reads them."""
        tables = TablesSoFar()
        for chunk in stored.chunks(joiner):
            if sets_a_rate(chunk):
                raise Undecodable()
            yield chunk, tables.of(joiner.known()), joiner.positions
    behind = _WrittenBehind(writer)
    try:
        for table, batch in stored_batches(rows, chunks()):
            behind.add(table, batch)
            if table == "events" and batch.num_rows:
                t = batch.column("t")
                if first_t is None and t[0].is_valid:
                    first_t = t[0].as_py()
                end = t[batch.num_rows - 1]
                if end.is_valid:   # as the event by event writer dates the span: the latest batch end
                    last_t = end.as_py() if last_t is None else max(last_t, end.as_py())
        behind.close()
    except ColumnsError as e:
        behind.cancel()
        writer.abort()
        raise Undecodable(f"{capture.source.description}: stored columns not read ({e}): "
                          "decoding the raw bytes") from None
    except BaseException:
        behind.cancel()
        writer.abort()
        raise
    writer.write_findings(doctor.findings(), start_time, first_t, last_t)
    warnings = list(capture.warnings)
    warnings += [f"{name}: {warning_text(f)}" for f in wiring_findings(signs, info)]
    return Exported(joiner.events, warnings)
