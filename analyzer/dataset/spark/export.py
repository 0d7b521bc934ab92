"""``export --spark MASTER``: the captures decoded by Spark's executors into the
dataset the local export writes (docs/spark.md).

The driver lists the captures (analyzer/dataset/inputs.py) and makes one task of
each: a DataFrame of one job a partition, largest inputs first so the long tasks
start first and the small ones fill in around them. Each task runs the local
export's own job (``export.run_job``: decode, pair, the doctor, the Parquet
writer with its whole-or-nothing commit) where the executor is, writing the
capture's files straight into the dataset folder, and hands back through
``mapInArrow`` only its outcome: rows written, warnings, or why it was skipped.
So the rows never travel through the driver, and the files, their names (the
capture key) and the rule for exporting again are the local export's.

A capture is one task, never split: event numbers run on across a recording's
parts and its files, and a command in one part can be answered in the next, so a
capture cut in two would not give the same rows.

A capture that fails on an executor, for any reason, is an outcome with its
error, as a capture that cannot be read is in the local export: the others are
written, and the command lists it as skipped and exits 1.
"""

from __future__ import annotations

import os
import pickle
from typing import Callable, Iterator

from ... import uris
from ...errors import OutputRefused
from ...outfile import show
from ..export import Job, Outcome, input_size, make_dataset_folder, run_job
from .session import check, one_line, start

OUTCOME_SCHEMA = "index long, outcome binary"


def run_on_spark(master: str, jobs: list[Job], *, on_done: Callable[[Outcome], None] | None = None,
                 show_progress: bool = False, spark=None) -> list[Outcome]:
    """Export ``jobs`` on Spark (a session for ``master``, or ``spark`` when given);
    the outcomes in the jobs' order, each also to ``on_done`` as the job ends."""
    own = spark is None
    if own:
        check(master)   # a master that cannot work is said before the output is made
    if jobs:
        check_output(jobs[0].root)
    if own:
        spark = start(master, "gimbalscope export", checked=True)
    try:
        outcomes = _run(spark, jobs, show_progress)
    finally:
        if own:
            spark.stop()
    for outcome in outcomes:
        if on_done is not None:
            on_done(outcome)
    return outcomes


def check_output(root: str) -> None:
    """Make the dataset folder, or say in one line why it cannot be written (before
    any executor starts)."""
    local = uris.local_path(root)
    if local is not None:
        make_dataset_folder(root)
        if not os.access(local, os.W_OK | os.X_OK):
            raise OutputRefused(f"{show(root)}: cannot write in the dataset folder: permission denied")
        return
    try:
        filesystem, where = uris.arrow_filesystem(root)
        filesystem.create_dir(where, recursive=True)
        probe_path = where.rstrip("/") + "/.gimbalscope-probe"
        with filesystem.open_output_stream(probe_path) as f:
            f.write(b"")
        filesystem.delete_file(probe_path)
    except (OSError, ValueError, ImportError) as e:
        raise OutputRefused(f"{root}: cannot write the dataset there: {uris.failure(e)}") from None


def _run(spark, jobs: list[Job], show_progress: bool) -> list[Outcome]:
    if not jobs:
        return []
    largest_first = sorted(jobs, key=lambda job: -input_size(job))
    rows = [(job.index, pickle.dumps(job)) for job in largest_first]
    # one job a partition: each capture is a task of its own
    frame = spark.sparkContext.parallelize(rows, len(rows)).toDF("index long, job binary")
    results = frame.mapInArrow(export_batches, OUTCOME_SCHEMA)
    with _progress(spark, jobs, show_progress):
        got = {row["index"]: pickle.loads(row["outcome"]) for row in results.collect()}
    return [got[job.index] for job in jobs]


def export_batches(batches: Iterator) -> Iterator:
    """On an executor: each job of ``batches`` (Arrow record batches of
    ``index, job``) exported, its outcome handed back as one row."""
    import pyarrow as pa

    for batch in batches:
        indices, outcomes = [], []
        for index, blob in zip(batch.column("index").to_pylist(), batch.column("job").to_pylist()):
            job: Job = pickle.loads(blob)
            try:
                outcome = run_job(job)
            except Exception as e:   # a bug, or the executor's machine: this capture is skipped, not the export
                outcome = Outcome(index, "+".join(job.paths),
                                  error=f"{'+'.join(job.paths)}: failed on a Spark executor: "
                                        f"{type(e).__name__}: {one_line(e)}")
            indices.append(index)
            outcomes.append(pickle.dumps(outcome))
        yield pa.RecordBatch.from_arrays([pa.array(indices, pa.int64()), pa.array(outcomes, pa.binary())],
                                         names=["index", "outcome"])


class _TaskMeter:
    """The progress bar's meter (analyzer/listeners/progress.py) for a Spark job:
    the inputs' bytes, counted done as Spark's tasks end."""

    def __init__(self, spark, jobs: list[Job]) -> None:
        self.tracker = spark.sparkContext.statusTracker()
        self.bytes = sum(input_size(job) for job in jobs) or len(jobs)
        self.tasks = len(jobs)
        self.finished = 0

    def total(self) -> int | None:
        return self.bytes

    def done(self) -> int:
        for stage in self.tracker.getActiveStageIds():
            info = self.tracker.getStageInfo(stage)
            if info is not None and info.numTasks == self.tasks:
                self.finished = max(self.finished, info.numCompletedTasks)
        return self.bytes * self.finished // self.tasks


def _progress(spark, jobs: list[Job], show_progress: bool):
    from ...listeners.progress import ReadProgress
    return ReadProgress(enabled=show_progress, meter=_TaskMeter(spark, jobs), label="exporting on Spark")
