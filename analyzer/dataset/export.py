"""Exporting captures into a dataset folder (docs/dataset.md): each capture in a
job of its own, the jobs spread over a pool of processes (decoding is CPU work,
and one Python process uses one core), with one progress bar over them all.

A job never raises for its input: a capture that cannot be read, or a
recording cut short (a killed tap's, before ``gimbalscope recover``), is an
``Outcome`` with its ``error``, its files left as they were, and the export goes
on with the others.
"""

from __future__ import annotations

import contextlib
import os
import queue
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

from dissectors.event import Event

from .. import uris
from ..capture import Capture, Options
from ..capture import open as open_capture
from ..info import CaptureInfo
from ..listeners.wiring_check import WiringCheck
from ..outfile import OutputRefused, show
from ..runner import Listener, TapRunner
from ..sources import CaptureError
from ..sources.meter import READS
from ..words import counted
from ..writers.base import FileWriter

if TYPE_CHECKING:   # pyarrow (the fleet extra) only for a dataset
    from ..writers.parquet import ParquetDatasetWriter

REPORT_EVERY = 0.25   # seconds between a job's reports of the bytes it has read
MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass
class Job:
    index: int
    paths: tuple[str, ...]     # one capture: a file, or the files of one (two raw dumps, a recording's parts),
                               # as given: local paths or URIs (analyzer/uris.py)
    root: str
    options: Options
    site: str | None = None    # --site; None: the recording's own, if it says
    file: str | None = None    # a file output (a registry format, ``-o F.pcapng``): this capture's part of it


@dataclass
class Outcome:
    index: int
    capture: str
    error: str | None = None   # why it was skipped (None: exported)
    rows: dict[str, int] = field(default_factory=dict)
    events: int = 0
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0


class Reports(Protocol):
    """Where jobs report the bytes of their inputs read: ``(job index, bytes)``,
    ``(job index, None)`` once done. A queue: of this process, or the pool's."""

    def put(self, report: tuple[int, int | None], /) -> None: ...

    def get_nowait(self) -> tuple[int, int | None]: ...


def capture_name(paths: tuple[str, ...]) -> str:
    """The ``capture`` column: the capture's files as given, joined by ``+``."""
    return "+".join(paths)


def cut_mcap(path: str) -> str | None:
    """Why an MCAP file is not whole (None: it ends with the format's footer magic).
    A recording cut short still decodes up to its cut, but an archive would keep
    a part of a capture as if it were all of it."""
    try:
        with open(path, "rb") as f:
            if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                return None   # no MCAP: the capture's own reader says what it is
            f.seek(0, os.SEEK_END)
            if f.tell() < 2 * len(MCAP_MAGIC):
                return f"{show(path)}: cut short (an MCAP file of {counted(f.tell(), 'byte')})"
            f.seek(-len(MCAP_MAGIC), os.SEEK_END)
            if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                return (f"{show(path)}: cut short (no MCAP footer: a killed recording?); "
                        f"'gimbalscope recover {show(path)} -o WHOLE.mcap' rewrites it whole")
    except OSError:
        return None   # the capture's own reader says what is wrong, in its words
    return None


class _Reporter(Listener):
    """Tells the pool's parent how many bytes of its inputs this job has read."""

    def __init__(self, index: int, out: Reports) -> None:
        self.index = index
        self.out = out
        self._next = 0.0

    def on_events(self, events: list[Event]) -> None:
        now = time.monotonic()
        if now >= self._next:
            self._next = now + REPORT_EVERY
            self.out.put((self.index, READS.done()))


_PROGRESS: Reports | None = None   # the pool's progress queue, in a worker process


def _init_worker(progress: Reports) -> None:
    global _PROGRESS
    _PROGRESS = progress


class _Destination(Protocol):
    """Where a job's rows go: the dataset folder, or the job's part of a file output."""

    reads_columns: bool   # a recording's stored columns can stand for decoding it (``from_columns``)

    @property
    def writer(self) -> Listener:
        """What listens to the capture's events as it is decoded."""
        ...

    @property
    def warnings(self) -> list[str]:
        """What the writer says beside its rows (a marks sidecar that does not read)."""
        ...

    def from_columns(self, capture: Capture, info: CaptureInfo, out: Outcome) -> bool:
        """Rows made from the recording's stored columns, kept: True; False: it is
        to be decoded, to a writer made afresh."""
        ...

    def keep(self, out: Outcome) -> None:
        """The rows written are kept, counted in ``out.rows``."""
        ...

    def discard(self) -> None:
        """Drop what the job wrote."""
        ...


