"""The statistics screen (``S``): the summary and the per-command and per-device
tables of ``gimbalscope stats``, in its words, the ACK latency histogram, and the
device map, redrawn when the capture has changed, at most once a second. With a filter, the figures are those of the
rows it shows (computed from the store's columns: analyzer/formats/store_stats.py)."""

from __future__ import annotations

import math

from rich.table import Table
from rich.text import Text
from textual.app import ComposeResult
from textual.containers import VerticalScroll
from textual.widgets import Footer, Static

from ...analysis.stats import bucket_middle
from ...listeners.stats import counts_table, summary
from ...output import fmt_seconds
from ...words import counted
from ..model import CaptureModel
from .back import BACK
from .redraw import Redrawn


def histogram(model: CaptureModel, width: int = 50) -> Text:
    """ACK latency over all commands, in log-spaced bins (factor 2)."""
    bins: dict[int, int] = {}
    zero = 0
    for c in model.totals.stats.by_command.values():
        lat = c.ack_latency
        zero += lat.zero
        for b, n in lat.buckets.items():
            k = math.floor(math.log2(bucket_middle(b) * 1e4))   # bins of 0.1 ms × 2^k
            bins[k] = bins.get(k, 0) + n
    out = Text("ACK latency histogram\n", style="bold")
    if not bins and not zero:
        out.append("no answered commands yet\n", style="dim")
        return out
    top = max(list(bins.values()) + [zero])
    rows = ([("≤ 0", zero)] if zero else []) + [
        (f"{fmt_seconds(0.0001 * 2 ** k)}–{fmt_seconds(0.0001 * 2 ** (k + 1))}", bins[k]) for k in sorted(bins)]
    for label, n in rows:
        out.append(f"{label:>20} ")
        out.append("█" * max(1, round(n / top * width)), style="cyan")
        out.append(f" {n}\n")
    return out


def device_map(model: CaptureModel) -> Table:
    t = Table(title="Device map", title_justify="left", header_style="bold")
    for col in ("device", "answered on", "commands", "answers", "answered NIC to"):
        t.add_column(col)
    for addr, info in sorted(model.totals.devices.items()):
        t.add_row(addr, ", ".join(sorted(info.lines)) or "never", str(info.commands), str(info.answered),
                  ", ".join(sorted(info.nic)) or "-")
    return t


class StatsScreen(Redrawn):
    BINDINGS = BACK

    def __init__(self, model: CaptureModel) -> None:
        super().__init__()
        self.model = model

    def compose(self) -> ComposeResult:
        with VerticalScroll():
            yield Static(id="summary")
            yield Static(id="by-command")
            yield Static(id="by-device")
            yield Static(id="histogram")
            yield Static(id="devices")
        yield Footer()

    def redraw(self) -> None:
        self.refresh_stats()

    def refresh_stats(self) -> None:
        m = self.model
        d = m.totals.stats.to_dict()
        # the words and columns of `gimbalscope stats` (analyzer/listeners/stats.py)
        head = Text()
        if m.filter_text:
            head.append(f"the {counted(m.filter.settled(m.shown), 'row')} of the filter: {m.filter_text}\n",
                        style="bold cyan")
        self.query_one("#summary", Static).update(head + Text("\n".join(summary(d))))
        self.query_one("#by-command", Static).update(counts_table("command", d["by_command"], "per command"))
        self.query_one("#by-device", Static).update(
            counts_table("device", d["by_device"], "per device (group.port.device)"))
        self.query_one("#histogram", Static).update(histogram(m))
        self.query_one("#devices", Static).update(device_map(m))
