"""``gimbalscope export``: captures into a Parquet dataset folder, for fleet
analytics (docs/dataset.md): tables ``events`` (the event contract of
docs/json-lines.md with one column per field of the command table, Tables 4-18),
``transactions`` (a command and its answers, spec §1.4.2-1.4.3) and ``findings``
(the wiring doctor's), partitioned by date, Hive style. ``query`` and
``report`` read it; so do DuckDB, Polars and Spark as it is.

Each INPUT is one capture, exported by its own job in a pool of processes
(``-j``), or by the executors of a Spark cluster (``--spark MASTER``:
analyzer/dataset/spark; docs/spark.md), which write the same dataset. The files
of one capture (two raw dumps, line A and line B; the parts of one recording)
are one INPUT joined by ``+``: ``ctl.bin+dev.bin``. A folder, or a quoted
pattern, is the captures in it (analyzer/dataset/inputs.py).
Exporting a capture again replaces its own files and nothing else. An input
that cannot be read, or a recording cut short, is said and skipped; the others
are exported, and the command exits 1, listing the skipped ones.

``-o FILE.pcapng`` writes the captures into one pcapng file for Wireshark
instead (docs/wireshark.md; the writer registry, analyzer/writers): each job
writes its capture as a pcapng section of its own, and the sections are joined
in the inputs' order once all are done, so a skipped capture leaves nothing
behind and the file appears only when whole.
"""

from __future__ import annotations

import argparse
import os
import sys

from ..dataset.export import Job, Outcome, export, make_dataset_folder
from ..listeners.printer import NotePrinter
from ..outfile import OutputRefused, show
from ..runner import ERROR, WARNING, Note
from ..sources import registry
from ..words import counted
from ..writers import WRITERS, file_output, folder_output, holds_many_captures
from . import common
from .common import Subcommands, UsageError, add_quiet_arg, add_serial_args, options_from, positive_int


