"""How far the capture files have been read, for progress bars: ``READS``, the
one ``ReadMeter`` of this process, which every input file is handed to when it
is opened (analyzer/sources/files.py)."""

from __future__ import annotations

import os
import stat
import threading
import weakref
from typing import BinaryIO


def _NO_HANDLE() -> None:
    """A weak reference to no file: a file read by another process."""
    return


class ReadMeter:
    """How far the capture files have been read: bytes read of their size on
    disk, for a progress bar (analyzer/listeners/progress.py).

    Every input file is opened in one place (``files.open_input``), which hands
    the open file to ``track``; nothing is counted per read. The position is the
    file's offset, asked of the system (``lseek``) when ``done()`` is called, from
    any thread. So a compressed input counts its compressed bytes, an MCAP its
    file bytes, and the parts of a recording all together; a file opened again
    (read from the start once more) counts once, at its newest position. A pipe
    or terminal has no size: then ``total()`` is None.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._files: dict[object, list] = {}   # file identity → [size or None, newest handle ref, fd, position]

    def clear(self) -> None:
        """Forget every file (a new command starts)."""
        with self._lock:
            self._files.clear()

    def track(self, f: BinaryIO) -> None:
        """Count ``f``, a binary file just opened for reading."""
        try:
            fd = f.fileno()
            st = os.fstat(fd)
            key: object = (st.st_dev, st.st_ino) if stat.S_ISREG(st.st_mode) else ("stream", id(f))
            size = st.st_size if stat.S_ISREG(st.st_mode) else None
            ref = weakref.ref(f)
        except (OSError, ValueError, TypeError, AttributeError):   # no descriptor: nothing to ask
            return
        with self._lock:
            self._files[key] = [size, ref, fd, 0]

    def report(self, path: str, position: int) -> None:
        """``path`` is being read elsewhere (the MCAP reader process) and has got
        to ``position``: counted as read, whatever this process's handle says."""
        try:
            st = os.stat(path)
        except OSError:
            return
        key = (st.st_dev, st.st_ino)
        with self._lock:
            entry = self._files.get(key)
            if entry is None:
                entry = self._files[key] = [st.st_size, None, -1, 0]
            entry[1] = _NO_HANDLE   # the position is reported, not asked of a handle
            entry[3] = max(entry[3], position)

    def total(self) -> int | None:
        """The files' sizes together; None when one has none (a pipe) or none is open."""
        with self._lock:
            sizes = [entry[0] for entry in self._files.values()]
        if not sizes or None in sizes:
            return None
        return sum(sizes)

    def done(self) -> int:
        """Bytes read so far (each file's newest handle's offset, or where it was
        last seen once closed), each at most its size."""
        with self._lock:
            entries = list(self._files.values())
        read = 0
        for entry in entries:
            size, ref, fd, position = entry
            f = ref()
            if f is not None and not f.closed:
                try:
                    position = entry[3] = os.lseek(fd, 0, os.SEEK_CUR)
                except OSError:
                    pass
            read += position if size is None else min(position, size)
        return read


# The capture files of this process (one command reads one capture at a time).
READS = ReadMeter()
