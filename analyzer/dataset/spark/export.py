"""``export --spark MASTER``: the captures decoded by Spark's executors into the
dataset the local export writes (docs/spark.md).

The driver lists the captures (analyzer/dataset/inputs.py) and makes one task of
each: an RDD of one job a partition, largest inputs first so the long tasks
start first and the small ones fill in around them. Each task runs the local
export's own job (``export.run_job``: decode, pair, the doctor, the Parquet
writer with its whole-or-nothing commit) where the executor is, writing the
capture's files straight into the dataset folder, and hands back only its
outcome: rows written, warnings, or why it was skipped. So the rows never
travel through the driver, and the files, their names (the capture key) and the
rule for exporting again are the local export's.

A capture is one task, never split: event numbers run on across a recording's
parts and its files, and a command in one part can be answered in the next, so a
capture cut in two would not give the same rows.

A capture that fails on an executor, for any reason its Python can catch (an
input that cannot be read, an executor's Python without pyarrow, a bug), is an
outcome with its error, as a capture that cannot be read is in the local export:
the task itself succeeds, so the others are written, and the command lists it
as skipped and exits 1. The outcomes travel as plain pickles (an RDD, not
``mapInArrow``): Spark's Arrow transport would need pyarrow in the executor's
Python before any of this code runs, and its absence would then fail the task,
and with it the whole job, instead of being said of each capture. What only
Spark sees (a Python worker that crashed, an executor lost, an executor whose
Python cannot load this package) fails the job: one line, exit 1
(``SparkFailed``), naming the capture whose task it was when Spark says.
"""

from __future__ import annotations

import os
import pickle
import re
from collections.abc import Callable, Iterable, Iterator
from typing import TYPE_CHECKING

from ... import uris
from ...errors import OutputRefused
from ...outfile import show
from ..export import Job, Outcome, capture_name, input_size, make_dataset_folder, run_job
from .session import SparkFailed, check, one_line, start

if TYPE_CHECKING:
    from pyspark.sql import SparkSession

    from ...listeners.progress import ReadProgress

# Spark's message for an aborted job: "... most recent failure: Lost task 3.0 in stage 0.0 (TID 7) ..."
_LOST_TASK = re.compile(r"Lost task (\d+)\.\d+ in stage")


def run_on_spark(master: str, jobs: list[Job], *, on_done: Callable[[Outcome], None] | None = None,
                 show_progress: bool = False, spark: SparkSession | None = None) -> list[Outcome]:
    """Export ``jobs`` on Spark (a session for ``master``, or ``spark`` when given);
    the outcomes in the jobs' order, each also to ``on_done`` as the job ends.
    Raises ``SparkFailed`` (one line) when Spark fails the job itself."""
    if spark is None:
        check(master)   # a master that cannot work is said before the output is made
    if jobs:
        check_output(jobs[0].root)
    session = spark if spark is not None else start(master, "gimbalscope export", checked=True)
    try:
        outcomes = _run(session, master, jobs, show_progress)
    finally:
        if spark is None:   # our own
            session.stop()
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


def _run(spark: SparkSession, master: str, jobs: list[Job], show_progress: bool) -> list[Outcome]:
    if not jobs:
        return []
    largest_first = sorted(jobs, key=lambda job: -input_size(job))
    # the capture's name travels beside its pickled job: a job the executor cannot unpickle is still named
    rows = [(job.index, capture_name(job.paths), pickle.dumps(job)) for job in largest_first]
    # one job a partition: each capture is a task of its own
    results = spark.sparkContext.parallelize(rows, len(rows)).mapPartitions(export_partition)
    try:
        with _progress(spark, jobs, show_progress):
            got = dict(results.collect())
    except Exception as e:   # noqa: BLE001 - Py4JJavaError, or pyspark's own exceptions for what it converts
        raise SparkFailed(_job_failed(master, e, largest_first)) from None
    return [got[job.index] for job in jobs]


def _job_failed(master: str, e: Exception, largest_first: list[Job]) -> str:
    """The one line for a job Spark failed: the capture whose task failed when
    Spark names the task (partition N is the Nth largest capture), and the cause."""
    cause = one_line(e).rstrip(".")
    lost = _LOST_TASK.search(str(e))
    where = ""
    if lost and int(lost.group(1)) < len(largest_first):
        where = f" in the task of {show(capture_name(largest_first[int(lost.group(1))].paths))}"
    hint = ""
    if "ModuleNotFoundError" in cause or "ImportError" in cause:
        hint = " (the executors' Python needs gimbalscope with the spark extra: docs/spark.md)"
    return (f"--spark {master}: Spark failed the export{where}: {cause}{hint}; the captures done before it are "
            f"written, export the others again")


def export_partition(rows: Iterable[tuple[int, str, bytes]]) -> Iterator[tuple[int, Outcome]]:
    """On an executor: each job of the partition (``index, capture, pickled job``)
    exported, handed back as ``(index, outcome)``. Nothing a capture does fails
    the task: whatever goes wrong is that capture's outcome, so Spark neither
    retries it nor aborts the job's other captures."""
    for index, name, blob in rows:
        try:
            outcome = run_job(pickle.loads(blob))
        except Exception as e:   # noqa: BLE001 - a bug, or the executor's machine: this capture is skipped, not the export
            outcome = Outcome(index, name, error=f"{name}: failed on a Spark executor: "
                                                 f"{type(e).__name__}: {one_line(e)}")
        yield index, outcome


class _TaskMeter:
    """The progress bar's meter (analyzer/listeners/progress.py) for a Spark job:
    the inputs' bytes, counted done as Spark's tasks end."""

    def __init__(self, spark: SparkSession, jobs: list[Job]) -> None:
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


def _progress(spark: SparkSession, jobs: list[Job], show_progress: bool) -> ReadProgress:
    from ...listeners.progress import ReadProgress
    return ReadProgress(enabled=show_progress, meter=_TaskMeter(spark, jobs), label="exporting on Spark")