class _DatasetFiles:
    """The capture's files in the dataset folder, made new beside its old ones
    (``ParquetDatasetWriter``); kept, they take their place."""

    reads_columns = True

    def __init__(self, job: Job, info: CaptureInfo, site: str | None) -> None:
        self.job, self.info, self.site = job, info, site
        self.writer = self._new()

    def _new(self) -> ParquetDatasetWriter:
        # pyarrow (the fleet extra) only for a dataset: a pcapng file needs the base install alone
        from ..writers.parquet import ParquetDatasetWriter, capture_key
        job = self.job
        return ParquetDatasetWriter(job.root, self.info, capture=capture_name(job.paths), site=self.site,
                                    key=capture_key(job.paths))

    def from_columns(self, capture: Capture, info: CaptureInfo, out: Outcome) -> bool:
        from .export_stored import Undecodable, export_stored

        try:
            done = export_stored(capture, info, self.writer, out.capture)
        except Undecodable as e:   # the writer aborted
            if e.why:
                out.warnings.append(e.why)
            self.writer = self._new()
            return False
        out.events = done.events
        out.warnings += done.warnings + self.warnings
        self.keep(out)
        return True

    @property
    def warnings(self) -> list[str]:
        return self.writer.warnings

    def keep(self, out: Outcome) -> None:
        self.writer.commit()
        out.rows = dict(self.writer.rows)

    def discard(self) -> None:
        self.writer.abort()


class _FilePart:
    """The job's part of a file output (``job.file``: a file of its own, which
    ``export`` joins with the others in the inputs' order; a pcapng file may
    hold several sections one after the other)."""

    reads_columns = False

    def __init__(self, job: Job, info: CaptureInfo) -> None:
        from ..writers import open_writer
        assert job.file is not None
        self.part = job.file
        self.writer: FileWriter = open_writer(job.file, info, capture=job.index)   # the part has the output's suffix

    def from_columns(self, capture: Capture, info: CaptureInfo, out: Outcome) -> bool:
        return False

    @property
    def warnings(self) -> list[str]:
        return []

    def keep(self, out: Outcome) -> None:
        out.rows = {self.writer.noun: self.writer.count}

    def discard(self) -> None:
        self.writer.on_stop()
        try:
            os.unlink(self.part)
        except OSError:
            pass


def _destination(job: Job, info: CaptureInfo, site: str | None) -> _Destination:
    return _FilePart(job, info) if job.file is not None else _DatasetFiles(job, info, site)


def run_job(job: Job, progress: Reports | None = None) -> Outcome:
    """Export one capture (in a worker process, a Spark executor, or this one)."""
    progress = progress if progress is not None else _PROGRESS
    started = time.monotonic()
    out = Outcome(job.index, capture_name(job.paths))
    READS.clear()
    try:
        with staged(job.paths) as local:
            _export(job, local, out, progress)
    except CaptureError as e:   # a remote input that could not be fetched
        out.error = str(e)
    finally:
        if progress is not None:
            progress.put((job.index, None))   # done: all of it counts as read
        out.seconds = time.monotonic() - started
    return out


def _export(job: Job, local: tuple[str, ...], out: Outcome, progress: Reports | None) -> None:
    name = out.capture
    for path in local:
        if path.lower().endswith(".mcap"):
            why = cut_mcap(path)
            if why:
                out.error = why
                return
    destination: _Destination | None = None
    try:
        capture = open_capture(*local, options=job.options)
        site = job.site
        if site is None:
            site = (capture.source.metadata or {}).get("site") or None
        info = CaptureInfo.of(capture, command="export", site=site)
        destination = _destination(job, info, site)
        if destination.reads_columns:
            try:
                if destination.from_columns(capture, info, out):
                    return
            finally:
                capture.source.close()   # its temporary copy (a compressed recording's) goes now, not when collected
            capture = open_capture(*local, options=job.options)   # afresh: the columns were read from it
        check = WiringCheck()   # swapped lines, a wrong rate, not this protocol: said, as decode says them
        listeners: list[Listener] = [check, destination.writer]
        if progress is not None:
            listeners.insert(0, _Reporter(job.index, progress))
        out.events = TapRunner(capture, listeners, info=info).run()
        out.warnings += list(capture.warnings) + [f"{name}: {text}" for text in check.warnings]
        out.warnings += destination.warnings
        cut = next((w for w in capture.warnings if "ends early" in w), None)
        if cut is not None:
            destination.discard()
            out.error = cut
        else:
            destination.keep(out)
    except CaptureError as e:
        if destination is not None:
            destination.discard()
        out.error = str(e)
    except OSError as e:   # the dataset folder: full, read-only
        if destination is not None:
            destination.discard()
        out.error = f"{show(e.filename or job.root)}: {e.strerror or e}"
    except BaseException:
        if destination is not None:
            destination.discard()
        raise


