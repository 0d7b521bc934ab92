"""The wiring doctor of a file being viewed, off the load's path: in a process of
its own, which reads the file again and hands back its findings when it is done.

Loading a file into the TUI means decoding, pairing and storing its events; the
doctor looks at every event too (its evidence, its per-device trends), a
fifth of the load's time when it ran in the capture thread. Beside it, in
another process at a lower priority, it costs the load nothing on a machine
with a core to spare, and its findings reach the screen (the status line, the
findings screen) when it is done, often before the load is.

Only where the file can be read twice: a live tap, a replay (paced, so not a
load) and standard input or a FIFO keep the doctor in the capture thread
(``readable_by_another_process``). A doctor that fails in its process is said as
a warning; the view goes on without findings.

The feed that holds a ``DoctorProcess`` (the capture thread's or the decoding
process's, feed.py and decode_process.py) puts its word in the next batch it
sends (``take``), and sends its last batch through it (``last_batch``): a word
that comes after that goes in one more last batch.
"""

from __future__ import annotations

import os
import stat
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .. import worker_process
from ..analysis.findings import Finding
from ..capture import Options

NICENESS = 10   # the doctor's process yields to the screen's and the load's


def readable_by_another_process(inputs: tuple[str, ...]) -> bool:
    """Can the capture's files be read again by another process (regular files)?"""
    if not inputs:
        return False
    for path in inputs:
        try:
            if not stat.S_ISREG(os.stat(path).st_mode):
                return False
        except (OSError, ValueError):
            return False
    return True


def findings_of(inputs: tuple[str, ...], options: Options, command: str | None = "view") -> list[Finding]:
    """The doctor's findings of the capture ``inputs`` (run in the doctor's process)."""
    from ..capture import open as open_capture
    from ..info import CaptureInfo
    from ..listeners import DoctorListener
    from ..runner import TapRunner

    capture = open_capture(*inputs, options=options)
    doctor = DoctorListener(tui=True)
    TapRunner(capture, [doctor], info=CaptureInfo.of(capture, command=command)).run()
    return doctor.findings


def _examine(inputs: tuple[str, ...], options: Options, command: str | None, sender: worker_process.Sender) -> None:
    """The doctor's process: ("findings", [Finding…]) or ("error", why), once."""
    try:
        os.nice(NICENESS)
    except OSError:
        pass
    try:
        sender.send(("findings", findings_of(inputs, options, command)))
    # KeyboardInterrupt too: a Ctrl-C that reaches this process (it shares the
    # terminal's process group) is said to the screen as what stopped it
    # ("KeyboardInterrupt: "), not left for it to hear as an end without a word
    except (Exception, KeyboardInterrupt) as e:   # noqa: BLE001 - whatever it is, the screen hears of it, in one line
        sender.send(("error", f"{type(e).__name__}: {e}"))


@dataclass(frozen=True)
class DoctorWord:
    """What the doctor's process said: its findings, or why it has none."""

    findings: list[Finding] | None
    error: str | None = None

    @property
    def warning(self) -> str | None:
        """A doctor that failed, as the status line says it."""
        return None if self.error is None else f"the wiring doctor stopped: {self.error}"


class DoctorProcess:
    """The doctor's process for one file, as a feed holds it. ``start()`` says
    whether it started; ``stop()`` ends it (the screen is closing), after which
    its word is not heard."""

    def __init__(self, inputs: tuple[str, ...], options: Options, command: str | None = "view") -> None:
        self.inputs, self.options, self.command = inputs, options, command
        self.process: worker_process.Worker | None = None
        self._stopped = False
        self._starting = threading.Lock()     # a start and a stop from two threads (decode_process.py)
        self._news = threading.RLock()        # the word, and the feed's last batch
        self._word: DoctorWord | None = None
        self._again: Callable[[], object] | None = None   # one more last batch, once the last has gone

    def start(self) -> bool:
        """Start the process (not once stopped); False if no process can be had."""
        with self._starting:
            if self._stopped:
                return False
            worker = worker_process.start(_examine, (self.inputs, self.options, self.command))
            if worker is None:
                return False
            self.process = worker
        threading.Thread(target=self._wait, args=(worker,), name="gimbalscope-doctor-wait", daemon=True).start()
        return True

    @property
    def stopped(self) -> bool:
        return self._stopped

    def stop(self) -> None:
        """End the process if it still runs."""
        with self._starting:
            self._stopped = True
        if self.process is not None:
            self.process.end()

    def tell(self, findings: list[Finding] | None, error: str | None = None) -> None:
        """The doctor's word (from the thread that waited for its process, or from a
        feed that could not start it): the next batch carries it."""
        with self._news:
            if self._stopped:
                return
            self._word = DoctorWord(findings, error)
            if self._again is not None:
                self._again()

    def take(self) -> DoctorWord | None:
        """The word not yet sent, once (the feed is making a batch)."""
        with self._news:
            word, self._word = self._word, None
            return word

    def last_batch(self, send: Callable[[], object], again: Callable[[], object]) -> None:
        """``send`` the feed's last batch; a word that comes after it is sent by
        ``again``, one more last batch."""
        with self._news:
            send()
            self._again = again

    def _wait(self, worker: worker_process.Worker) -> None:
        try:
            message: Any = worker.messages.recv()
        except (EOFError, OSError):
            message = ("error", "its process ended without a word")
        except Exception as e:   # noqa: BLE001 - a word that cannot be read is said as the doctor's failure
            message = ("error", f"its word could not be read: {type(e).__name__}: {e}")
        finally:
            worker.messages.close()
            worker.end()   # it has said its last word: reaped now, not left a zombie until the screen closes
        what, value = message
        if what == "findings":
            self.tell(value)
        else:
            self.tell(None, value)
