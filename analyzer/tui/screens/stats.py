"""The statistics screen (``S``): per command and per device, the ACK latency
histogram, and the device map, refreshed once a second."""

from __future__ import annotations

import math

from rich.table import Table
from rich.text import Text
from textual.app import ComposeResult
from textual.containers import VerticalScroll
from textual.screen import Screen
from textual.widgets import Footer, Static

from dissectors.event import NO_ACK, NO_RESULT, OK, ST_NAK, ST_NIC

from ...output import fmt_seconds
from ..model import CaptureModel
from .back import BACK


def _ms(v: float | None) -> str:
    return fmt_seconds(v) if v is not None else "-"


def counts_table(title: str, rows: dict) -> Table:
    t = Table(title=title, title_justify="left", expand=False, header_style="bold")
    for col in ("", "commands", "ok", "NAK", "NIC", "no ACK", "no result", "checksum", "retx",
                "ACK min", "median", "p95", "max"):
        t.add_column(col, justify="left" if not col else "right")
    for key, c in sorted(rows.items()):
        lat = c.ack_latency
        t.add_row(key, str(c.commands), str(c.status.get(OK, 0)), str(c.status.get(ST_NAK, 0)),
                  str(c.status.get(ST_NIC, 0)), str(c.status.get(NO_ACK, 0)), str(c.status.get(NO_RESULT, 0)),
                  str(c.checksum_errors), str(c.retransmissions),
                  _ms(lat.min if lat.n else None), _ms(lat.quantile(0.5)), _ms(lat.quantile(0.95)),
                  _ms(lat.max if lat.n else None))
    return t


def histogram(model: CaptureModel, width: int = 50) -> Text:
    """ACK latency over all commands, in log-spaced bins (factor 2)."""
    bins: dict[int, int] = {}
    zero = 0
    for c in model.stats.by_command.values():
        lat = c.ack_latency
        zero += lat.zero
        for b, n in lat.buckets.items():
            x = math.exp((b + 0.5) * math.log(1.01))
            k = math.floor(math.log2(x * 1e4))   # bins of 0.1 ms × 2^k
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
    for addr, info in sorted(model.devices.items()):
        t.add_row(addr, ", ".join(sorted(info.lines)) or "never", str(info.commands), str(info.answered),
                  ", ".join(sorted(info.nic)) or "-")
    return t


class StatsScreen(Screen):
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

    def on_mount(self) -> None:
        self.refresh_stats()
        self.set_interval(1.0, self.refresh_stats)

    def refresh_stats(self) -> None:
        m = self.model
        d = m.stats.to_dict()
        s = d["status"]
        self.query_one("#summary", Static).update(Text(
            f"{d['events']:,} events, {d['commands']:,} commands: {s[OK]:,} ok, {s[ST_NAK]} NAK, {s[ST_NIC]} NIC, "
            f"{s[NO_ACK]} no ACK, {s[NO_RESULT]} no result; {d['checksum_errors']} checksum errors, "
            f"{d['noise']['events']} noise runs ({d['noise']['bytes']} bytes), {d['retransmissions']} retransmissions",
            style="bold"))
        self.query_one("#by-command", Static).update(counts_table("Per command", m.stats.by_command))
        self.query_one("#by-device", Static).update(counts_table("Per device", m.stats.by_device))
        self.query_one("#histogram", Static).update(histogram(m))
        self.query_one("#devices", Static).update(device_map(m))
