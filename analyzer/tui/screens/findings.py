"""The doctor's screen (``w``): the wiring doctor's findings, updated live;
Enter on an evidence line goes to that event (analyzer.analysis.doctor)."""

from __future__ import annotations

from typing import ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.widgets import Footer, Tree

from ...styles import INFO, SEVERITY_STYLE
from ...words import counted
from ..model import CaptureModel
from .redraw import Redrawn


class FindingsScreen(Redrawn):
    """The wiring doctor's findings, updated live; Enter on an evidence line goes
    to that event (analyzer.analysis.doctor)."""

    BINDINGS: ClassVar[list[BindingType]] = [Binding("escape,q,w", "dismiss_none", "Back", id="findings.back")]

    def __init__(self, model: CaptureModel) -> None:
        super().__init__()
        self.model = model
        self._shown: tuple | None = None

    def compose(self) -> ComposeResult:
        yield Tree("findings", id="findings")
        yield Footer()

    def on_mount(self) -> None:
        super().on_mount()
        self.query_one("#findings").focus()

    def redraw(self) -> None:
        m = self.model
        findings = m.findings
        shown = (id(findings), m.findings_known, m.done, m.doctor_error)
        if shown == self._shown:
            return
        self._shown = shown
        tree = self.query_one("#findings", Tree)
        tree.clear()
        tree.show_root = False
        if not findings:
            tree.root.add_leaf(Text(self._nothing_yet(), style="dim"))
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
                ev = node.add(Text(f"evidence ({counted(len(f.evidence), 'event')})", style="dim"), expand=True)
                for n in f.evidence:
                    ev.add_leaf(Text(f"#{n}", style="underline cyan"), data=n)
        tree.root.expand()

    def _nothing_yet(self) -> str:
        m = self.model
        if m.doctor_error is not None:
            return f"no findings: the wiring doctor stopped ({m.doctor_error})"
        if not m.findings_known:   # a file's doctor reads it in a process of its own, maybe after the load
            return "no findings yet: the wiring doctor is still reading the capture"
        if m.done:
            return "no findings: the wiring doctor found nothing wrong"
        return "no findings yet: the doctor checks the traffic once a second"

    def on_tree_node_selected(self, event: Tree.NodeSelected[int | None]) -> None:
        if isinstance(event.node.data, int):
            self.dismiss(event.node.data)

    def action_dismiss_none(self) -> None:
        self.dismiss(None)
