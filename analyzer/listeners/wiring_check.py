"""The input checked as it is read (``decode``, ``stats``, ``convert``, ``export``):
the wiring signs of analyzer/analysis/signs.py, kept for every event, and at the end
one warning line for each error they show: lines swapped, a line read at the wrong
rate, input that is not this protocol at all. These commands would otherwise print
orphans or noise and exit 0 without a word; the full doctor (``gimbalscope doctor``)
says more, at more cost an event."""

from __future__ import annotations

from dissectors.event import Event

from ..analysis.doctor import Invocation
from ..analysis.findings import Finding
from ..analysis.signs import WiringSigns
from ..info import CaptureInfo
from ..runner import WARNING, Listener, TapRunner


def warning_text(f: Finding) -> str:
    """One line: what is wrong, what shows it, what to try."""
    detail = f.detail.splitlines()[0] if f.detail else ""
    return f"{f.title}: {detail}" + (f" (try: {f.fix})" if f.fix else "")


def wiring_findings(signs: WiringSigns, info: CaptureInfo) -> list[Finding]:
    """What ``signs`` show at error level, their fixes said for the command run."""
    how = Invocation(info.inputs, info.live, info.command, baud=info.baud)
    signs.read_baud = info.baud     # the rate the tap read at: a wrong rate is named against it
    return signs.findings(how.swap_fix(), how.baud_fix(), how.live)


class WiringCheck(Listener):
    def __init__(self) -> None:
        self._runner: TapRunner | None = None
        self.signs: WiringSigns | None = None   # from on_start
        self.findings: list[Finding] = []
        self.warnings: list[str] = []        # what was said, for a job that reports them itself

    def on_start(self, runner: TapRunner) -> None:
        self._runner = runner
        self.signs = WiringSigns(runner.lines)

    def on_events(self, events: list[Event]) -> None:
        assert self.signs is not None, "on_start comes first"
        add = self.signs.add
        for ev in events:
            add(ev)

    def on_stop(self) -> None:
        runner = self._runner
        if self.signs is None or runner is None:
            return
        self.findings = wiring_findings(self.signs, runner.info)
        for f in self.findings:
            text = warning_text(f)
            self.warnings.append(text)
            runner.post(text, WARNING, finding=f)
