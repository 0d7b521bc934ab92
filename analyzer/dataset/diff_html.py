"""``gimbalscope diff --html FILE``: the comparison of two captures as one
self-contained HTML page, styled as the fleet report's (report_html.py): the
changes called, worse first, every other figure below them, then the
transactions that differ as a unified listing. No script, no style sheet, font
or image from elsewhere; every text from the captures is escaped."""

from __future__ import annotations

import html
from collections.abc import Sequence
from typing import Any

from ..analysis.compare import BETTER, SAME, WORSE, Change, reading_order
from .report_html import CSS

_EXTRA_CSS = """
.better { color: #1b5e20; font-weight: bold; }
.same { color: #555; }
pre { font-size: 0.85em; background: #f7f7f7; padding: 0.6em; overflow-x: auto; }
.add { color: #1b5e20; background: #e8f5e9; } .del { color: #b00020; background: #fdecea; }
.hunk { color: #555; }
"""
_CLASS = {WORSE: "worse", BETTER: "better", SAME: "same"}


def _value(c: Change, x: float | None) -> str:
    if x is None:
        return "none"
    return f"{x * 1000:.1f} ms" if c.latency else f"{x * 100:.1f} %"


def _row(c: Change) -> str:
    where = "all" if c.scope == "capture" else f"{c.scope} {c.key}"
    if c.latency:
        counts = f"p95 {_value(c, c.p95[0])} → {_value(c, c.p95[1])}"
    else:
        k1, n1, k2, n2 = c.counts
        counts = f"{k1:,}/{n1:,} → {k2:,}/{n2:,}"
    p = "" if c.p is None else ("&lt; 0.001" if c.p < 0.001 else f"{c.p:.3f}")
    cells = [html.escape(where), html.escape(c.figure), _value(c, c.before), _value(c, c.after), counts, p]
    return ("<tr>" + "".join(f"<td>{cell}</td>" for cell in cells)
            + f'<td class="{_CLASS[c.verdict]}">{html.escape(c.verdict)}</td></tr>')


def _listing(lines: Sequence[str]) -> str:
    out = []
    for line in lines:
        text = html.escape(line)
        if line.startswith("@@"):
            out.append(f'<span class="hunk">{text}</span>')
        elif line.startswith("+") and not line.startswith("+++"):
            out.append(f'<span class="add">{text}</span>')
        elif line.startswith("-") and not line.startswith("---"):
            out.append(f'<span class="del">{text}</span>')
        else:
            out.append(text)
    return "<pre>" + "\n".join(out) + "</pre>"


def render(before: dict[str, Any], after: dict[str, Any], changes: Sequence[Change], listing: Sequence[str]) -> str:
    """The page: ``before`` and ``after`` name each capture and its size
    (``capture``, ``events``, ``commands``), ``changes`` every figure compared,
    ``listing`` the unified listing of the transactions (none: the same)."""
    rows = reading_order(changes)
    worse = sum(c.verdict == WORSE for c in changes)
    better = sum(c.verdict == BETTER for c in changes)
    verdict = (f'<p class="worse">{worse} got worse</p>' if worse else '<p class="ok">nothing got worse</p>')
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        "<title>gimbalscope diff</title>", f"<style>{CSS}{_EXTRA_CSS}</style></head><body>",
        "<h1>gimbalscope diff</h1>",
        "<table><tr><th></th><th>capture</th><th>commands</th><th>events</th></tr>",
        *(f"<tr><td>{label}</td><td>{html.escape(str(side['capture']))}</td><td>{side['commands']:,}</td>"
          f"<td>{side['events']:,}</td></tr>" for label, side in (("before", before), ("after", after))),
        "</table>", verdict, (f"<p>{better} got better; every change is tested against chance, all tests of the "
        "comparison held to 5 % together (docs/diff.md).</p>"),
        "<h2>Figures</h2>",
        ("<table><tr><th>where</th><th>figure</th><th>before</th><th>after</th><th>counts</th><th>p</th>"
        "<th>verdict</th></tr>"), *(_row(c) for c in rows), "</table>",
        "<h2>Transactions</h2>",
        _listing(listing) if listing else "<p>the same, command for command</p>",
        "</body></html>",
    ]
    return "\n".join(parts) + "\n"