def register(sub: Subcommands) -> None:
    p = sub.add_parser("export", help="export captures as a Parquet dataset (query, report, DuckDB, Spark) "
                                      "or as pcapng (Wireshark)",
                       description="Export captures into a dataset folder of Parquet tables (events, "
                                   "transactions, findings), partitioned by date (docs/dataset.md), or into one "
                                   "pcapng file for Wireshark (-o FILE.pcapng; docs/wireshark.md). Each INPUT "
                                   "is one capture; join the files of one capture with '+' (ctl.bin+dev.bin).")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="a capture file, FILE+FILE (two raw dumps of lines A and B, or the parts of one "
                        "recording), a folder of captures, or a quoted pattern; with --spark also a URI (file://, "
                        f"hdfs://, s3a://). The captures read: {registry.input_kinds()}")
    p.add_argument("-o", "--output", required=True, metavar="DIR|FILE.pcapng",
                   help="the dataset folder (made if absent), or one pcapng file for Wireshark; "
                        "with --spark also a URI (file://, hdfs://, s3a://)")
    p.add_argument("--spark", metavar="MASTER",
                   help="decode on Spark: local[N], spark://HOST:PORT, yarn, k8s://… (the spark extra; "
                        "docs/spark.md). The dataset is the one the local export writes")
    p.add_argument("--force", action="store_true", help="with a file output: replace it if it exists")
    p.add_argument("-j", "--jobs", type=positive_int, default=os.cpu_count() or 1, metavar="N",
                   help="captures exported at once, each in a process of its own (default: %(default)s, "
                        "the number of cores)")
    p.add_argument("--separate", action="store_true",
                   help="the inputs are separate captures, even where two raw dumps look like one capture's "
                        "two lines (which export otherwise refuses: join them with '+')")
    p.add_argument("--site", metavar="NAME",
                   help="the site column of every row (default: the site a recording names, else empty)")
    add_quiet_arg(p)
    add_serial_args(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from .. import uris
    from ..dataset.inputs import captures_of

    local_output = uris.local_path(args.output)
    remote_output = local_output is None
    if (remote_output or any(uris.is_remote(i) for i in args.inputs)) and not args.spark:
        raise UsageError("URIs (hdfs://, s3a://) are for --spark; a local export reads and writes local paths")
    to_file = local_output is not None and file_output(local_output)
    root = args.output if to_file or remote_output else folder_output(args.output)
    options = options_from(args)
    jobs = [Job(i, paths, root, options, site=args.site) for i, paths in enumerate(captures_of(args.inputs))]
    if not args.separate:
        from ..dataset.lines_apart import lines_of_one_capture
        local = [tuple(uris.local_path(p) or p for p in job.paths) for job in jobs]
        joined = lines_of_one_capture(local, options)
        if joined is not None:
            raise UsageError(joined)
    if to_file:
        if args.spark:
            raise UsageError("--spark writes a dataset folder; a pcapng file is written here: leave out --spark")
        return run_to_file(args, jobs)
    if args.spark:
        from ..dataset.spark.export import run_on_spark
        notes = OutcomeNotes()
        outcomes = run_on_spark(args.spark, jobs, on_done=notes, show_progress=_progress_wanted())
        notes.close()
    else:
        make_dataset_folder(root)
        outcomes = run_jobs(args, jobs)
    exported = [o for o in outcomes if o.error is None]
    events = sum(o.rows.get("events", 0) for o in exported)
    txns = sum(o.rows.get("transactions", 0) for o in exported)
    findings = sum(o.rows.get("findings", 0) for o in exported)
    marks = sum(o.rows.get("marks", 0) for o in exported)
    print(f"gimbalscope: exported {len(exported)} of {counted(len(outcomes), 'capture')} to {show(root)}: "
          f"{counted(events, 'event')}, {counted(txns, 'transaction')}, {counted(findings, 'finding')}"
          + (f", {counted(marks, 'mark')}" if marks else ""), file=sys.stderr)
    return said_skipped(outcomes)


def run_to_file(args: argparse.Namespace, jobs: list[Job]) -> int:
    """The captures into one file of a registry format that holds several (pcapng)."""
    import shutil
    import tempfile

    from ..outfile import AtomicOutput, check_output, write_error

    path = args.output
    if not holds_many_captures(path):
        suffix = os.path.splitext(path)[1].lower()
        many = ", ".join(s for s in WRITERS if holds_many_captures(s))
        raise OutputRefused(f"{show(path)}: export writes a dataset folder or a {many} file; for one {suffix} "
                            f"file use: gimbalscope convert CAPTURE -o {show(path)}")
    check_output(path, [p for job in jobs for p in job.paths], force=args.force)
    parts = tempfile.mkdtemp(prefix=".gimbalscope-export-", dir=os.path.dirname(os.path.abspath(path)))
    try:
        part_of = {job.index: os.path.join(parts, f"{job.index}{os.path.splitext(path)[1]}") for job in jobs}
        for job in jobs:
            job.file = part_of[job.index]
        outcomes = run_jobs(args, jobs)
        exported = [o for o in outcomes if o.error is None]
        if exported:   # nothing read, no file: an empty one would not open
            with AtomicOutput(path) as target:
                try:
                    for job in jobs:
                        if outcomes[job.index].error is None:
                            with open(part_of[job.index], "rb") as part:
                                shutil.copyfileobj(part, target.file, 1 << 20)
                except OSError as e:
                    raise write_error(path, e) from None
    finally:
        shutil.rmtree(parts, ignore_errors=True)
    packets = sum(o.rows.get("packets", 0) for o in exported)
    print(f"gimbalscope: exported {len(exported)} of {counted(len(outcomes), 'capture')} to {show(path)}: "
          f"{counted(packets, 'packet')}", file=sys.stderr)
    return said_skipped(outcomes)


def run_jobs(args: argparse.Namespace, jobs: list[Job]) -> list[Outcome]:
    notes = OutcomeNotes()
    outcomes = export(jobs, args.jobs, show_progress=_progress_wanted(), on_done=notes)
    notes.close()
    return outcomes


def _progress_wanted() -> bool:
    from ..listeners.progress import wanted
    return wanted()


class OutcomeNotes:
    """What each capture's outcome says, as it ends: its warnings, and why it was
    skipped; ``close()`` sums up warnings said too often."""

    def __init__(self) -> None:
        self.notes = NotePrinter(findings=False, quiet=common.quiet())

    def __call__(self, outcome: Outcome) -> None:
        for text in outcome.warnings:
            self.notes.on_note(Note(text, WARNING))
        if outcome.error is not None:
            self.notes.on_note(Note(f"skipped {outcome.error}", ERROR))   # said even with -q

    def close(self) -> None:
        self.notes.on_stop()


def said_skipped(outcomes: list[Outcome]) -> int:
    """Lists the skipped captures: the exit status."""
    skipped = [o for o in outcomes if o.error is not None]
    if skipped:
        print(f"gimbalscope: skipped {len(skipped)}: " + ", ".join(show(o.capture) for o in skipped),
              file=sys.stderr)
        return 1
    return 0
