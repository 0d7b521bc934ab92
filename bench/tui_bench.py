#!/usr/bin/env python3
"""TUI figures (issues: Textual TUI; day-long captures). Runs the real app
headless (Textual's Pilot) and prints:

  0. the first screen from the process start: `gimbalscope view FILE` (the
     console script) in a terminal of its own, until it shows the first event
     row, for that MCAP and for two raw dumps and a socat log of up to 100,000
     events (median of three each)
  1. `gimbalscope view` of an N-event MCAP (made once, kept in the temporary
     folder, made again when its stored columns are not this decoder's): time to the first screen, time until every event is loaded against
     `decode --format jsonl` of the same file, peak memory and bytes per event,
     and whether End pressed while loading follows to the last event
  2. keys on those events: home, page down, next error, pair, same device, end
     (milliseconds until the screen has refreshed); a filter over every event in
     the background (a key meanwhile, the whole filter) and Esc stopping one
  3. live tap of two saturated 115200-baud ptys: events shown vs events on the
     wire (dropped?), and how far the screen is behind the wire (p50/p95/max)
  4. (--idle SECONDS, alone) `gimbalscope live` on two quiet ptys in a terminal
     of its own: the share of a core it uses while nothing arrives

Targets: first screen < 1 s (from the process start, and in the app); a recording
with stored columns fully loaded >= 10x faster than decode --format jsonl of it;
peak RSS <= 150 bytes per event at 1M events and within 2 GB at 10M; keys < 200
ms at 10M; live no drops and at most 250 ms behind; idle live <= 1 % of a core.

    python3 bench/tui_bench.py [--events 1000000] [--live-seconds 10] [--no-live]
    python3 bench/tui_bench.py --events 10000000 --no-live   # makes a 10M recording first (minutes)
    python3 bench/tui_bench.py --idle 20                    # the idle live TUI's CPU share over 20 s
    python3 bench/tui_bench.py --first-screen               # only figure 0 (a 100k-event recording)
"""

from __future__ import annotations

import argparse
import asyncio
import os
import re
import resource
import sys
import tempfile
import threading
import time
import tty

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "bench"))

from mcap_bench import BAUD, EVENTS_PER_COMMAND, saturated
from measure import run_measured

import analyzer
from analyzer.capture import open_live
from analyzer.info import CaptureInfo
from analyzer.runner import TapRunner
from analyzer.tui.decode_process import ProcessFeed
from analyzer.tui.feed_choice import Loading, early_decoding
from analyzer.tui.run import SWITCH, make_app, stop_feed
from analyzer.tui.widgets import EventList
from analyzer.writers.mcap import McapWriter

SIZE = (120, 40)
# the first event row as the terminal gets it, escape codes taken out: number 1,
# its time ("-" untimed), its direction and line ("     1 0.000000    → A 1.1.2")
FIRST_ROW = re.compile(rb"(?:^|\s)1 +\S+ +(?:\xe2\x86\x92|\xe2\x86\x90) [AB] ")
ESCAPE = re.compile(rb"\x1b\[[0-9;?]*[A-Za-z]")


def rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def columns_usable(path: str) -> bool:
    """Does the recording carry stored columns this decoder reads (docs/mcap.md)?"""
    from analyzer.capture.stored import stored_events

    capture = analyzer.open(path)
    try:
        return stored_events(capture)[0] is not None
    finally:
        capture.source.close()


def make_recording(events: int, path: str) -> None:
    """An MCAP of about ``events`` events, recorded as ``convert`` does."""
    tr = saturated(int(events / EVENTS_PER_COMMAND), seed=11)
    log = path + ".log"
    with open(log, "w") as f:
        f.write(tr.socat_log())
    cap = analyzer.open(log, baud=BAUD)
    info = CaptureInfo.of(cap, command="bench")
    TapRunner(cap, [McapWriter(path, info)], info=info).run()
    os.remove(log)


async def timed_press(pilot, key: str) -> float:
    t = time.perf_counter()
    await pilot.press(key)
    await pilot.pause()          # the screen has processed the key and refreshed
    return (time.perf_counter() - t) * 1000


