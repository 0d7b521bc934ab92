"""The fleet report as one self-contained HTML page (``report --html``): the
devices trending worse first, then each device's periods as a table and its
p95 ACK latency and error rate as inline SVG charts (matplotlib), then the
doctor's findings per capture. No script, no style sheet, font or image from
elsewhere: the page opens anywhere, mailed or archived. Every text from the
data is escaped."""

from __future__ import annotations

import datetime as dt
import html
import io
import re
from typing import TYPE_CHECKING

from ..words import counted
from .report import PERIOD_COLUMNS, DeviceReport, Report, period_cells

if TYPE_CHECKING:   # matplotlib is imported only for a page
    from matplotlib.figure import Figure

# the page's style, shared by the diff page (diff_html.py)
CSS = """
body { font-family: system-ui, sans-serif; margin: 2em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.2em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; white-space: nowrap; }
.worse { color: #b00020; font-weight: bold; }
.ok { color: #1b5e20; }
.charts { display: flex; flex-wrap: wrap; gap: 1em; }
.error { color: #b00020; } .warning { color: #9a6700; } .info { color: #555; }
"""


def _svg(fig: Figure) -> str:
    """A figure as SVG markup to put inline: without the XML prologue, the DOCTYPE
    (a URL a browser never fetches, but a page needs none) and the metadata block."""
    buf = io.StringIO()
    fig.savefig(buf, format="svg", bbox_inches="tight", metadata={"Date": None})
    text = buf.getvalue()
    text = re.sub(r"<\?xml[^>]*\?>\s*", "", text)
    text = re.sub(r"<!DOCTYPE[^>]*>\s*", "", text)
    text = re.sub(r"<metadata>.*?</metadata>\s*", "", text, flags=re.DOTALL)
    return text


def _charts(device: DeviceReport) -> str:
    import matplotlib
    matplotlib.use("Agg")   # no display: the figures only become SVG text
    import matplotlib.dates as mdates
    import matplotlib.pyplot as plt

    matplotlib.rcParams["svg.fonttype"] = "none"    # text stays text: smaller, selectable
    matplotlib.rcParams["svg.hashsalt"] = "gimbalscope"   # the same page for the same data
    days = [p.start for p in device.periods]
    out = []
    for title, values, unit in (
            ("p95 ACK latency", [None if p.ack_p95 is None else p.ack_p95 * 1000 for p in device.periods], "ms"),
            ("error rate", [p.error_rate * 100 for p in device.periods], "%")):
        fig, ax = plt.subplots(figsize=(4.2, 2.4), dpi=96)
        xs = [d for d, v in zip(days, values) if v is not None]
        ys = [v for v in values if v is not None]
        ax.set_title(f"{device.device}: {title}", fontsize=9)
        ax.tick_params(labelsize=7)
        if xs:
            # dates: matplotlib plots them through its date converter, though its hints name only numbers
            ax.plot(xs, ys, marker="o", color="#b00020" if device.worse else "#1f5f9f")   # type: ignore[arg-type]
            # a day either side: one or two points still sit inside a readable axis
            ax.set_xlim(min(xs) - dt.timedelta(days=1), max(xs) + dt.timedelta(days=1))   # type: ignore[arg-type]
            locator = mdates.AutoDateLocator(maxticks=6)
            ax.xaxis.set_major_locator(locator)
            ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))
            ax.set_ylabel(unit, fontsize=8)
            ax.set_ylim(bottom=0, top=max(ys) * 1.15 or 1)
        else:
            ax.text(0.5, 0.5, "no values (a capture without time has no latency)", ha="center", va="center",
                    fontsize=8, transform=ax.transAxes)
            ax.set_xticks([])
            ax.set_yticks([])
        out.append(_svg(fig))
        plt.close(fig)
    return '<div class="charts">' + "".join(out) + "</div>"


def _device(d: DeviceReport, period: str) -> str:
    e = html.escape
    head = f'<h2 id="dev-{e(d.device)}">{e(d.device)}'
    if d.worse:
        head += ' <span class="worse">trending worse</span>'
    head += "</h2>"
    trend = "".join(f'<p class="worse">{e(t.text())}</p>' for t in d.worse)
    # the columns and cells of the text report (report.PERIOD_COLUMNS)
    names = "".join(f"<th>{e(name)}</th>" for name in (period, *(n for group in PERIOD_COLUMNS for n in group)))
    rows = "".join(f"<tr><td>{p.start.isoformat()}</td>" + "".join(f"<td>{e(c)}</td>" for c in period_cells(p))
                   + "</tr>" for p in d.periods)
    table = f"<table><tr>{names}</tr>{rows}</table>"
    return head + trend + table + _charts(d)


def render(report: Report, title: str) -> str:
    e = html.escape
    worse = report.worse
    if worse:
        summary = ("<ul>" + "".join(f'<li><a href="#dev-{e(d.device)}" class="worse">{e(d.device)}</a>: '
                                    + "; ".join(e(t.text()) for t in d.worse) + "</li>" for d in worse) + "</ul>")
    else:
        summary = '<p class="ok">No device is trending worse.</p>'
    findings = []
    for c in report.captures:
        when = c.start.isoformat() if c.start is not None else "no time"
        items = "".join(f'<li class="{e(f.severity)}">{e(f.severity)}: {e(f.title)}'
                        + (f" ({e(f.subject)})" if f.subject else "") + f" <code>{e(f.code)}</code></li>"
                        for f in c.findings)
        site = f", site {e(c.site)}" if c.site else ""
        findings.append(f"<h3>{e(c.capture)} <small>({e(when)}{site})</small></h3><ul>{items}</ul>")
    commands = sum(d.commands for d in report.devices)
    body = (f"<h1>{e(title)}</h1>"
            f"<p>{counted(len(report.devices), 'device')}, {counted(commands, 'command')}, per {e(report.period)}.</p>"
            f"<h2>Trending worse</h2>{summary}"
            + "".join(_device(d, report.period) for d in report.devices)
            + "<h2>Wiring doctor, per capture</h2>" + ("".join(findings) or "<p>No findings.</p>"))
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{e(title)}</title>'
            f"<style>{CSS}</style></head><body>{body}</body></html>\n")
