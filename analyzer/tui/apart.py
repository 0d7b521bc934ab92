"""What the screen's helper processes share (decode_apart.py, doctor_apart.py):
starting one, its own first steps (off the terminal the screen is drawn on;
SIGTERM as an exception), and ending it."""

from __future__ import annotations

import os
import signal
import sys
import threading


def spawn(target, args: tuple, name: str):
    """Start ``target(*args, conn)`` in a new process; (process, the end of a
    one-way pipe it sends on), or None if no process can be had."""
    import multiprocessing
    # spawn: a fresh interpreter (fork would copy the screen's threads mid-flight)
    ctx = multiprocessing.get_context("spawn")
    parent, child = ctx.Pipe(duplex=False)
    process = ctx.Process(target=target, args=(*args, child), name=name, daemon=True)
    # the screen captures standard output and error (no descriptors): the first
    # process started (with multiprocessing's resource tracker) is given the real
    # ones, which it then points at /dev/null (``quiet``). Only from the screen's
    # own thread: the streams are the whole process's, and the screen puts its
    # own back as it closes; from another thread (a doctor started once a file has
    # loaded) the tracker runs already and nothing needs them
    swap = threading.current_thread() is threading.main_thread()
    saved = sys.stdout, sys.stderr
    if swap:
        sys.stdout, sys.stderr = sys.__stdout__, sys.__stderr__
    try:
        process.start()
    except Exception:   # no process to be had (out of processes, memory, descriptors)
        parent.close()
        return None
    finally:
        if swap:
            sys.stdout, sys.stderr = saved
        child.close()
    return process, parent


def helper_started() -> None:
    """A helper process's first step. Nothing of it may reach the terminal the
    screen is drawn on; and the screen ends it with SIGTERM (``end``), taken as
    SystemExit so that its capture is closed on the way out (a large MCAP's
    reader process with it)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    signal.signal(signal.SIGTERM, _ended)


def _ended(signum, frame) -> None:
    raise SystemExit(0)


def end(process) -> None:
    """End a helper process if it still runs (the screen is closing)."""
    if process is not None and process.is_alive():
        process.terminate()
        process.join(timeout=5)
