"""The wiring doctor alongside a run (analyzer/analysis/doctor.py): fed every event, it
checks about once a second of capture time (every ``UNTIMED_CHECK_EVERY`` events
when the capture has no time) and posts each new finding (not the device map)
once, as a note the printer prints and a recording keeps on ``/log``.

Used by ``live``, ``demo``, ``doctor`` and the TUI (``tui=True``: findings are
read where the swap key is at hand, which a fix may mention)."""

from __future__ import annotations

from dissectors.event import Event

from ..analysis.doctor import INFO, UNTIMED_CHECK_EVERY, Invocation, WiringDoctor, one_line
from ..analysis.findings import Finding
from ..runner import DOCTOR, Listener, Note, TapRunner


class DoctorListener(Listener):
    def __init__(self, every: float = 1.0, *, tui: bool = False) -> None:
        self.every = every
        self.tui = tui
        self.doctor: WiringDoctor | None = None   # from on_start
        self.findings: list[Finding] = []   # as of the last check
        self.checked = False                # the last step re-checked the findings
        self._runner: TapRunner | None = None
        self._told: set[tuple[str, str]] = set()
        self._swapped = False
        self._next: float | None = None     # the capture time of the next check
        self._next_event = UNTIMED_CHECK_EVERY

    def on_start(self, runner: TapRunner) -> None:
        self._runner = runner
        self._swapped = runner.swapped
        self.doctor = self._new_doctor(runner)

    def _new_doctor(self, runner: TapRunner) -> WiringDoctor:
        """A doctor for the runner's wiring as it is now, nothing told yet."""
        info = runner.info
        doctor = WiringDoctor(runner.lines, runner.ack_timeout,
                              Invocation(info.inputs, info.live, info.command, self.tui, baud=info.baud))
        doctor.physical = runner.physical
        self._told.clear()
        self._next = None
        self._next_event = UNTIMED_CHECK_EVERY
        return doctor

    def on_events(self, events: list[Event]) -> None:
        runner, doctor = self._runner, self.doctor
        assert runner is not None and doctor is not None, "on_start comes first"
        if runner.swapped != self._swapped:
            # the lines were swapped while capturing (the TUI's key): a new wiring,
            # so start again rather than mix evidence from both
            self._swapped = runner.swapped
            doctor = self.doctor = self._new_doctor(runner)
        skew_from = runner.skew_from
        if skew_from is not None and skew_from != doctor.trend_from:
            doctor.restart_ack_trend(skew_from)
        self.checked = self._add(runner, doctor, events)
        for cmd in runner.echoed:
            doctor.echoed(cmd)
        t = doctor.last_t
        if t is None or (self._next is not None and t < self._next):
            return
        self._next = t + self.every
        self._check(runner, doctor)
        self.checked = True

    def _add(self, runner: TapRunner, doctor: WiringDoctor, events: list[Event]) -> bool:
        add = doctor.add
        checked = False
        for ev in events:
            add(ev)
            # without time, check by event count, inside the batch: an untimed
            # capture's batches can be tens of thousands of events long
            if ev.t is None and doctor.events >= self._next_event:
                self._next_event = doctor.events + UNTIMED_CHECK_EVERY
                self._check(runner, doctor)
                checked = True
        return checked

    def _check(self, runner: TapRunner, doctor: WiringDoctor) -> None:
        self.findings = doctor.findings()
        for f in self.findings:
            if f.severity != INFO and f.key not in self._told:
                self._told.add(f.key)
                runner.post(one_line(f), f.severity, finding=f, origin=DOCTOR)

    def on_stop(self) -> None:
        if self.doctor is not None:
            self.findings = self.doctor.findings()   # the last word
            self.checked = True


class FindingTeller(Listener):
    """Live: each finding on standard output the first time it shows."""

    def on_note(self, note: Note) -> None:
        if note.origin == DOCTOR:
            f = note.finding
            print(f"{f.severity.upper():8} {f.title}", flush=True)
