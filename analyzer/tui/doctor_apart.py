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
(``apart_possible``). A doctor that fails in its process is said as a warning;
the view goes on without findings.
"""

from __future__ import annotations

import os
import stat
import threading
from collections.abc import Callable

from .apart import end, helper_started, spawn

NICENESS = 10   # the doctor's process yields to the screen's and the load's


def apart_possible(inputs: tuple[str, ...]) -> bool:
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


def findings_of(inputs: tuple[str, ...], options, command: str = "view") -> list:
    """The doctor's findings of the capture ``inputs`` (run in the doctor's process)."""
    from ..capture import open as open_capture
    from ..info import CaptureInfo
    from ..listeners import DoctorListener
    from ..runner import TapRunner

    capture = open_capture(*inputs, options=options)
    doctor = DoctorListener(tui=True)
    TapRunner(capture, [doctor], info=CaptureInfo.of(capture, command=command)).run()
    return doctor.findings


def _child(inputs, options, command, conn) -> None:
    helper_started()
    try:
        os.nice(NICENESS)
    except OSError:
        pass
    try:
        conn.send(("findings", findings_of(inputs, options, command)))
    except SystemExit:   # stopped by the screen, which is closing: nothing to say
        pass
    except BaseException as e:   # whatever it is, the screen hears of it, in one line
        conn.send(("error", f"{type(e).__name__}: {e}"))
    finally:
        conn.close()


class DoctorApart:
    """The doctor's process for one file. ``start()`` says whether it started;
    ``deliver_to(done)`` names who hears ``done(findings, error)`` when it ends
    (from a thread of its own; not when it is stopped)."""

    def __init__(self, inputs: tuple[str, ...], options, command: str = "view") -> None:
        self.inputs, self.options, self.command = inputs, options, command
        self.done: Callable[[list | None, str | None], None] | None = None
        self.process = None
        self._stopped = threading.Event()
        self._ready = threading.Event()
        self._lock = threading.Lock()   # a start and a stop from two threads (decode_apart.py)

    def start(self) -> bool:
        """Start the process (not once stopped); False if no process can be had."""
        with self._lock:
            return not self._stopped.is_set() and self._start()

    def _start(self) -> bool:
        started = spawn(_child, (self.inputs, self.options, self.command), "gimbalscope-doctor")
        if started is None:
            return False
        self.process, conn = started
        threading.Thread(target=self._wait, args=(conn,), name="gimbalscope-doctor-wait", daemon=True).start()
        return True

    @property
    def stopped(self) -> bool:
        return self._stopped.is_set()

    def deliver_to(self, done: Callable[[list | None, str | None], None]) -> None:
        self.done = done
        self._ready.set()

    def _wait(self, conn) -> None:
        try:
            what, value = conn.recv()
        except (EOFError, OSError):
            what, value = "error", "its process ended without a word"
        finally:
            conn.close()
        self._ready.wait()
        if self._stopped.is_set():
            return
        if what == "findings":
            self.done(value, None)
        else:
            self.done(None, value)

    def stop(self) -> None:
        """End the process if it still runs (the screen is closing)."""
        with self._lock:
            self._stopped.set()
        self._ready.set()
        end(self.process)


class HearsTheDoctorApart:
    """What a feed does with the word of a doctor in a process of its own
    (``findings_arrived``, from the thread that waited for it): the next batch
    carries it; once the last batch has gone, one more last batch does
    (``_send_last``). A doctor that failed is a warning on screen. The feed has
    ``doctor`` (an ``ApartFindings``), ``_end_lock``, ``_ended``, ``_warnings``,
    ``_findings`` and ``_doctor_error``."""

    def findings_arrived(self, findings: list | None, error: str | None) -> None:
        with self._end_lock:
            if error is not None:
                self._warnings.append(f"the wiring doctor stopped: {error}")
                self._doctor_error = error
            else:
                self.doctor.findings = findings   # the feed's last word, if the capture has not ended
                self._findings = findings
            if self._ended:
                self._send_last()

    def _send_last(self) -> None:
        raise NotImplementedError


class ApartFindings:
    """What the feed reads of the doctor (``checked``, ``findings``, as of a
    ``DoctorListener``) while the doctor runs apart: nothing until its process
    is done, then its findings, once."""

    def __init__(self) -> None:
        self.checked = False
        self.findings: list | None = None   # None: not known yet (the feed sends no change)
