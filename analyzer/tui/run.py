"""Open the TUI on a capture: the glue between the CLI and the app. The capture
is fed to the screen by a capture thread or a decoding process (feed_choice.py);
quitting stops it and finalises any recording.

Nothing of the screen (Textual, the app's modules) is imported before
``make_app``: ``run_app`` starts a viewed file's decoding process first, whose
interpreter then imports while this one imports the screen."""

from __future__ import annotations

import argparse
import difflib
import importlib
import os
import pkgutil
import signal
import sys
import tomllib
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from ..capture import Capture
from ..errors import KeymapError, UsageError
from ..info import CaptureInfo
from ..runner import Listener
from ..worker_process import Worker
from .feed import FeedBatch, KeptWindows, ScreenFeed
from .feed_choice import Loading, choose_feed, early_decoding
from .model import CaptureModel
from .model.marks_kept import MarksKept

if TYPE_CHECKING:
    from ..talk.session import TalkSession
    from ..writers.mcap import McapWriter
    from .app import GimbalscopeApp

# A capture thread decodes flat out while a file loads (one that is not decoded
# in a process of its own: feed_choice.py); with the interpreter's default 5 ms
# switch interval the screen's thread waits that long for every turn and the
# first screen took over a second. Switch more often (live reader threads also
# stamp reads more promptly: see cli/live.py).
SWITCH = 0.0002


def load_keymap(path: str | None) -> dict[str, str]:
    """A TOML file of binding id = "keys" (e.g. ``"app.filter" = "ctrl+l"``)."""
    if not path:
        return {}
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except OSError as e:
        raise KeymapError(f"{path}: cannot read keymap: {e.strerror or e}") from None
    except tomllib.TOMLDecodeError as e:
        raise KeymapError(f"{path}: not a TOML keymap: {e}") from None
    # ids have dots: `app.filter = "ctrl+l"` is a table in TOML, `"app.filter" = ...` a key
    flat: dict[str, object] = {}

    def walk(prefix: str, table: dict) -> None:
        for k, v in table.items():
            if isinstance(v, dict):
                walk(f"{prefix}{k}.", v)
            else:
                flat[f"{prefix}{k}"] = v
    walk("", data)
    keymap = {k: v for k, v in flat.items() if isinstance(v, str)}
    bad = [k for k in flat if k not in keymap]
    if bad:
        raise KeymapError(f"{path}: keymap values must be key strings: {', '.join(bad)}")
    check_ids(path, keymap)
    return keymap


def binding_ids() -> set[str]:
    """Every id a keymap can rebind, read from the Binding(id=...) of each widget,
    screen and app class of this package (so a new binding is known at once)."""
    from textual.binding import Binding
    from textual.dom import DOMNode

    package = __name__.rpartition(".")[0]
    for mod in pkgutil.walk_packages(sys.modules[package].__path__, prefix=package + "."):
        importlib.import_module(mod.name)   # screens are imported lazily by the app
    ids: set[str] = set()
    todo = [DOMNode]
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        if cls.__module__.startswith(package + "."):
            ids.update(b.id for b in vars(cls).get("BINDINGS", ()) if isinstance(b, Binding) and b.id)
    return ids


def check_ids(path: str, keymap: dict[str, str]) -> None:
    """Textual ignores an id it does not know; a typo would silently change nothing."""
    valid = binding_ids()
    unknown = [k for k in keymap if k not in valid]
    if not unknown:
        return
    parts = []
    for k in unknown:
        near = difflib.get_close_matches(k, sorted(valid), n=3, cutoff=0.6)
        parts.append(f"{k!r} (did you mean {' or '.join(near)}?)" if near else repr(k))
    s = "s" if len(unknown) > 1 else ""
    raise KeymapError(f"{path}: unknown binding id{s} {', '.join(parts)}; `?` in the TUI lists the ids")


