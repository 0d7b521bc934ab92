"""``gimbalscope report DIR``: each device of an exported dataset over time
(docs/dataset.md): commands, error and NAK rates, ACK and result latency
percentiles per day or week (statuses per spec §1.4.2-1.4.3), the devices
trending worse (analyzer/dataset/report.py), and the wiring doctor's findings
per capture. Text on the terminal, ``--format json``, and ``--html FILE``: one
self-contained page with trend charts."""

from __future__ import annotations

import argparse
import os
import sys

from ..outfile import AtomicOutput, check_output, show
from ..output import dumps
from .common import positive_int


def register(sub: argparse._SubParsersAction) -> None:
    from ..dataset.report import MIN_COMMANDS
    p = sub.add_parser("report", help="each device over time, and which are trending worse",
                       description="Per device and day (or week): commands, error and NAK rates, ACK and result "
                                   "latency; devices whose latency or error rate is trending worse; the wiring "
                                   "doctor's findings per capture. Reads a dataset made by 'gimbalscope export'.")
    p.add_argument("dataset", metavar="DIR", help="the dataset folder")
    p.add_argument("--period", choices=("day", "week"), default="day")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--html", metavar="FILE", help="also write one self-contained HTML page with trend charts")
    p.add_argument("--force", action="store_true", help="overwrite the --html FILE if it exists")
    p.add_argument("--min-commands", type=positive_int, default=MIN_COMMANDS, metavar="N",
                   help="a period counts toward a trend only with N commands (default %(default)s)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..dataset.query import connect
    from ..dataset.report import build, to_dict

    if args.html:
        check_output(args.html, force=args.force)   # before the work: a bad path costs nothing
    report = build(connect(args.dataset), args.period, min_commands=args.min_commands)
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


def _ms(v) -> str:
    return "" if v is None else f"{v * 1000:.1f}"


def render_text(report) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console(highlight=False, width=None if sys.stdout.isatty() else 150)
    if not report.devices:
        console.print("no transactions in this dataset")
    worse = report.worse
    if worse:
        console.print(f"[bold red]{len(worse)} trending worse:[/]")
        for d in worse:
            console.print(f"  [red]{d.device}[/]: " + "; ".join(t.text() for t in d.worse), markup=True)
    elif report.devices:
        console.print("no device is trending worse")
    for d in report.devices:
        title = f"{d.device}" + ("  [red]trending worse[/]" if d.worse else "")
        table = Table(title=title, title_justify="left")
        for col in (report.period, "commands", "ok", "nak", "nic", "no_ack", "no_res", "errors", "NAKs",
                    "ACK p50 ms", "p95", "result p50 ms", "p95"):
            table.add_column(col, justify="left" if col == report.period else "right")
        for p in d.periods:
            table.add_row(p.start.isoformat(), str(p.commands),
                          *(str(p.statuses.get(s, 0)) for s in ("ok", "nak", "nic", "no_ack", "no_result")),
                          f"{p.error_rate:.1%}", f"{p.nak_rate:.1%}", _ms(p.ack_p50), _ms(p.ack_p95),
                          _ms(p.result_p50), _ms(p.result_p95))
        console.print(table)
    if report.captures:
        console.print("[bold]wiring doctor, per capture[/]")
        for c in report.captures:
            when = c.start.isoformat() if c.start is not None else "no time"
            console.print(f"  {c.capture} ({when}" + (f", site {c.site}" if c.site else "") + ")", markup=False)
            for f in c.findings:
                console.print(f"    {f.severity}: {f.title}" + (f" ({f.subject})" if f.subject else ""), markup=False)
