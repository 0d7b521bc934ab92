"""``gimbalscope`` in a child process, for tests that talk to it while it runs.

Its standard output and error are read as they come, by threads, so a test waits
on what the tool says ("listening on …") instead of sleeping for a guess of how
long it takes to start: a loaded machine can take seconds to import the tool, and
bytes written to a port before it is open are flushed by the open.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable

from tests.conftest import ROOT

PATIENCE = 60.0        # seconds to wait for a condition: the machine may be busy
LISTENING = ": listening on "   # what ``live`` and ``doctor`` say once their ports are open


def wait_for(predicate: Callable[[], object], what: str, timeout: float = PATIENCE) -> None:
    end = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < end, f"gave up waiting for {what}"
        time.sleep(0.02)


class Child:
    """``gimbalscope ARGS``; ``out`` and ``err`` hold the lines read so far."""

    def __init__(self, *args: object, stdout: int = subprocess.PIPE) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "analyzer", *map(str, args)], stdout=stdout,
                                     stderr=subprocess.PIPE, text=True, cwd=ROOT)
        self.out: list[str] = []
        self.err: list[str] = []
        self._readers = [threading.Thread(target=self._read, args=(pipe, lines), daemon=True)
                         for pipe, lines in ((self.proc.stdout, self.out), (self.proc.stderr, self.err))
                         if pipe is not None]
        for reader in self._readers:
            reader.start()

    @staticmethod
    def _read(pipe, lines: list[str]) -> None:
        for line in pipe:
            lines.append(line)   # noqa: PERF402 - one at a time: the waiting test sees each line as it comes

    def wait_said(self, text: str, what: str = "") -> None:
        """Until a line of standard error holds ``text``; the child ending first fails."""
        wait_for(lambda: self.said(text) or self.proc.poll() is not None, what or repr(text))
        assert self.said(text), "".join(self.err)

    def said(self, text: str) -> bool:
        return any(text in line for line in list(self.err))

    def wait_listening(self) -> None:
        """Until the tap has its ports open and a signal would stop it cleanly."""
        self.wait_said(LISTENING, "the tap to listen")

    def stop(self, sig: int = signal.SIGINT) -> tuple[int, str, str]:
        """Send ``sig`` (if still running), wait for the end: (exit code, stdout, stderr)."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        return self.wait()

    def wait(self) -> tuple[int, str, str]:
        code = self.proc.wait(PATIENCE)
        for reader in self._readers:
            reader.join(PATIENCE)
        return code, "".join(self.out), "".join(self.err)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.wait()
