"""Work in a process of its own: a function started in a fresh interpreter, which
sends the process that started it messages on a one-way channel.

Used where a second core does part of the work (the MCAP reader process of a
large recording) or keeps it off a thread that must stay free (the TUI's
decoding and doctor processes). The fleet export's pool and Spark have their own.

- **A fresh interpreter**, started as ``python -c``, not multiprocessing: a fork
  would copy the caller's threads mid-flight (the TUI's, a live tap's), one of
  them perhaps holding a lock; multiprocessing's spawn imports the caller's main
  script again (a user's script without a main guard would run twice) and starts
  a resource tracker beside it. The child gets the caller's ``sys.path`` (its
  text entries, the ones imports read), and the function and its arguments,
  pickled, on its standard input.
- **The channel** is the child's standard output, taken over before the work
  starts: what the work prints goes where its standard error goes, which is
  nowhere, so nothing reaches a terminal a screen is drawn on. Each message is
  one pickle with its length before it, so a child that dies mid-message is
  told from one that sent something unreadable; on Linux its pipe holds a
  megabyte, so the child seldom waits on the reader (``_widen``). The channel carries the
  objects this package's own code sends, from a process it started; nothing
  read from a file or the network is unpickled.
- **Ending it**: SIGTERM is SystemExit in the child, so its ``finally`` clauses
  run (a decoding process closes its capture, and a reader process of its own
  with it); ``Worker.end`` asks so, and kills a child that does not listen. A
  child still running when the caller exits is ended then.
- **Prepared ahead**: a caller that knows which module's work it will start
  before it knows the arguments starts the process early (``prepared``): the
  child's interpreter starts and imports that module while the caller imports
  its own, and ``start`` hands it its work. ``view`` does so for its decoding
  process before any of the command's modules are imported (docs/tui.md).
"""

from __future__ import annotations

import atexit
import importlib
import json
import os
import pickle
import signal
import struct
import subprocess
import sys
import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import IO, TypeVarTuple

_Args = TypeVarTuple("_Args")

_LENGTH = struct.Struct("<Q")   # a message's length, before its pickle
# the child's first steps: the caller's sys.path, then the work (``_serve``)
_BOOT = f"import sys, json; sys.path[:] = json.loads(sys.argv[1]); from {__name__} import _serve; _serve()"
PIPE_BYTES = 1 << 20   # the channel's pipe (``_widen``): what Linux lets any user ask for (pipe-max-size)
END_WAIT = 5.0   # seconds a child has to end on SIGTERM before it is killed


class Sender:
    """The child's end of the channel. Unbuffered: a message sent is on its way,
    and a child ended in the middle of one has nothing left to flush."""

    def __init__(self, fd: int) -> None:
        self._fd = fd

    def send(self, message: object) -> None:
        """Send ``message`` (pickled) at once."""
        self.send_bytes(pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL))

    def send_bytes(self, payload: bytes) -> None:
        """Send one message already pickled."""
        self._write(_LENGTH.pack(len(payload)))
        self._write(payload)

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self._fd, view):]

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class Receiver:
    """The parent's end of the channel."""

    def __init__(self, stream: IO[bytes]) -> None:
        self._stream = stream

    def recv(self) -> object:
        """The next message. EOFError: the child has ended without sending one
        (or was ended in the middle of it); a message that does not unpickle
        raises what unpickling it raises."""
        return pickle.loads(self.recv_bytes())

    def recv_bytes(self) -> bytes:
        head = self._stream.read(_LENGTH.size)
        if len(head) < _LENGTH.size:
            raise EOFError("the process ended")
        size, = _LENGTH.unpack(head)
        payload = self._stream.read(size)
        if len(payload) < size:
            raise EOFError("the process ended in the middle of a message")
        return payload

    def close(self) -> None:
        self._stream.close()


def channel() -> tuple[Receiver, Sender]:
    """A channel with no process behind it (a pipe within this one)."""
    read, write = os.pipe()
    return Receiver(os.fdopen(read, "rb")), Sender(write)