@contextlib.contextmanager
def staged(paths: tuple[str, ...]) -> Iterator[tuple[str, ...]]:
    """The capture's files as local paths: a ``file://`` URI's path, and a remote
    URI's file copied into a temporary folder (the readers read local files; an
    executor has no other copy), removed after."""
    here = tuple(p for p in map(uris.local_path, paths) if p is not None)
    if len(here) == len(paths):   # none remote
        yield here
        return
    import shutil
    import tempfile
    folder = tempfile.mkdtemp(prefix="gimbalscope-input-")
    try:
        local: list[str] = []
        for i, path in enumerate(paths):
            on_disk = uris.local_path(path)
            if on_disk is not None:
                local.append(on_disk)
                continue
            # its own name (the readers know some kinds by it: .gz, .zst), in a folder of its own
            target = os.path.join(folder, str(i), path.rstrip("/").rsplit("/", 1)[-1] or "capture")
            os.makedirs(os.path.dirname(target))
            try:
                filesystem, where = uris.arrow_filesystem(path)
                with filesystem.open_input_stream(where) as src, open(target, "wb") as dst:
                    shutil.copyfileobj(src, dst, 1 << 20)
                # a raw dump is dated by its file's time (docs/dataset.md, "Layout"): the object's, not the copy's
                mtime = filesystem.get_file_info(where).mtime
                if mtime is not None:
                    os.utime(target, (mtime.timestamp(), mtime.timestamp()))
            except (OSError, ValueError) as e:
                raise CaptureError(f"{path}: cannot read it: {uris.failure(e)}") from None
            local.append(target)
        yield tuple(local)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def input_size(job: Job) -> int:
    """Bytes of a job's input files (0 when a file is remote or missing: the job says)."""
    try:
        return sum(os.path.getsize(uris.local_path(p) or "") for p in job.paths)
    except OSError:
        return 0


def make_dataset_folder(root: str) -> None:
    """The local dataset folder ``root`` made if absent, or one line saying why not."""
    local = uris.local_path(root)
    assert local is not None, root   # a remote folder is Spark's (spark/export.py, check_output)
    try:
        os.makedirs(local, exist_ok=True)
    except OSError as e:
        raise OutputRefused(f"{show(root)}: cannot make the dataset folder: {e.strerror or e}") from None


class PoolMeter:
    """Bytes read of every job's inputs, from the jobs' reports (the progress
    bar's meter, analyzer/listeners/progress.py)."""

    def __init__(self, jobs: list[Job], reports: Reports) -> None:
        self.sizes = {job.index: input_size(job) for job in jobs}
        self.read = {job.index: 0 for job in jobs}
        self.reports = reports

    def total(self) -> int | None:
        return sum(self.sizes.values()) or None

    def done(self) -> int:
        while True:
            try:
                index, n = self.reports.get_nowait()
            except (queue.Empty, OSError, ValueError, EOFError):
                break
            size = self.sizes.get(index, 0)
            self.read[index] = size if n is None else min(n, size)
        return sum(self.read.values())


def export(jobs: list[Job], workers: int, *, show_progress: bool = False,
           on_done: Callable[[Outcome], None] | None = None) -> list[Outcome]:
    """Run every job, ``workers`` at a time; ``on_done(outcome)`` as each ends.
    The outcomes in the jobs' order."""
    from ..listeners.progress import ReadProgress

    outcomes: dict[int, Outcome] = {}
    if workers <= 1 or len(jobs) <= 1:
        here: queue.Queue[tuple[int, int | None]] = queue.Queue()
        with ReadProgress(enabled=show_progress, meter=PoolMeter(jobs, here), label="exporting"):
            for job in jobs:
                outcome = outcomes[job.index] = run_job(job, here)
                if on_done is not None:
                    on_done(outcome)
        return [outcomes[job.index] for job in jobs]

    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    # spawn: a fresh interpreter per worker (fork would copy the progress bar's thread)
    ctx = multiprocessing.get_context("spawn")
    reports = ctx.Queue()
    pool = ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=ctx,
                               initializer=_init_worker, initargs=(reports,))
    try:
        with ReadProgress(enabled=show_progress, meter=PoolMeter(jobs, reports), label="exporting"):
            futures = [pool.submit(run_job, job) for job in jobs]
            for future in as_completed(futures):
                outcome = future.result()
                outcomes[outcome.index] = outcome
                if on_done is not None:
                    on_done(outcome)
    except BaseException:
        # Ctrl-C reached the workers too (one process group): each drops its new files
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return [outcomes[job.index] for job in jobs]
