"""How the screen's capture is fed: the first of ``FEED_CASES`` whose case holds
and whose processes can be had (docs/tui.md, "Loading a file").

| case | the feed |
|---|---|
| a file viewed that another process can read, nothing else listening | a decoding process (``ProcessFeed``), the doctor in another: beside it with ``DOCTOR_BESIDE_CORES`` cores, else once the file has loaded |
| a file viewed that another process can read | a capture thread (``Feed``), the doctor in a process of its own |
| anything else: a live tap, a replay, a pipe; or no process to be had | a capture thread, the doctor in its runner |

A capture thread is a ``LiveFeed``, a ``Feed`` or a ``StreamFeed`` by its input
(``feed_class``).

The first case's decoding process may be started before the screen is made
(``early_decoding``, as ``run_app`` does): its interpreter then imports while
the screen's does, and the feed adopts it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

from ..capture import Capture
from ..info import CaptureInfo
from ..listeners import DoctorListener
from ..runner import Listener, TapRunner
from ..worker_process import Worker
from .decode_process import ProcessFeed
from .doctor_process import DoctorProcess, readable_by_another_process
from .feed import FeedBatch, KeptWindows, ScreenFeed, feed_class

if TYPE_CHECKING:
    from ..writers.mcap import McapWriter

Deliver = Callable[[FeedBatch], None]


@dataclass(frozen=True)
class Loading:
    """What the screen loads, and what else listens to it (make_app's arguments)."""

    capture: Capture
    info: CaptureInfo
    mode: str                                 # live, replay, view
    recorder: McapWriter | None = None        # --record
    listeners: Sequence[Listener] = ()        # the --foxglove server
    record_lean: bool = False
    decoding: Worker | None = None            # the first case's process, started already (early_decoding)
    windows: KeptWindows | None = None        # --keep: the keeper (also among ``listeners``)

    def viewed_file(self) -> bool:
        """A file viewed that another process can read again."""
        return self.mode == "view" and readable_by_another_process(self.capture.inputs)

    def viewed_file_alone(self) -> bool:
        """A file viewed that another process can read again, which nothing but
        the screen hears (no recorder, no listener)."""
        return self.viewed_file() and self.recorder is None and not self.listeners

    def anything(self) -> bool:
        return True

    def doctor_process(self) -> DoctorProcess:
        return DoctorProcess(self.capture.inputs, self.capture.options, command=self.info.command)


def decoding_process(loading: Loading, deliver: Deliver) -> ScreenFeed | None:
    """The file decoded in a process of its own, the doctor in another."""
    feed = ProcessFeed(loading.capture.inputs, loading.capture.options, deliver, command=loading.info.command,
                       doctor=loading.doctor_process(), started=loading.decoding)
    return feed if feed.spawn() else None


def early_decoding(loading: Loading) -> Worker | None:
    """The first case's decoding process, started now, before the screen is made
    (hand it over as ``Loading.decoding``); None where that case does not hold, or
    no process can be had (the case then tries once more, and the cases go on
    as they would)."""
    if not loading.viewed_file_alone():   # the first case (FEED_CASES)
        return None
    return ProcessFeed.start_process(loading.capture.inputs, loading.capture.options, loading.info.command)


def thread_doctor_process(loading: Loading, deliver: Deliver) -> ScreenFeed | None:
    """A capture thread, the doctor in a process of its own."""
    doctor = loading.doctor_process()
    return capture_thread(loading, deliver, doctor) if doctor.start() else None


def thread_doctor_in_runner(loading: Loading, deliver: Deliver) -> ScreenFeed:
    """A capture thread, the doctor in its runner."""
    return capture_thread(loading, deliver, None)


def capture_thread(loading: Loading, deliver: Deliver, doctor_process: DoctorProcess | None) -> ScreenFeed:
    """A capture thread with the recorder and listeners, and the doctor in its
    runner unless it has ``doctor_process``."""
    doctor = DoctorListener(tui=True) if doctor_process is None else None
    # ``listeners`` beside the recorder: both hear the doctor's notes after the same events
    heard = [listener for listener in (loading.recorder, *loading.listeners, doctor) if listener is not None]
    runner = TapRunner(loading.capture, heard, info=loading.info)
    feed = feed_class(runner)(runner, deliver, doctor, recorder=loading.recorder, record_lean=loading.record_lean,
                              doctor_process=doctor_process, windows=loading.windows)
    runner.add_listener(feed)   # last: it reads the doctor's findings of each step
    return feed


class FeedCase(NamedTuple):
    holds: Callable[[Loading], bool]
    way: Callable[[Loading, Deliver], ScreenFeed | None]   # None: its process could not be had


FEED_CASES = (   # in order (module doc)
    FeedCase(Loading.viewed_file_alone, decoding_process),
    FeedCase(Loading.viewed_file, thread_doctor_process),
    FeedCase(Loading.anything, thread_doctor_in_runner),
)


def choose_feed(loading: Loading, deliver: Deliver) -> ScreenFeed:
    """The feed of the first case that holds and whose processes can be had."""
    for case in FEED_CASES:
        if case.holds(loading) and (feed := case.way(loading, deliver)) is not None:
            return feed
    raise AssertionError("the last case holds always, and its way needs no process")