class Worker:
    """A started child: ``messages`` is what it sends."""

    def __init__(self, process: subprocess.Popen[bytes], messages: Receiver) -> None:
        self._process = process
        self.messages = messages

    @property
    def pid(self) -> int:
        """The child's process id."""
        return self._process.pid

    def is_alive(self) -> bool:
        return self._process.poll() is None

    def kill(self) -> None:
        """End it at once, with no chance to close anything (as the kernel's OOM killer would)."""
        if self.is_alive():
            self._process.kill()

    def give(self, work: Callable[..., None], args: tuple) -> bool:
        """Hand it its work (a prepared child waits for it on its standard input);
        False if it ended before it could read it."""
        stdin = self._process.stdin
        assert stdin is not None   # a pipe, closed once the work is on it
        try:
            with stdin:
                pickle.dump((work, args), stdin, protocol=pickle.HIGHEST_PROTOCOL)
        except BaseException as e:
            self.messages.close()
            self.end()
            if isinstance(e, OSError):   # the child ended before it read its work
                return False
            raise
        return True

    def discard(self) -> None:
        """End a child that was never given work, and close its pipes."""
        self.end()
        self.messages.close()
        if self._process.stdin is not None:
            self._process.stdin.close()

    def end(self, wait: float = END_WAIT) -> None:
        """End it if it still runs (SIGTERM, then SIGKILL after ``wait`` seconds), and reap it."""
        if self.is_alive():
            self._process.terminate()
            try:
                self._process.wait(wait)
            except subprocess.TimeoutExpired:
                self._process.kill()
        self._process.wait()


_running: weakref.WeakSet[Worker] = weakref.WeakSet()


@atexit.register
def _end_all() -> None:
    for worker in list(_running):
        worker.end()


def start(work: Callable[[*_Args, Sender], None], args: tuple[*_Args]) -> Worker | None:
    """Run ``work(*args, sender)`` in a process of its own; None if no process
    can be had (out of processes, memory, descriptors). ``work`` is a function
    at the top of a module (the child imports it by name); ``args`` are pickled.
    The child's standard error (and what it prints) goes nowhere. A process
    ``prepared`` for ``work``'s module is taken rather than one started."""
    worker = _prepared.pop(work.__module__, None)
    if worker is not None and worker.give(work, args):
        return worker
    worker = _spawn()
    return worker if worker is not None and worker.give(work, args) else None


_prepared: dict[str, Worker] = {}   # module → a process that has imported it, waiting for its work


@contextmanager
def prepared(module: str) -> Iterator[None]:
    """Within it, the next ``start`` of a function of ``module`` runs in a process
    started on entry, which has imported ``module`` meanwhile: a caller that
    knows early which work it will start has the child's imports overlap its
    own (``view``'s decoding process, started before the command's modules are
    imported: docs/tui.md). One that no ``start`` took is ended on exit."""
    worker = None if module in _prepared else _spawn(module)
    if worker is not None:
        _prepared[module] = worker
    try:
        yield
    finally:
        if worker is not None and _prepared.get(module) is worker:   # no start took it
            del _prepared[module]
            worker.discard()


def _spawn(*preload: str) -> Worker | None:
    """A fresh interpreter that imports ``preload``, then waits for its work (``_give``)."""
    try:
        process = subprocess.Popen([sys.executable, "-c", _BOOT, json.dumps(_path()), *preload],
                                   stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    except OSError:
        return None
    assert process.stdin is not None and process.stdout is not None   # both are pipes
    _widen(process.stdout.fileno())
    worker = Worker(process, Receiver(process.stdout))
    _running.add(worker)
    return worker


def _widen(pipe: int) -> None:
    """Let the pipe hold a whole message (a loading file's chunk of columns is
    about a megabyte): with Linux's default 64 kB the child waits at every one
    until the receiving thread, which shares its interpreter with a busy screen,
    has read most of it. Where the system refuses, the pipe stays as it is."""
    if sys.platform != "linux":
        return
    import fcntl
    try:
        fcntl.fcntl(pipe, fcntl.F_SETPIPE_SZ, PIPE_BYTES)
    except OSError:   # above the system's or the user's limit for pipes
        pass


def _path() -> list[str]:
    """The caller's ``sys.path``, its text entries only: the import system skips
    any other (bytes, a path object), so decoding one for the child would let it
    import from a folder its caller does not, and JSON could not carry it as it is."""
    return [entry for entry in sys.path if isinstance(entry, str)]


def _serve() -> None:
    """The child: the channel taken from standard output, SIGTERM as SystemExit,
    then the work."""
    sender = Sender(os.dup(1))
    os.dup2(2, 1)
    signal.signal(signal.SIGTERM, _ended)
    try:
        for module in sys.argv[2:]:   # prepared: imported while the caller makes up its mind
            importlib.import_module(module)
        work, args = pickle.load(sys.stdin.buffer)
        work(*args, sender)
    except (SystemExit, KeyboardInterrupt):   # ended by the caller, or Ctrl-C: nothing to say
        pass
    finally:
        sender.close()


def _ended(signum: int, frame: object) -> None:
    raise SystemExit(0)
