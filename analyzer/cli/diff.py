"""``gimbalscope diff BEFORE AFTER``: is it better? Two captures compared per
device and per command (analysis/compare.py: rates with a test of chance,
latencies), then the transactions that differ, aligned by their sequence of
commands, as a unified listing. Exit 0 when nothing got worse, 1 when something
did (docs/diff.md)."""

from __future__ import annotations

import argparse
import difflib
import sys
from typing import Any

from ..analysis.compare import BETTER, SAME, Change, compare, reading_order, worse
from ..capture import open as open_capture
from ..dataset.inputs import split_input
from ..listeners import StatsListener
from ..listeners.exchanges import Exchanges
from ..outfile import AtomicOutput, check_output, show
from ..output import dumps
from .common import Subcommands, add_quiet_arg, add_serial_args, non_negative_int, options_from, run_tap

EXIT_WORSE = 1


def register(sub: Subcommands) -> None:
    p = sub.add_parser("diff", help="compare two captures: what got better, what got worse",
                       description="Compare two captures per device and per command (error rates with a test "
                                   "of chance, latencies), then list the transactions that differ, aligned by "
                                   "their sequence of commands. Exit 1 when something got worse.")
    p.add_argument("before", metavar="BEFORE", help="the capture before the change (A+B: two files of one capture)")
    p.add_argument("after", metavar="AFTER", help="the capture after it")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--context", type=non_negative_int, default=2, metavar="N",
                   help="transactions shown around each difference (default 2)")
    p.add_argument("--lines", type=non_negative_int, default=60, metavar="N",
                   help="lines of the transaction listing shown at most (default 60; 0: all)")
    p.add_argument("--all", action="store_true", help="also list figures that did not clearly change")
    p.add_argument("--html", metavar="FILE", help="also write the comparison as one self-contained HTML page")
    p.add_argument("--force", action="store_true", help="overwrite the --html FILE if it exists")
    add_quiet_arg(p)
    add_serial_args(p)
    p.set_defaults(run=run)


def _read(spec: str, args: argparse.Namespace) -> tuple[dict[str, Any], Exchanges]:
    capture = open_capture(*split_input(spec), options=options_from(args))
    counter, exchanges = StatsListener(), Exchanges()
    # check: a capture that is not this protocol, or swapped lines, is said as stats says it
    run_tap(capture, "diff", counter, exchanges, progress=True, check=True)
    return counter.stats.to_dict(), exchanges


def run(args: argparse.Namespace) -> int:
    if args.html:
        check_output(args.html, force=args.force)   # before the work: a bad path costs nothing
    before, old = _read(args.before, args)
    after, new = _read(args.after, args)
    changes = compare(before, after, old.latencies, new.latencies)
    listing = list(difflib.unified_diff(old.lines, new.lines, fromfile=args.before, tofile=args.after,
                                        n=args.context, lineterm=""))
    bad = worse(changes)
    if args.format == "json":
        data = {"before": _summary(args.before, before), "after": _summary(args.after, after),
                "changes": [c.to_dict() for c in changes], "worse": len(bad),
                "better": sum(c.verdict == BETTER for c in changes),
                "transactions": {"before": len(old.lines), "after": len(new.lines), "unified": listing}}
        sys.stdout.buffer.write(dumps(data) + b"\n")
    else:
        _print_text(args, changes, listing, before, after)
    if args.html:
        from ..dataset.diff_html import render

        with AtomicOutput(args.html) as out:
            out.write(render(_summary(args.before, before), _summary(args.after, after), changes,
                             listing).encode("utf-8"))
        print(f"gimbalscope: comparison written to {show(args.html)}", file=sys.stderr)
    return EXIT_WORSE if bad else 0


def _summary(name: str, stats: dict[str, Any]) -> dict[str, Any]:
    return {"capture": name, "events": stats["events"], "commands": stats["commands"],
            "duration": stats["duration"]}


# ------------------------------------------------------------------ text
def _print_text(args: argparse.Namespace, changes: list[Change], listing: list[str],
                before: dict[str, Any], after: dict[str, Any]) -> None:
    out = sys.stdout
    for label, name, stats in (("before:", args.before, before), ("after: ", args.after, after)):
        out.write(_named(f"{label} {stats['commands']:,} commands, {stats['events']:,} events: ", name) + "\n")
    out.write("\n")
    called = [c for c in changes if c.verdict != SAME]
    shown = changes if args.all else called
    for c in reading_order(shown):
        out.write(_line(c) + "\n")
    if not called:
        out.write("no figure changed by more than chance\n")
    unchanged = len(changes) - len(called)
    if unchanged and not args.all:
        out.write(f"({unchanged:,} other figures without a clear change: --all lists them)\n")
    out.write("\n")
    if not listing:
        out.write("the transactions are the same, command for command\n")
        return
    body = listing[2:]   # the ---/+++ header names the captures, said above
    added = sum(1 for line in body if line.startswith("+"))
    removed = sum(1 for line in body if line.startswith("-"))
    out.write(f"transactions: {removed:,} only before, {added:,} only after, aligned by command\n"
              "sequence (a unified listing: @@ numbers are transaction numbers)\n")
    limit = args.lines if args.lines > 0 else len(listing)
    for line in listing[:limit]:
        out.write(_fit(line) + "\n")
    if len(listing) > limit:
        out.write(f"... {len(listing) - limit:,} more lines (--lines 0 shows all)\n")


def _line(c: Change) -> str:
    """``1.1.12: NAKs 4.1 % -> 0.2 %, better (p < 0.001)``, within 80 columns."""
    where = "all" if c.scope == "capture" else c.key
    if c.latency:
        text = f"{where}: {c.figure} median {_ms(c.before)} -> {_ms(c.after)}, p95 {_ms(c.p95[0])} -> {_ms(c.p95[1])}"
    else:
        text = f"{where}: {c.figure} {_pct(c.before)} -> {_pct(c.after)}"
        k1, n1, k2, n2 = c.counts
        text += f" ({k1:,}/{n1:,} -> {k2:,}/{n2:,})"
    text += f", {c.verdict}" + (f" ({_p(c.p)})" if c.p is not None else "")
    return _fit(text)


def _named(text: str, name: str, width: int = 80) -> str:
    """``text`` then a capture's name, its start cut when the line would pass ``width``."""
    room = width - len(text)
    return text + (name if len(name) <= room else "..." + name[len(name) - room + 3:])


def _fit(text: str, width: int = 80) -> str:
    return text if len(text) <= width else text[:width - 3] + "..."


def _pct(x: float | None) -> str:
    return "none" if x is None else f"{x * 100:.1f} %"


def _ms(x: float | None) -> str:
    return "none" if x is None else f"{x * 1000:.1f} ms"


def _p(p: float) -> str:
    return "p < 0.001" if p < 0.001 else f"p = {p:.3f}"
