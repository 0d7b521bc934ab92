"""``gimbalscope report DIR``: each device of an exported dataset over time
(docs/dataset.md): commands, error and NAK rates, ACK and result latency
percentiles per day or week (statuses per spec §1.4.2-1.4.3), the devices
trending worse (analyzer/dataset/report.py), and the wiring doctor's findings
per capture. Text on the terminal, ``--format json``, and ``--html FILE``: one
self-contained page with trend charts. ``--spark MASTER`` computes the figures
with Spark SQL instead of DuckDB (analyzer/dataset/spark/report.py): the same
report, for datasets too big for one machine."""

from __future__ import annotations

import argparse
import os
import sys
from typing import TYPE_CHECKING

from ..outfile import AtomicOutput, check_output, show
from ..output import dumps
from .common import Subcommands, UsageError, positive_int

if TYPE_CHECKING:
    from ..dataset.report import Report


def register(sub: Subcommands) -> None:
    from ..dataset.report import MIN_COMMANDS
    p = sub.add_parser("report", help="each device over time, and which are trending worse",
                       description="Per device and day (or week): commands, error and NAK rates, ACK and result "
                                   "latency; devices whose latency or error rate is trending worse; the wiring "
                                   "doctor's findings per capture. Reads a dataset made by 'gimbalscope export'.")
    p.add_argument("dataset", metavar="DIR", help="the dataset folder (with --spark also a URI: file://, hdfs://, "
                                                  "s3a://)")
    p.add_argument("--period", choices=("day", "week"), default="day")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--html", metavar="FILE", help="also write one self-contained HTML page with trend charts")
    p.add_argument("--force", action="store_true", help="overwrite the --html FILE if it exists")
    p.add_argument("--min-commands", type=positive_int, default=MIN_COMMANDS, metavar="N",
                   help="a period counts toward a trend only with N commands (default %(default)s)")
    p.add_argument("--spark", metavar="MASTER",
                   help="compute the figures with Spark: local[N], spark://HOST:PORT, yarn, k8s://… "
                        "(the spark extra; docs/spark.md)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..dataset.report import to_dict

    if args.html:
        check_output(args.html, force=args.force)   # before the work: a bad path costs nothing
    report = spark_report(args) if args.spark else duckdb_report(args)
    if args.format == "json":
        sys.stdout.buffer.write(dumps(to_dict(report)) + b"\n")
    else:
        render_text(report)
    if args.html:
        from ..dataset.report_html import render
        page = render(report, f"gimbalscope report: {os.path.basename(os.path.abspath(args.dataset))}")
        with AtomicOutput(args.html) as out:
            out.write(page.encode("utf-8"))
        print(f"gimbalscope: report written to {show(args.html)}", file=sys.stderr)
    return 0


def duckdb_report(args: argparse.Namespace) -> Report:
    from .. import uris
    from ..dataset.query import connect
    from ..dataset.report import build
    local = uris.local_path(args.dataset)
    if local is None:
        raise UsageError(f"{args.dataset}: a dataset behind a URI is read with --spark MASTER")
    return build(connect(local), args.period, min_commands=args.min_commands)


def spark_report(args: argparse.Namespace) -> Report:
    from .. import uris
    from ..dataset.query import check_dataset
    from ..dataset.spark.report import build_on_spark
    from ..dataset.spark.session import check, start
    check(args.spark)
    local = uris.local_path(args.dataset)
    if local is not None:
        check_dataset(local)   # before Spark starts: a wrong path costs no JVM
    spark = start(args.spark, "gimbalscope report", checked=True)
    try:
        return build_on_spark(spark, args.dataset, args.period, min_commands=args.min_commands)
    finally:
        spark.stop()


def render_text(report: Report) -> None:
    from rich.console import Console
    from rich.text import Text

    from ..dataset.report import PERIOD_COLUMNS, period_cells
    from ..formats.fit_width import FitLines, FitTable

    # piped, Rich takes the width from COLUMNS, else 80: the text fits it
    console = Console(highlight=False)
    if not report.devices:
        console.print("no transactions in this dataset")
    worse = report.worse
    if worse:
        lines = [Text(f"{len(worse)} trending worse:", style="bold red")]
        lines += [Text.assemble("  ", (d.device, "red"), ": " + "; ".join(t.text() for t in d.worse)) for d in worse]
        console.print(FitLines(*lines))
    elif report.devices:
        console.print("no device is trending worse")
    for d in report.devices:
        title = Text.assemble((d.device, "bold"), ("  trending worse", "red") if d.worse else "")
        console.print(FitTable(report.period, PERIOD_COLUMNS,
                               [[p.start.isoformat(), *period_cells(p)] for p in d.periods], title))
    if report.captures:
        lines = [Text("wiring doctor, per capture", style="bold")]
        for c in report.captures:
            when = c.start.isoformat() if c.start is not None else "no time"
            lines.append(Text(f"  {c.capture} ({when}" + (f", site {c.site}" if c.site else "") + ")"))
            lines += [Text(f"    {f.severity}: {f.title}" + (f" ({f.subject})" if f.subject else ""))
                      for f in c.findings]
        console.print(FitLines(*lines))
