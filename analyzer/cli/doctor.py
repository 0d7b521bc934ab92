"""``gimbalscope doctor INPUT…|PORT…``: what is wrong with the link, in plain words
with the fix to try (analyzer.analysis.doctor; every finding is in the table of
analyzer.analysis.findings: swapped lines, wrong baud rate, echo, silent devices, a
device silent since a rate change, noise, controller timing, slow answers, the device
map). From any capture, or live from one or two ports (``--seconds``, findings
printed as they appear).

``--scan-baud PORT…`` listens (never transmits) at each standard rate of §1.5.1
in turn and says which one decodes cleanly.

The exit status is for scripts and CI checks (docs/doctor.md, "Exit status"): 0 when
nothing is found above info, 1 for warnings, 3 for errors; 2 stays a usage or input
error, as for every command. ``--scan-baud``: 0 when one rate decodes cleanly, 1 when
the scan cannot tell.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import stat
import sys
import threading
from dataclasses import replace

from ..analysis.doctor import INFO, WiringDoctor
from ..analysis.findings import Finding
from ..capture import Capture, Options, open_live
from ..capture import open as open_capture
from ..listeners import DoctorListener, FindingTeller
from ..runner import Listener
from ..sources import registry
from ..styles import ERROR, SEVERITY_STYLE, WARNING
from ..words import counted
from .common import (
    STANDARD_BAUDS,
    Subcommands,
    UsageError,
    add_quiet_arg,
    add_serial_args,
    non_negative_float,
    options_from,
    positive_float,
    run_tap,
)


def register(sub: Subcommands) -> None:
    p = sub.add_parser("doctor", help="say what is wrong with the link, and what to try",
                       description="Findings about the wiring and the devices from a capture (see INPUT), or "
                                   "live from one or two ports.")
    p.add_argument("inputs", nargs="+", metavar="INPUT|PORT",
                   help=f"{registry.input_help()}; or one or two serial ports (device names or pyserial URLs)")
    add_quiet_arg(p)
    add_serial_args(p)
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("--seconds", type=non_negative_float, default=10.0,
                   help="ports: how long to listen (default 10; 0 = until Ctrl-C)")
    p.add_argument("--scan-baud", action="store_true",
                   help="listen at each standard rate (1200-115200) in turn and report which decodes cleanly")
    p.add_argument("--dwell", type=positive_float, default=2.0, metavar="S",
                   help="with --scan-baud: seconds at each rate (default 2)")
    p.set_defaults(run=run)


# the exit status by the worst severity found (2 is taken: usage and input errors)
EXIT_BY_SEVERITY = {INFO: 0, WARNING: 1, ERROR: 3}
SCAN_FOUND, SCAN_UNSURE = 0, 1


def exit_status(findings: list[Finding]) -> int:
    return max((EXIT_BY_SEVERITY[f.severity] for f in findings), default=0)


def is_port(arg: str) -> bool:
    if "://" in arg:
        return True
    try:
        return stat.S_ISCHR(os.stat(arg).st_mode)
    except OSError:
        return False


def run(args: argparse.Namespace) -> int:
    options = options_from(args)
    ports = [a for a in args.inputs if is_port(a)]
    if ports and len(ports) != len(args.inputs):
        raise UsageError("give capture files or serial ports, not both")
    if args.scan_baud:
        missing = [a for a in args.inputs if not is_port(a) and not os.path.exists(a)]
        if missing:
            raise UsageError(f"{missing[0]}: no such serial port")
        if not ports:
            raise UsageError("--scan-baud listens on serial ports (files have no rate to change)")
        return scan_baud(ports, options, args)
    if ports:
        if len(ports) > 2:
            raise UsageError(f"{len(ports)} ports given: a tap reads one port or two (line A, line B)")
        return diagnose(open_live(ports, options), args, live=True)
    return diagnose(open_capture(*args.inputs, options=options), args, live=False)


def examine(capture: Capture, *listeners: Listener, notes: bool = True,
            progress: bool = False) -> tuple[WiringDoctor, int]:
    """Run a capture through the doctor (and ``listeners``, which hear each finding
    the first time it shows, checked about once a second of capture time)."""
    doctor = DoctorListener()
    # findings are printed by the report (or FindingTeller), not as notes
    runner = run_tap(capture, "doctor", doctor, *listeners, notes=notes, findings=False, say_empty=False,
                     progress=progress)
    assert doctor.doctor is not None, "made as the run started"
    return doctor.doctor, runner.events


def diagnose(capture: Capture, args: argparse.Namespace, live: bool) -> int:
    timer = None
    old = {}
    if live:
        def stop(*_: object) -> None:
            capture.source.stop()
        old = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
        if args.seconds > 0:
            timer = threading.Timer(args.seconds, capture.source.stop)
            timer.daemon = True
            timer.start()
        print(f"gimbalscope doctor: listening on {capture.source.description} "
              f"({'until Ctrl-C' if not args.seconds else f'{args.seconds:g} s'})", file=sys.stderr, flush=True)

    tell = [FindingTeller()] if live and args.format == "text" else []
    try:
        doctor, events = examine(capture, *tell, progress=not live)   # a bar for a long file
    finally:
        if timer is not None:
            timer.cancel()
        for sig, handler in old.items():
            signal.signal(sig, handler)
    findings = doctor.findings()
    if args.format == "json":
        print(json.dumps({"source": capture.source.description, "events": events,
                          "seconds": round(doctor.span, 3) if doctor.timed else None,
                          "findings": [f.to_dict() | {"after": _seconds_in(f, doctor),
                                                      "after_events": f.first_seen_event} for f in findings]},
                         indent=2, ensure_ascii=False))
        return exit_status(findings)
    report(findings, doctor, events)
    return exit_status(findings)


def _seconds_in(f: Finding, doctor: WiringDoctor) -> float | None:
    """Seconds of traffic it took to find (None without time)."""
    if f.first_seen is None or doctor.first_t is None:
        return None
    return round(f.first_seen - doctor.first_t, 3)


def _found_after(f: Finding, doctor: WiringDoctor) -> str | None:
    """How much traffic it took to find: seconds, or events where there is no time."""
    after = _seconds_in(f, doctor)
    if after is not None:
        return f"{after:.1f} s of traffic"
    if f.first_seen_event is not None:
        return counted(f.first_seen_event, "event")
    return None


def report(findings: list[Finding], doctor: WiringDoctor, events: int) -> None:
    from rich.console import Console
    from rich.text import Text

    console = Console(highlight=False, soft_wrap=True)
    problems = [f for f in findings if f.severity != INFO]
    head = counted(len(problems), "finding") if problems else "no problems found"
    # a capture without time (raw dumps) is measured in events, not "0.0 s"
    amount = (f"{doctor.span:.1f} s of traffic ({counted(events, 'event')})" if doctor.timed
              else f"{counted(events, 'event')} (no time in this capture)")
    console.print(Text(f"gimbalscope doctor: {head} in {amount}", style="bold"))
    for f in findings:
        after = _found_after(f, doctor)
        line = Text(f"{f.severity.upper():8} ", style=SEVERITY_STYLE[f.severity])
        line.append(f.title, style="bold")
        if after is not None and f.severity != INFO:
            line.append(f"  [found after {after}]", style="dim")
        console.print(line)
        for part in f.detail.splitlines():
            console.print(Text("         " + part))
        if f.fix:
            console.print(Text("         try: " + f.fix, style="green"))
        if f.evidence:
            console.print(Text("         evidence: " + " ".join(f"#{n}" for n in f.evidence), style="dim"))


def scan_baud(ports: list[str], options: Options, args: argparse.Namespace) -> int:
    """Listen at each standard rate; the one whose bytes decode is the line's rate."""
    rows = []
    for rate in STANDARD_BAUDS:
        capture = open_live(ports, replace(options, baud=rate))
        timer = threading.Timer(args.dwell, capture.source.stop)
        timer.daemon = True
        timer.start()
        try:
            doctor, _events = examine(capture, notes=False)   # other rates' warnings are noise
        finally:
            timer.cancel()
        total = sum(line.bytes for line in doctor.lines.values())
        good = sum(line.good_bytes for line in doctor.lines.values())
        frames = sum(line.frames - line.bad_frames for line in doctor.lines.values())
        rows.append({"baud": rate, "bytes": total, "decoded": round(good / total, 3) if total else 0.0,
                     "good_frames": frames})
        if args.format == "text":
            print(f"{rate:>7} baud: {counted(total, 'byte'):>12}, {good / total if total else 0:5.0%} decode, "
                  f"{counted(frames, 'good frame')}", flush=True)
    verdict, best = scan_verdict(rows)
    if args.format == "json":
        print(json.dumps({"ports": ports, "rates": rows, "best": best, "verdict": verdict}, indent=2))
    else:
        print(scan_words(verdict, best, rows))
    return SCAN_FOUND if best is not None else SCAN_UNSURE


