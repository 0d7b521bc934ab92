"""Full screens over the model: statistics (per command, per device, latency
histogram, device map), plots of commanded vs reported position, and help."""

from __future__ import annotations

import math

from rich.table import Table
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import VerticalScroll
from textual.screen import Screen
from textual.widgets import Footer, Static

from dissectors.event import NO_ACK, NO_RESULT, OK, ST_NAK, ST_NIC

from ..output import fmt_seconds
from ..styles import INFO, LEGEND, ROW_STYLE, SEVERITY_STYLE
from .model import CaptureModel

_BACK = [Binding("escape,q", "app.pop_screen", "Back", id="screen.back")]


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
    BINDINGS = _BACK

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


def _column(points, k: int):
    """Times (k = 0) or values (k = 1) of a series: its array, or from (t, v) pairs."""
    arr = getattr(points, "t" if k == 0 else "v", None)
    return arr if arr is not None else [p[k] for p in points]


def plot(series: dict, width: int, height: int) -> Text:
    """Series as dots on a character grid (one colour each), with the value range."""
    colours = ["cyan", "bright_green", "magenta", "yellow"]
    filled = [s for s in series.values() if len(s)]
    if not filled:
        return Text("no positions yet (go-to commands and position queries)", style="dim")
    # the ranges from the columns (devices.Series), at C speed: a day of polling is
    # millions of points
    t0, t1 = min(min(_column(s, 0)) for s in filled), max(max(_column(s, 0)) for s in filled)
    v0, v1 = min(min(_column(s, 1)) for s in filled), max(max(_column(s, 1)) for s in filled)
    if t1 - t0 < 1e-9:
        t1 = t0 + 1
    if v1 - v0 < 1e-9:
        v0, v1 = v0 - 1, v1 + 1
    grid = [[(" ", "")] * width for _ in range(height)]
    for k, (name, pts) in enumerate(series.items()):
        ch = "•" if k % 2 else "·"
        for t, v in pts:
            x = min(width - 1, int((t - t0) / (t1 - t0) * (width - 1)))
            y = height - 1 - min(height - 1, int((v - v0) / (v1 - v0) * (height - 1)))
            grid[y][x] = (ch if "commanded" in name else "●", colours[k % len(colours)])
    out = Text()
    for r, row in enumerate(grid):
        label = f"{v1:8.2f}°" if r == 0 else f"{v0:8.2f}°" if r == height - 1 else " " * 9
        out.append(label + " │", style="dim")
        for ch, colour in row:
            out.append(ch, style=colour)
        out.append("\n")
    out.append(" " * 10 + f"└ {t0:.1f} s" + " " * max(1, width - 20) + f"{t1:.1f} s\n", style="dim")
    for k, name in enumerate(series):
        out.append(f"  {'●' if 'reported' in name else '·'} {name}", style=colours[k % len(colours)])
    out.append("\n")
    return out


class PlotScreen(Screen):
    """Commanded (go-to) vs reported (position query) azimuth and elevation per device."""

    BINDINGS = _BACK

    def __init__(self, model: CaptureModel) -> None:
        super().__init__()
        self.model = model

    def compose(self) -> ComposeResult:
        yield VerticalScroll(id="plots")
        yield Footer()

    def on_mount(self) -> None:
        self.redraw()
        self.set_interval(1.0, self.redraw)

    def redraw(self) -> None:
        box = self.query_one("#plots", VerticalScroll)
        width = max(30, self.size.width - 14)
        parts = []
        for addr, series in sorted(self.model.series.items()):
            for axis in ("azimuth", "elevation"):
                sel = {k: v for k, v in series.items() if k.endswith(axis)}
                if sel:
                    parts.append(Text(f"device {addr}: {axis}", style="bold"))
                    parts.append(plot(sel, width, 8))
        if not parts:
            parts = [Text("no positions yet: plots need go-to commands (P) and position queries (P?)",
                          style="dim")]
        box.remove_children()
        box.mount_all([Static(p) for p in parts])


class HelpScreen(Screen):
    BINDINGS = _BACK

    def __init__(self, app) -> None:
        super().__init__()
        self._app = app

    def compose(self) -> ComposeResult:
        from .widgets import EventList

        t = Table(title="Keys (ids rebind with --keymap)", title_justify="left", header_style="bold")
        t.add_column("key")
        t.add_column("does")
        t.add_column("id", style="dim")
        for b in list(EventList.BINDINGS) + list(type(self._app).BINDINGS):
            t.add_row(b.key, b.description, b.id or "")
        rules = Text("\nRow colours: ", style="bold")
        for name, row in LEGEND:
            rules.append(f" {name} ", style=ROW_STYLE[row])
        with VerticalScroll():
            yield Static(t)
            yield Static(rules)
        yield Footer()


class FindingsScreen(Screen):
    """The wiring doctor's findings, updated live; Enter on an evidence line goes
    to that event (analyzer.analysis.doctor)."""

    BINDINGS = [Binding("escape,q,w", "dismiss_none", "Back", id="findings.back")]

    def __init__(self, model: CaptureModel) -> None:
        super().__init__()
        self.model = model
        self._shown: list | None = None

    def compose(self) -> ComposeResult:
        from textual.widgets import Tree

        yield Tree("findings", id="findings")
        yield Footer()

    def on_mount(self) -> None:
        self.redraw()
        self.set_interval(1.0, self.redraw)
        self.query_one("#findings").focus()

    def redraw(self) -> None:
        from textual.widgets import Tree

        findings = self.model.findings
        if findings is self._shown:
            return
        self._shown = findings
        tree = self.query_one("#findings", Tree)
        tree.clear()
        tree.show_root = False
        if not findings:
            tree.root.add_leaf(Text("no findings yet: the doctor checks the traffic once a second", style="dim"))
        for f in findings:
            label = Text(f"{f.severity.upper():8}", style=SEVERITY_STYLE.get(f.severity, ""))
            label.append(f" {f.title}", style="bold")
            if f.first_seen is not None and f.severity != INFO:
                label.append(f"  (at {f.first_seen:.1f} s)", style="dim")
            node = tree.root.add(label, expand=f.severity != INFO)
            for part in f.detail.splitlines():
                node.add_leaf(part)
            if f.fix:
                node.add_leaf(Text("try: " + f.fix, style="green"))
            if f.evidence:
                ev = node.add(Text(f"evidence ({len(f.evidence)} events)", style="dim"), expand=True)
                for n in f.evidence:
                    ev.add_leaf(Text(f"#{n}", style="underline cyan"), data=n)
        tree.root.expand()

    def on_tree_node_selected(self, event) -> None:
        if isinstance(event.node.data, int):
            self.dismiss(event.node.data)

    def action_dismiss_none(self) -> None:
        self.dismiss(None)