def vm_hwm_mb(pid: int | str = "self") -> float:
    """Peak resident memory of a process (VmHWM: ru_maxrss is inherited across fork)."""
    with open(f"/proc/{pid}/status") as f:
        return int(next(line for line in f if line.startswith("VmHWM")).split()[1]) / 1024


def watch_decoding(app, figures: dict) -> None:
    """The peak memory of the process a viewed file is decoded in, read until it
    ends (the screen's own peak is the process's above)."""
    def watch():
        while not app.model.done:
            process = app.feed.process if isinstance(app.feed, ProcessFeed) else None
            if process is not None:
                try:
                    figures["rss_decoding"] = vm_hwm_mb(process.pid)
                except (OSError, StopIteration):   # ended
                    pass
            time.sleep(0.1)
    threading.Thread(target=watch, daemon=True).start()


def recorded_events(path: str) -> int | None:
    """How many events a recording holds: its /events topic's message count."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    if summary is None or summary.statistics is None:
        return None
    ids = [c.id for c in summary.channels.values() if c.topic == "/events"]
    return sum(summary.statistics.channel_message_counts.get(i, 0) for i in ids) or None


def view_figures(path: str) -> dict[str, float]:
    """``gimbalscope view PATH`` headless, in this (fresh) process: first screen,
    loading, memory, and keys once loaded. Returns the figures."""
    sys.setswitchinterval(SWITCH)   # as run_app does
    t0 = time.perf_counter()
    # as `gimbalscope view` runs it (tui/run.py, run_app): the decoding process
    # started before the screen is made; the recording with its own settings (a
    # --baud given would decode it)
    capture = analyzer.open(path)
    info = CaptureInfo.of(capture, command="view")
    app = make_app(capture, mode="view", info=info, decoding=early_decoding(Loading(capture, info, "view")))
    figures: dict[str, float] = {}

    # the first screen: when the event list first renders a line holding an event
    # (Pilot's pause() waits for an idle queue, which never comes while loading)
    original = EventList.render_line

    def render_line(self, y):
        strip = original(self, y)
        if "first" not in figures and y > 0 and self.model.row(int(self.scroll_y) + y - 1) is not None:
            figures["first"] = time.perf_counter() - t0
            figures["rows_at_first"] = self.model.row_count
        return strip
    EventList.render_line = render_line

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            watch_decoding(app, figures)
            while "first" not in figures:
                await pilot.pause(0.01)
            EventList.render_line = original
            # End while loading: the list keeps following until the file has loaded.
            # Pressed at 90% of the events (following redraws the list with every
            # batch, which is not what loading a file costs), or at once if the
            # recording does not say how many events it holds
            expected = recorded_events(path)
            while expected and app.model.shown < 0.9 * expected and not app.model.done:
                await pilot.pause(0.05)
            await pilot.press("end")
            while not app.model.done:
                await pilot.pause(0.05)
            figures["loaded"] = time.perf_counter() - t0
            figures["events"] = app.model.shown
            figures["rss_loaded"] = vm_hwm_mb()   # the load's peak (the keys and filters below add theirs)
            await pilot.pause()
            lst = app.query_one(EventList)
            figures["end_follows"] = float(lst.selected == app.model.shown)
            lst.focus()
            # home and end alternate five times (one press each is too noisy a figure)
            jumps = [(await timed_press(pilot, "home"), await timed_press(pilot, "G")) for _ in range(5)]
            figures["home"] = sum(h for h, _e in jumps) / 5
            figures["end"] = sum(e for _h, e in jumps) / 5
            await timed_press(pilot, "home")
            figures["pagedown"] = sum([await timed_press(pilot, "pagedown") for _ in range(20)]) / 20
            figures["next_error"] = sum([await timed_press(pilot, "e") for _ in range(20)]) / 20
            figures["pair"] = sum([await timed_press(pilot, "p") for _ in range(20)]) / 20
            figures["same_device"] = sum([await timed_press(pilot, "d") for _ in range(10)]) / 10
            await timed_press(pilot, "G")   # the filter below starts from the end, following
            # a filter over every event runs in the background: keys are answered
            # meanwhile, the status line shows its progress, Esc stops it
            await pilot.press("slash", *'status == "nak"')
            t = time.perf_counter()
            # Pilot's press returns once the app is idle, which a running filter's
            # progress messages delay: the key's figure is the time until the list
            # has handled it (its action ran)
            handled = []
            move = EventList.action_move
            EventList.action_move = lambda self, step: (handled.append(time.perf_counter()), move(self, step))[1]
            enter = asyncio.create_task(pilot.press("enter"))
            while not app.sweep_text:
                await asyncio.sleep(0.001)
            k = time.perf_counter()
            up = asyncio.create_task(pilot.press("up"))
            while not handled:
                await asyncio.sleep(0.001)
            figures["key_while_filtering"] = (handled[0] - k) * 1000
            figures["filter_busy"] = float(bool(app.sweep_text))   # the filter was still running then
            EventList.action_move = move
            await enter
            await up
            while app.model.filter_text != 'status == "nak"':
                await pilot.pause(0.02)
            await pilot.pause()
            figures["filter"] = (time.perf_counter() - t) * 1000
            figures["filter_rows"] = app.model.row_count
            # a filter the columns cannot decide (the payload's text): the closure runs on
            # every frame, long enough to be stopped
            await pilot.press("slash", "ctrl+u", *'payload == "x"', "enter")
            await pilot.pause(0.3)
            t = time.perf_counter()
            await pilot.press("escape")
            await pilot.pause()
            figures["cancel"] = (time.perf_counter() - t) * 1000
            figures["cancelled"] = float(app.model.filter_text == 'status == "nak"' and not app.sweep_text)
            figures["rss"] = vm_hwm_mb()
    asyncio.run(drive())
    stop_feed(app)
    return figures


def view_report(path: str) -> None:
    """``view`` figures (in a child process, for its own peak memory) against
    ``decode --format jsonl`` of the same file."""
    import json
    import subprocess

    out = subprocess.run([sys.executable, __file__, "--view-figures", path], capture_output=True, text=True,
                         check=True).stdout
    f = json.loads(out.strip().splitlines()[-1])
    jsonl, _jsonl_rss = run_measured(["decode", path, "--format", "jsonl"])
    n = f["events"]
    print(f"1. view of {n:,} events: first screen after {f['first']:.2f} s (target < 1 s); all loaded after "
          f"{f['loaded']:.2f} s ({n / f['loaded']:,.0f} events/s), decode --format jsonl of the same file "
          f"{jsonl:.1f} s: {jsonl / f['loaded']:.1f}x as fast (target >= 10x from its stored columns); "
          "peak RSS once loaded "
          f"{f['rss_loaded']:.0f} MB, {f['rss_loaded'] * 1024 * 1024 / n:.0f} bytes per event (target <= 150), "
          f"the process decoding it {f.get('rss_decoding', 0):.0f} MB at its peak, "
          f"after the keys and filters {f['rss']:.0f} MB; End "
          f"pressed while loading (at 90%) {'followed to the last event' if f['end_follows'] else 'did NOT follow'}")
    print(f"2. keys on {n:,} events (ms until the screen has refreshed; target < 200): home {f['home']:.0f}, "
          f"page down {f['pagedown']:.0f}, next error {f['next_error']:.0f}, pair {f['pair']:.0f}, same device "
          f"{f['same_device']:.0f}, end {f['end']:.0f}; filter 'status == \"nak\"' over every event, Enter to "
          f"its rows on screen (target <= 1 s at 1M, <= 3 s at 10M) {f['filter']:.0f} ({f['filter_rows']:,} rows; "
          f"a key meanwhile handled after {f['key_while_filtering']:.0f}"
          f"{'' if f['filter_busy'] else ' (the filter had ended)'}); "
          f"Esc stopped a running filter in {f['cancel']:.0f}{'' if f['cancelled'] else ' (NOT stopped)'}")


def console_script() -> list[str]:
    """The ``gimbalscope`` command beside this interpreter (the venv's), else ``python -m analyzer``."""
    script = os.path.join(os.path.dirname(sys.executable), "gimbalscope")
    return [script] if os.access(script, os.X_OK) else [sys.executable, "-m", "analyzer"]


def first_screen_from_start(args: list[str], timeout: float = 60.0) -> float:
    """Seconds from starting ``gimbalscope ARGS`` in a terminal of its own (a pty of
    SIZE, as a user's) until that terminal has been sent the first event row."""
    import fcntl
    import pty
    import select
    import signal
    import struct
    import subprocess
    import termios

    term_m, term_s = pty.openpty()
    fcntl.ioctl(term_s, termios.TIOCSWINSZ, struct.pack("HHHH", SIZE[1], SIZE[0], 0, 0))
    env = dict(os.environ, TERM="xterm-256color", COLUMNS=str(SIZE[0]), LINES=str(SIZE[1]))
    t0 = time.perf_counter()
    proc = subprocess.Popen([*console_script(), *args], stdin=term_s, stdout=term_s, stderr=term_s, env=env,
                            start_new_session=True)
    os.close(term_s)
    shown, seen = None, b""
    try:
        while shown is None and time.perf_counter() - t0 < timeout:
            if not select.select([term_m], [], [], 0.01)[0]:
                continue
            try:
                data = os.read(term_m, 1 << 16)
            except OSError:   # the TUI has ended (and closed the terminal)
                break
            if not data:
                break
            seen += data
            if FIRST_ROW.search(ESCAPE.sub(b" ", seen)):
                shown = time.perf_counter() - t0
    finally:
        proc.send_signal(signal.SIGTERM)   # the TUI quits on SIGTERM, as on q
        end = time.monotonic() + 10
        while proc.poll() is None and time.monotonic() < end:   # read what it draws, so that it never waits to write
            if select.select([term_m], [], [], 0.05)[0]:
                try:
                    os.read(term_m, 1 << 16)
                except OSError:
                    break
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        os.close(term_m)
    if shown is None:
        text = ESCAPE.sub(b" ", seen).decode(errors="replace")[-400:]
        raise SystemExit(f"gimbalscope {' '.join(args)}: no event row within {timeout:.0f} s: ...{text}")
    return shown


def make_captures(events: int, folder: str) -> dict[str, list[str]]:
    """Two raw dumps and a socat log of about ``events`` events (made once)."""
    a, b, log = (os.path.join(folder, f"gimbalscope-tui-bench-{events}{end}") for end in ("-a.bin", "-b.bin", ".log"))
    if not all(os.path.exists(p) for p in (a, b, log)):
        tr = saturated(int(events / EVENTS_PER_COMMAND), seed=11)
        for path, data in ((a, tr.line_bytes("A")), (b, tr.line_bytes("B"))):
            with open(path, "wb") as f:
                f.write(data)
        with open(log, "w") as f:
            f.write(tr.socat_log())
    return {"two raw dumps": [a, b, "--baud", str(BAUD)], "a socat log": [log]}


def first_screen_report(recording: str, events: int) -> None:
    """Figure 0: the first screen from the process start, median of three, for
    the recording and for raw dumps and a socat log of up to 100,000 events."""
    import statistics

    inputs = {f"the {recorded_events(recording) or events:,}-event MCAP recording": [recording],
              **make_captures(min(events, 100_000), os.path.dirname(recording))}
    figures = []
    for name, args in inputs.items():
        runs = [first_screen_from_start(["view", *args]) for _ in range(3)]
        figures.append(f"{name} {statistics.median(runs):.2f} s ({', '.join(f'{r:.2f}' for r in runs)})")
    print(f"0. first screen from the process start (gimbalscope view in a {SIZE[0]}x{SIZE[1]} terminal until it "
          f"shows the first event row; median of 3; target < 1 s): {'; '.join(figures)}")


def baseline_keys() -> None:
    """The same keys on the 474-event sample: what a key costs with few rows."""
    app = make_app(analyzer.open(os.path.join(ROOT, "captures", "demo-socat.log")), mode="view")
    out: dict[str, float] = {}

    async def drive():
        async with app.run_test(size=SIZE) as pilot:
            while not app.model.done:
                await pilot.pause(0.05)
            out["pagedown"] = sum([await timed_press(pilot, "pagedown") for _ in range(20)]) / 20
            out["next_error"] = sum([await timed_press(pilot, "e") for _ in range(10)]) / 10
    asyncio.run(drive())
    stop_feed(app)
    print(f"   the same keys on the 474-event sample: page down {out['pagedown']:.0f}, next error "
          f"{out['next_error']:.0f} (the cost of a key does not grow with the capture)")


def feed_ptys(fds: list[int], seconds: float, seed: int, start: float) -> None:
    """The wire, in its own process (as in the field, it is not the tap's): each
    line's bytes written back to back at 115200 baud from ``start`` (monotonic)."""
    tr = saturated(int(seconds * 1500) + 100, seed=seed)
    bt = 10 / BAUD

    def feed(line: str, fd: int) -> None:
        for w in (w for w in tr.writes if w.line == line and w.t <= seconds):
            d = start + w.t + len(w.data) * bt - time.monotonic()
            if d > 0:
                time.sleep(d)
            os.write(fd, w.data)

    threads = [threading.Thread(target=feed, args=(line, fd)) for line, fd in zip("AB", fds)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()


def live_figures(seconds: float) -> None:
    import subprocess

    ptys = []
    for _ in range(2):
        m, s = os.openpty()
        tty.setraw(s)
        ptys.append((m, s, os.ttyname(s)))
    ports = [ptys[0][2], ptys[1][2]]
    capture = open_live(ports, analyzer.Options(baud=BAUD))
    app = make_app(capture, mode="live", ports=ports)
    lags: list[float] = []
    seed = 5
    # how far the screen is behind the wire: for every event, the time from its last
    # byte on the wire to the moment the screen's model first holds it (the list
    # redraws in the same turn)
    model = app.model
    seen: set[int] = set()

    def note(events) -> None:
        now = time.time() - capture.source.start_time
        for ev in events:
            if ev.number not in seen and ev.t_end is not None:
                seen.add(ev.number)
                lags.append(now - ev.t_end)
    real_extend, real_unsettled = model.extend, model.set_unsettled
    model.extend = lambda batch: (note(batch), real_extend(batch))[1]
    model.set_unsettled = lambda held: (note(held), real_unsettled(held))[1]

    async def drive():
        sys.setswitchinterval(SWITCH)
        async with app.run_test(size=SIZE) as pilot:
            await pilot.pause(0.5)
            start = time.monotonic() + 0.3
            # Popen starts the writer and returns: the app polls it between pauses
            writer = subprocess.Popen(  # noqa: ASYNC220
                [sys.executable, __file__, "--feed-ptys", str(ptys[0][0]), str(ptys[1][0]),
                 "--live-seconds", str(seconds), "--seed", str(seed), "--start", repr(start)],
                pass_fds=(ptys[0][0], ptys[1][0]))
            while writer.poll() is None:
                await pilot.pause(0.1)
            await pilot.pause(1.5)   # let the last batch arrive
            return app.model.shown + len(app.model.unsettled)
    shown = asyncio.run(drive())
    stop_feed(app)
    # what was on the wire: the same bytes decoded from files
    tr = saturated(int(seconds * 1500) + 100, seed=seed)
    tmp = tempfile.mkdtemp(prefix="gimbalscope-tui-bench-")
    written = [w for w in tr.writes if w.t <= seconds]
    with open(os.path.join(tmp, "a.bin"), "wb") as f:
        f.write(b"".join(w.data for w in written if w.line == "A"))
    with open(os.path.join(tmp, "b.bin"), "wb") as f:
        f.write(b"".join(w.data for w in written if w.line == "B"))
    on_wire = sum(1 for _ in analyzer.open(os.path.join(tmp, "a.bin"), os.path.join(tmp, "b.bin"), baud=BAUD))
    lags.sort()
    p = lambda q: lags[min(len(lags) - 1, int(q * len(lags)))] * 1000
    print(f"3. live, two saturated {BAUD}-baud ptys for {seconds:.0f} s: {shown:,} events shown, {on_wire:,} "
          f"decoded from the same bytes ({'none dropped' if shown >= on_wire else f'{on_wire - shown} missing'}); "
          f"screen behind the wire p50 {p(0.5):.0f} ms, p95 {p(0.95):.0f} ms, max {lags[-1] * 1000:.0f} ms "
          f"over {len(lags):,} events (target <= 250 ms)")


def idle_figures(seconds: float) -> None:
    """``gimbalscope live`` on two quiet ptys, in a terminal of its own (a pty,
    as a user's): the share of a core the process uses while nothing arrives, from
    its CPU time (/proc/PID/stat utime + stime) over ``seconds`` after it settled."""
    import fcntl
    import pty
    import struct
    import subprocess
    import termios

    lines = []
    for _ in range(2):
        m, s = os.openpty()
        tty.setraw(s)
        lines.append((m, s, os.ttyname(s)))
    term_m, term_s = pty.openpty()
    fcntl.ioctl(term_s, termios.TIOCSWINSZ, struct.pack("HHHH", SIZE[1], SIZE[0], 0, 0))
    env = dict(os.environ, TERM="xterm-256color", COLUMNS=str(SIZE[0]), LINES=str(SIZE[1]))
    proc = subprocess.Popen([sys.executable, "-m", "analyzer", "live", lines[0][2], lines[1][2]],
                            stdin=term_s, stdout=term_s, stderr=term_s, env=env, cwd=ROOT, start_new_session=True)
    os.close(term_s)
    stop = threading.Event()

    def drain() -> None:   # the terminal: read what the TUI draws, so that it never waits to write
        while not stop.is_set():
            try:
                if not os.read(term_m, 65536):
                    return
            except OSError:
                return
    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    tick = os.sysconf("SC_CLK_TCK")

    def cpu() -> float:
        with open(f"/proc/{proc.pid}/stat") as f:
            fields = f.read().rpartition(")")[2].split()
        return (int(fields[11]) + int(fields[12])) / tick   # utime, stime (fields 14 and 15)
    try:
        time.sleep(5.0)   # started, first screen drawn
        if proc.poll() is not None:
            raise SystemExit(f"gimbalscope live ended early (status {proc.returncode})")
        c0, t0 = cpu(), time.monotonic()
        time.sleep(seconds)
        c1, t1 = cpu(), time.monotonic()
    finally:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        stop.set()
        os.close(term_m)
        for m, s, _name in lines:
            os.close(m)
            os.close(s)
    share = 100 * (c1 - c0) / (t1 - t0)
    print(f"4. idle live TUI: gimbalscope live on two quiet ptys, {SIZE[0]}x{SIZE[1]} terminal: {share:.2f} % of a "
          f"core over {t1 - t0:.0f} s ({c1 - c0:.2f} s of CPU; target <= 1 %)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--events", type=int, help="events of the recording (1,000,000; --first-screen: 100,000)")
    ap.add_argument("--live-seconds", type=float, default=10.0)
    ap.add_argument("--recording", help="reuse this MCAP (made if missing)")
    ap.add_argument("--feed-ptys", nargs=2, type=int, help=argparse.SUPPRESS)   # the wire process
    ap.add_argument("--view-figures", help=argparse.SUPPRESS)                  # the view process
    ap.add_argument("--no-live", action="store_true", help="skip the live figures")
    ap.add_argument("--first-screen", action="store_true",
                    help="only figure 0, the first screen from the process start (--events 100000 unless told)")
    ap.add_argument("--idle", type=float, metavar="SECONDS",
                    help="only the idle live TUI's CPU share, measured over SECONDS (e.g. 20)")
    ap.add_argument("--seed", type=int, default=5, help=argparse.SUPPRESS)
    ap.add_argument("--start", type=float, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.events is None:
        args.events = 100_000 if args.first_screen else 1_000_000
    if args.feed_ptys:
        feed_ptys(args.feed_ptys, args.live_seconds, args.seed, args.start)
        return
    if args.idle:
        idle_figures(args.idle)
        return
    if args.view_figures:
        import json
        print(json.dumps(view_figures(args.view_figures)))
        return
    path = args.recording or os.path.join(tempfile.gettempdir(), f"gimbalscope-tui-bench-{args.events}.mcap")
    if not os.path.exists(path) or not columns_usable(path):
        print(f"making a {args.events:,}-event recording at {path} (once, and again when its stored columns are "
              "not this decoder's) ...", flush=True)
        make_recording(args.events, path)
    first_screen_report(path, args.events)
    if args.first_screen:
        return
    view_report(path)
    baseline_keys()
    if not args.no_live:
        live_figures(args.live_seconds)


if __name__ == "__main__":
    main()