def _clean(row: dict) -> bool:
    return row["decoded"] >= 0.9 and row["good_frames"] >= 3


def scan_verdict(rows: list[dict]) -> tuple[str, int | None]:
    """What the scan concludes: ``found`` (and the rate), ``silent``, ``unclean``,
    or ``undecided`` when several rates decode cleanly: a port that does not apply
    the rate (a pseudo-terminal, a network port, an adapter passing bytes through)
    decodes at every rate, and nothing tells the line's own."""
    heard = [r for r in rows if r["bytes"]]
    if not heard:
        return "silent", None
    clean = [r for r in heard if _clean(r)]
    if not clean:
        return "unclean", None
    if len(clean) > 1:
        return "undecided", None
    return "found", clean[0]["baud"]


def scan_words(verdict: str, best: int | None, rows: list[dict]) -> str:
    if verdict == "found":
        row = next(r for r in rows if r["baud"] == best)
        return f"the line runs at {best} baud ({row['decoded']:.0%} of bytes decode); use --baud {best}"
    if verdict == "silent":
        return "nothing heard at any rate: is anything talking on the line (and the tap on the right pins)?"
    if verdict == "unclean":
        return "no rate decodes cleanly: check data bits, parity and stop bits, then the wiring"
    clean = [str(r["baud"]) for r in rows if r["bytes"] and _clean(r)]
    every = len(clean) == sum(1 for r in rows if r["bytes"])
    which = "every rate decodes" if every else f"{len(clean)} rates decode ({', '.join(clean)})"
    return (f"cannot tell the rate: {which} equally well, so this port does not apply the rate "
            f"(a pseudo-terminal, a network port, or an adapter that passes bytes through); "
            f"read the rate off the controller's settings")