def make_app(capture: Capture, *, mode: str, ports: list[str] | None = None, speed: float = 1.0,
             recorder: McapWriter | None = None, record_path: str | None = None, record_lean: bool = False,
             info: CaptureInfo | None = None, keymap: dict[str, str] | None = None,
             filter_text: str | None = None, listeners: Sequence[Listener] = (),
             decoding: Worker | None = None, talk: TalkSession | None = None,
             windows: KeptWindows | None = None) -> GimbalscopeApp:
    """mode: live (follow on, record key), replay (paced, follow on), view (a file,
    follow off). The capture starts when the app mounts, fed as feed_choice.py
    chooses, with ``recorder`` (``--record``), ``listeners`` (the ``--foxglove``
    server), the doctor and the feed as the runner's listeners; ``info`` is the one
    ``recorder`` and ``listeners`` were made with. ``record_lean``: the record
    key writes lean recordings (``live --lean``, docs/mcap.md). ``decoding``: the
    file's decoding process, started already (``early_decoding``): the feed
    adopts it. ``talk``: the port the ``:`` prompt sends on (``live --talk``).
    ``windows``: ``live --keep``'s keeper, among ``listeners``, whose count the status line shows."""
    from .app import GimbalscopeApp  # the screen's imports: after run_app has started the decoding

    model = CaptureModel(follow=mode != "view")
    if filter_text:
        model.set_filter(filter_text)   # already checked by the CLI
    if mode == "replay":
        model.replay.start(speed)
    info = info or CaptureInfo.of(capture, command=mode)

    loading = Loading(capture, info, mode, recorder, listeners, record_lean, decoding, windows)

    def make_feed(deliver: Callable[[FeedBatch], None]) -> ScreenFeed:
        return choose_feed(loading, deliver)

    source = " + ".join(ports) if ports else info.source
    # a file's marks are kept beside it; a live tap's in its recording
    marks_kept = MarksKept(capture.inputs) if mode != "live" and capture.inputs and all(
        os.path.isfile(name) for name in capture.inputs) else None
    return GimbalscopeApp(model, make_feed, mode=mode, source=source, settings=info.serial_settings,
                          record_path=record_path, keymap=keymap, talk=talk, marks_kept=marks_kept)


def stop_feed(app: GimbalscopeApp, listeners: Sequence[Listener] = ()) -> list[str]:
    """Stop the capture (its thread, its processes) and finalise its recording;
    what it has to say. ``listeners`` (make_app's) are closed first: one may hold
    the capture thread (a replay paced for Foxglove)."""
    feed = app.feed
    for listener in listeners:
        listener.close()
    if feed is None:
        return []
    feed.stop()
    feed.join(timeout=5.0)
    return feed.notes


def run_app(capture: Capture, **kw: Any) -> int:
    """The TUI until it quits; then what the capture had to say (recordings written).

    A file viewed has its decoding process started first, before the screen's
    imports (make_app's): the two interpreters import side by side, and the
    first rows are there about when the screen is (docs/tui.md, "Loading a file")."""
    mode, listeners = kw["mode"], kw.get("listeners", ())
    info = kw.pop("info", None) or CaptureInfo.of(capture, command=mode)
    decoding = early_decoding(Loading(capture, info, mode, kw.get("recorder"), listeners))
    try:
        app = make_app(capture, info=info, decoding=decoding, **kw)
        old = signal.signal(signal.SIGTERM, lambda *_: app.call_later(app.exit))
        switch = sys.getswitchinterval()
        sys.setswitchinterval(SWITCH)
        try:
            app.run()
        finally:
            sys.setswitchinterval(switch)
            signal.signal(signal.SIGTERM, old)
            notes = stop_feed(app, listeners)
    finally:
        if decoding is not None:
            decoding.end()   # its feed has ended it, unless the screen never came to make one
    # "serving Foxglove on …" is for the screen: once it has closed, nothing serves
    screen_only = {l.announcement for l in listeners}
    for note in (n for n in notes if n not in screen_only):
        print(f"gimbalscope: {note}", file=sys.stderr)
    return 0


def keymap_from(args: argparse.Namespace) -> dict[str, str]:
    """--keymap, read and checked; a bad one is a UsageError (one line, exit 2)."""
    try:
        return load_keymap(getattr(args, "keymap", None))
    except KeymapError as e:
        raise UsageError(str(e)) from None


def open_tui(capture: Capture, args: argparse.Namespace, *, mode: str, speed: float = 1.0,
             keymap: dict[str, str] | None = None, info: CaptureInfo | None = None,
             listeners: Sequence[Listener] = ()) -> int:
    """``replay`` and ``view``: the TUI on a capture file (--keymap, --filter honoured;
    pass ``keymap`` when it was read already), with ``listeners`` beside the screen
    (``replay --foxglove``; ``info`` the one they were made with)."""
    if keymap is None:
        keymap = keymap_from(args)
    return run_app(capture, mode=mode, speed=speed, keymap=keymap, filter_text=getattr(args, "filter", None),
                   info=info, listeners=listeners)
