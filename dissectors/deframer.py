"""Incremental, pure deframer for one serial line (spec §1.4, Table 1).

``Deframer.feed(data, t)`` takes the next bytes of a line and returns the events
completed by them: frames, simple responses (ACK/NAK/NIC) and coalesced noise
runs, each with the absolute offset of its first byte in the line's stream.
It does no I/O and never raises on wire bytes: anything malformed becomes an
event with problems attached.

Decisions only ever depend on bytes already seen plus "no more bytes are coming
before a silence" (``finish``/``idle``/``skip`` or a timed gap), so feeding a stream
in any split gives the same events.

Memory is bounded: a noise run is emitted in pieces of at most ``NOISE_PIECE``
bytes, cut every ``NOISE_PIECE`` bytes from the run's start (absolute offsets, so
the cut does not depend on how the bytes were split), and no more than one piece
plus one frame is ever held.

How broken input is handled (docs/decoding.md, "Deframing"):
- A frame whose checksum fails is re-examined before it is reported: if a valid
  frame starts inside it, that frame wins (a corrupted length byte must not
  swallow the next good frame); if the bytes up to the next frame start check out
  with another length, the length byte was corrupted and the frame is repaired.
- With time known, a silence longer than ``frame_gap`` inside a frame means the
  frame was cut short.
- A failed candidate that ends exactly where something else begins, or whose payload
  is mostly printable, is reported as a frame with a bad checksum; otherwise its
  start byte is treated as noise and deframing goes on.
"""

from __future__ import annotations

import os
import re
from bisect import bisect_right
from collections.abc import Callable
from typing import Protocol

from .event import ACK as K_ACK
from .event import COMMAND, FRAME, NOISE, RESULT, Event
from .event import NAK as K_NAK
from .event import NIC as K_NIC
from .problems import CHECKSUM, LENGTH, TRUNCATED, Problem
from .problems import NOISE as NOISE_PROBLEM
from .wire import ACK, NAK, NIC, START, LineSettings


class _BufferLoop(Protocol):
    """The C loop over a buffer (dissectors/_deframe.c, ``deframe``): from index
    ``i``, it appends the events of what needs no decision to ``out`` and returns
    the index it stopped at. ``segments``: a timed buffer's chunk offsets, times
    and byte times."""
    def __call__(self, buf: bytes, i: int, kinds: tuple[str | None, ...], line: str, frame_kind: str,
                 base: int, out: list[Event], /, *segments: list[int] | list[float]) -> int: ...


# One read that is exactly one token, as its event, or None (``Deframer._whole``).
_WholeRead = Callable[[bytes, float | None, float, int, str, str, tuple[str | None, ...]], Event | None]

_SIMPLE = {ACK: K_ACK, NAK: K_NAK, NIC: K_NIC}
_FRAME_KIND = {"A": COMMAND, "B": RESULT}
_MAX_FRAME = 256 + 7
NOISE_PIECE = 4096   # bytes: the longest noise event (a longer run comes in pieces)
# bytes that can begin something other than noise: a frame, or a simple response
_NOT_NOISE = re.compile(b"[" + re.escape(bytes([START, ACK, NAK, NIC])) + b"]")
_START = re.compile(re.escape(bytes([START])))   # line A: only a frame


_C_INTERFACE = 4   # the version of deframe() and whole() this module calls (_deframe.c, INTERFACE)


def _compiled() -> tuple[_BufferLoop | None, _WholeRead | None]:
    """The C loop for whole valid frames and simple responses, and its one-read
    form (dissectors/_deframe.c: ``deframe``, ``whole``), or Nones: not built (no
    compiler at install), or ``GIMBALSCOPE_PURE=1`` in the environment. Both give
    the same events; the pure code below is the reference."""
    if os.environ.get("GIMBALSCOPE_PURE", "") not in ("", "0"):
        return None, None
    try:
        from . import _deframe
    except ImportError:
        return None, None
    if _deframe.INTERFACE != _C_INTERFACE:   # built from another version of _deframe.c
        return None, None
    _deframe.configure(Event("", 0, NOISE, b""), Event.__slots__)
    return _deframe.deframe, _deframe.whole


_BUILT = _compiled()
_c_loop, _c_whole = _BUILT
COMPILED = _c_loop is not None   # whether this process deframes with the C loop


def use_compiled_loop(compiled: bool) -> bool:
    """Deframe in this process with the C loop (``compiled``, when it was built)
    or with the pure-Python loop, from the next read on; returns whether the C
    loop was in use before. The two give the same events (the tests run both);
    ``GIMBALSCOPE_PURE=1`` makes the choice for a whole process."""
    global _c_loop, _c_whole
    before = _c_loop is not None
    _c_loop, _c_whole = _BUILT if compiled else (None, None)
    return before


def _suspect(buf: bytes, start: int, end: int) -> bool:
    """A payload that carries a start byte: payloads are ASCII (§1.4.1.2), so the
    frame may be a broken header whose checksum matched by chance (1 in 256),
    swallowing the frames after it."""
    return buf.find(START, start, end) != -1


def _printable_share(data: bytes | bytearray) -> float:
    if not data:
        return 0.0
    return sum(1 for b in data if 0x20 <= b < 0x7F) / len(data)


class Deframer:
    """Turns one line's byte stream into events.

    line: "A" (controller→device), "B" (device→controller) or "AB" (a single-line
    tap carrying both). Frames come out as ``command`` on A, ``result`` on B and
    ``frame`` on AB (pairing decides). Simple response bytes are recognised on B
    and AB only; on A they are noise.

    settings: the line's ``LineSettings`` (dissectors/wire.py), which a capture
    shares with the line's source and changes when the link's rate changes; the
    deframer reads its byte time (seconds per character, to give every byte a
    time) and frame gap (a silence longer than this inside a frame cuts it;
    timed input only) at each read. Without it, ``byte_time`` and ``frame_gap``
    make settings of the deframer's own (the default gap follows the byte time).
    """

    def __init__(self, line: str = "B", byte_time: float = 0.0,
                 frame_gap: float | None = None, simple_responses: bool | None = None,
                 settings: LineSettings | None = None) -> None:
        self.line = line
        self.settings = settings if settings is not None else LineSettings.timed_by(byte_time, frame_gap)
        self.frame_kind = _FRAME_KIND.get(line, FRAME)
        self.simple = (line != "A") if simple_responses is None else simple_responses
        # the simple response kind of each byte value, for the C loop
        self._kinds = tuple(_SIMPLE.get(b) if self.simple else None for b in range(256))
        self._buf = b""
        self._base = 0              # absolute offset of _buf[0]
        self._seg_off: list[int] = []   # absolute offset where each timed chunk starts
        self._seg_t: list[float] = []   # wire time of that chunk's first byte
        self._seg_bt: list[float] = []  # and the time each of its bytes took (its byte time)
        self._gaps: list[int] = []      # absolute offsets preceded by a silence > frame_gap
        # when the last byte fed (or skipped) ended, as placed; None untimed (an
        # attribute, not a property: a capture reads it after every read)
        self.last_end: float | None = None
        self._noise_start: int | None = None  # absolute offset of a pending noise run
        self._timed = False
        self._resume = 0             # absolute offset where deframing resumes
        self._ends = "end of capture"   # what a frame cut at the end of the buffer met

    # ----------------------------------------------------------------- input
    @property
    def offset(self) -> int:
        """Absolute offset of the next byte to be fed."""
        return self._base + len(self._buf)

    @property
    def pending_since(self) -> float | None:
        """Wire time of the oldest byte not yet turned into an event (None: none or untimed)."""
        if not self._buf or not self._timed:
            return None
        return self._time_at(self._base)

    def set_byte_time(self, byte_time: float) -> None:
        """The line's rate changed (a rate-set command was ACKed): bytes fed from
        now on take ``byte_time`` each; bytes already fed keep theirs. The default
        frame gap follows the rate; one given explicitly stays. (This changes the
        settings the deframer reads: a capture changes its shared ``LineSettings``
        instead, ``set_rate``.)"""
        self.settings.set_byte_time(byte_time)

    def feed(self, data: bytes, t: float | None = None, not_before: float | None = None) -> list[Event]:
        """Add bytes; ``t`` is the wire time the first of them started (None: untimed),
        as estimated from when they were read (``t + len(data) × byte time``).

        Byte order is the truth (docs/time.md, "Byte order"): bytes that came faster
        than the rate allows would be placed before bytes already fed; they start
        where the line's previous bytes ended instead, or at ``not_before`` when
        later (the other line's latest read, for a capture with one clock), and
        are spread so that they end when they were read."""
        n = len(data)
        if not n:
            return []
        settings = self.settings   # read once a call: a rate change applies from the next read
        bt = settings.byte_time
        buf = self._buf
        if t is not None:
            self._timed = True
            last = self.last_end
            floor = last if not_before is None or (last is not None and last >= not_before) else not_before
            if floor is not None and t < floor:
                read = t + n * bt
                bt = (read - floor) / n if read > floor else 0.0
                t = floor
            if buf and last is not None and t - last > settings.frame_gap:
                self._gaps.append(self._base + len(buf))
            self.last_end = t + n * bt
        if not buf and self._noise_start is None and not self._gaps:
            # the usual read: one whole token with nothing pending becomes its event
            # directly (no segment bookkeeping: nothing of it stays buffered)
            if _c_whole is not None:
                ev = _c_whole(bytes(data), t, bt, self._base, self.line, self.frame_kind, self._kinds)
            else:
                ev = self._whole(bytes(data), t, bt)
            if ev is not None:
                self._base = self._resume = self._base + n
                return [ev]
        if t is not None:
            self._seg_off.append(self._base + len(buf))
            self._seg_t.append(t)
            self._seg_bt.append(bt)
        self._buf = buf + data if buf else bytes(data)
        return self._parse(final=False)

    def _whole(self, data: bytes, t: float | None, bt: float) -> Event | None:
        """The event ``_parse`` would make of ``data`` when it is exactly one valid
        frame or one simple response byte, else None."""
        n = len(data)
        base = self._base
        if n == 1:
            kind = _SIMPLE.get(data[0]) if self.simple else None
            if kind is None:
                return None
            return Event(self.line, base, kind, data, t, None if t is None else t + bt)
        if data[0] != START or n < 8 or (data[5] or 256) + 7 != n:
            return None
        if sum(data[1:-1]) & 0xFF != data[-1] or data.find(START, 6, n - 1) >= 0:
            return None
        t1 = None if t is None else t + n * bt
        return Event(self.line, base, self.frame_kind, data, t, t1,
                     (data[1], data[2], data[3]), data[4], data[6:-1], True)

    def idle(self, now: float) -> list[Event]:
        """Live input: nothing arrived until ``now``; close what a silence closes."""
        if self._buf and self.last_end is not None and now - self.last_end > self.settings.frame_gap:
            return self._parse(final=True)
        return []

    def finish(self) -> list[Event]:
        """End of stream: everything pending becomes events."""
        return self._parse(final=True)

    def skip(self, n: int, t: float | None = None) -> list[Event]:
        """The next ``n`` bytes of the line will not be fed (decoding fell behind):
        everything pending becomes events, as before a silence, so no frame is
        stitched across the gap; offsets advance by ``n``, so they stay the line's
        absolute offsets. ``t``: when the first of them started, if known: the
        line's next bytes come after them."""
        self._ends = "bytes not decoded"
        try:
            out = self._parse(final=True)
        finally:
            self._ends = "end of capture"
        self._base += len(self._buf) + n
        self._buf = b""
        self._resume = self._base
        self._noise_start = None
        self._seg_off.clear()
        self._seg_t.clear()
        self._seg_bt.clear()
        self._gaps.clear()
        last = self.last_end
        if t is None:
            self.last_end = None   # the skipped bytes ended later; the next chunk's time stands
        else:
            end = t + n * self.settings.byte_time
            self.last_end = end if last is None or end > last else last
        return out

    # ------------------------------------------------------------------ time
    def _time_at(self, off: int, after: int = 0) -> float | None:
        """When the byte at ``off`` started (``after`` 1: ended); None untimed."""
        if not self._timed:
            return None
        k = bisect_right(self._seg_off, off) - 1
        k = max(k, 0)
        return self._seg_t[k] + (off - self._seg_off[k] + after) * self._seg_bt[k]

    def _gap_in(self, start: int, end: int) -> int | None:
        """First gap boundary g with start < g < end (absolute offsets), if any."""
        gaps = self._gaps
        if not gaps:
            return None
        k = bisect_right(gaps, start)
        if k < len(gaps) and gaps[k] < end:
            return gaps[k]
        return None

    # ---------------------------------------------------------------- events
    def _event(self, kind: str, start: int, end: int) -> Event:
        """Make an event for absolute offsets [start, end)."""
        base = self._base
        raw = self._buf[start - base:end - base]
        if self._timed:
            t0 = self._time_at(start)
            t1 = self._time_at(end - 1, 1)
            ev = Event(self.line, start, kind, raw, t0, t1)
        else:
            ev = Event(self.line, start, kind, raw)
        return ev

    def _frame_event(self, start: int, end: int, ok: bool) -> Event:
        ev = self._event(self.frame_kind, start, end)
        raw = ev.raw
        ev.dst, ev.src, ev.payload, ev.checksum_ok = (raw[1], raw[2], raw[3]), raw[4], raw[6:-1], ok
        return ev

    def _flush_noise(self, out: list[Event], upto: int) -> None:
        ns = self._noise_start
        if ns is not None and ns < upto:
            ev = self._event(NOISE, ns, upto)
            ev.add_problem(NOISE_PROBLEM, f"{upto - ns} byte{'s' if upto - ns != 1 else ''} outside any frame")
            out.append(ev)
        self._noise_start = None

    def _valid_at(self, q: int, final: bool) -> int | None:
        """End offset of a checksum-valid frame starting at absolute q, -1 if none
        can start there, None if more bytes are needed to tell."""
        buf, base = self._buf, self._base
        rq = q - base
        end_abs = base + len(buf)
        need = q + 6 if len(buf) - rq < 6 else q + (buf[rq + 5] or 256) + 7
        if self._gap_in(q, min(need, end_abs)) is not None:
            return -1  # it would straddle a silence
        if need > end_abs:
            return -1 if final else None
        if sum(buf[rq + 1:need - base - 1]) & 0xFF == buf[need - base - 1]:
            return need
        return -1

    # ----------------------------------------------------------------- parse
    def _parse(self, final: bool) -> list[Event]:
        """The events the buffered bytes make, as far as no later byte can change
        them (all of them when ``final``); consumed bytes are dropped."""
        out: list[Event] = []
        i = self._deframe_buffer(out, final)
        buf = self._buf
        base = self._base
        if final and i >= len(buf):
            self._flush_noise(out, base + len(buf))
        self._resume = base + i
        # drop consumed bytes, keeping a pending noise run's bytes
        keep_from = i if self._noise_start is None else self._noise_start - base
        if keep_from > 0:
            self._buf = buf[keep_from:]
            self._base = base + keep_from
            self._prune()
        return out

    def _deframe_buffer(self, out: list[Event], final: bool) -> int:
        """Append to ``out`` the events of the buffer from where deframing resumes;
        returns the buffer index it stopped at (its end, or a frame still arriving).
        The C loop takes what needs no decision; this loop takes the rest."""
        append = out.append
        buf = self._buf
        base = self._base
        n = len(buf)
        simple = _SIMPLE if self.simple else {}
        line, frame_kind, timed, kinds = self.line, self.frame_kind, self._timed, self._kinds
        fast = not self._gaps   # no silence inside the buffer: frames cannot be cut
        not_noise = (_NOT_NOISE if self.simple else _START).search
        c_loop = _c_loop if fast else None   # (no silence inside: the C loop may run)
        segments = (self._seg_off, self._seg_t, self._seg_bt) if timed else ()
        i = self._resume - base
        while i < n:
            if c_loop is not None and self._noise_start is None:
                i = c_loop(buf, i, kinds, line, frame_kind, base, out, *segments)
                if i >= n:
                    break
            b = buf[i]
            if b == START:
                # fast path: a complete frame whose checksum holds
                if fast and n - i >= 6:
                    end = i + (buf[i + 5] or 256) + 7
                    # (a start byte inside the payload is suspect: see _suspect)
                    if end <= n and sum(buf[i + 1:end - 1]) & 0xFF == buf[end - 1] \
                            and buf.find(START, i + 6, end - 1) < 0:
                        if self._noise_start is not None:
                            self._flush_noise(out, base + i)
                        raw = buf[i:end]
                        t0 = self._time_at(base + i) if timed else None
                        t1 = self._time_at(base + end - 1, 1) if timed else None
                        append(Event(line, base + i, frame_kind, raw, t0, t1,
                                     (raw[1], raw[2], raw[3]), raw[4], raw[6:-1], True))
                        i = end
                        continue
                nxt = self._try_frame(out, base + i, final)
                if nxt is None:   # need more bytes
                    break
                i = nxt - base
                continue
            kind = simple.get(b)
            if kind is not None:
                abs_i = base + i
                if self._noise_start is not None:
                    self._flush_noise(out, abs_i)
                if timed:
                    append(Event(line, abs_i, kind, buf[i:i + 1], self._time_at(abs_i), self._time_at(abs_i, 1)))
                else:
                    append(Event(line, abs_i, kind, buf[i:i + 1]))
                i += 1
                continue
            # noise up to the next byte that may begin something else: extend the
            # pending run (or start one) at once; a silence splits runs
            m = not_noise(buf, i)
            j = m.start() if m is not None else n
            self._noise(out, base + i, base + j)
            i = j
        return i

    def _prune(self) -> None:
        base = self._base
        if len(self._seg_off) > 32:   # now and then: a small list costs nothing to keep
            k = bisect_right(self._seg_off, base) - 1
            if k > 0:
                del self._seg_off[:k]
                del self._seg_t[:k]
                del self._seg_bt[:k]
        if self._gaps:
            k = bisect_right(self._gaps, base)
            if k:
                del self._gaps[:k]

    def _try_frame(self, out: list[Event], p: int, final: bool) -> int | None:
        """Decide what starts at absolute offset p (a start byte). Returns the
        absolute offset to continue from, or None when more bytes are needed.

        A whole frame whose checksum holds is handled here (with silences in the
        buffer, every frame comes this way); anything else goes to the step that
        reads it."""
        buf, base = self._buf, self._base
        rp = p - base
        avail = len(buf) - rp
        gaps = self._gaps   # usually empty: then no silence can cut anything, no need to look
        if avail < 6:
            cut = self._gap_in(p, base + len(buf) + 1) if gaps else None
            if cut is None and not final:
                return None   # the header is still arriving
            return self._cut_header(out, p, cut)
        length = buf[rp + 5] or 256
        total = length + 7
        cut = self._gap_in(p, p + total) if gaps else None
        if cut is None and avail >= total:
            if sum(buf[rp + 1:rp + total - 1]) & 0xFF == buf[rp + total - 1]:
                if _suspect(buf, rp + 6, rp + total - 1):
                    q = self._frame_inside_suspect(rp, total, final)
                    if q is None:
                        return None
                    if q >= 0:
                        return self._broken(out, p, q, CHECKSUM.problem(
                            f"frame that only checks out by chance, resynchronised on the frame at offset {q}"))
                self._flush_noise(out, p)
                out.append(self._frame_event(p, p + total, True))
                return p + total
        elif cut is None and not final:
            return None  # the frame is still arriving
        return self._bad_frame(out, p, length, cut, final)

    def _cut_header(self, out: list[Event], p: int, cut: int | None) -> int:
        """Fewer than 6 bytes follow the start byte at p, and a silence (at ``cut``)
        or the end of the data came: a header cut short."""
        stop = cut if cut is not None else self._base + len(self._buf)
        n = stop - p
        return self._broken(out, p, stop, TRUNCATED.problem(f"header cut after {n} byte{'s' if n != 1 else ''}"))

    def _frame_inside_suspect(self, rp: int, total: int, final: bool) -> int | None:
        """A frame at buffer index rp checks out but carries a start byte in its
        payload. Checksums match by chance 1 time in 256, so it yields to a valid
        frame inside it, or to a whole printable frame inside it even with a bad
        checksum: that frame's absolute offset; -1 when none does; None when more
        bytes are needed to tell."""
        buf, base = self._buf, self._base
        q = buf.find(START, rp + 6, rp + total - 1)
        while q != -1:
            v = self._valid_at(base + q, final)
            if v is None:
                return None
            if v > 0 or self._plausible_inside(q, rp + total):
                return base + q
            q = buf.find(START, q + 1, rp + total - 1)
        return -1

    def _bad_frame(self, out: list[Event], p: int, length: int, cut: int | None, final: bool) -> int | None:
        """The frame stated at p is bad: its checksum failed, or a silence (at
        ``cut``) or the end of the data cut it. Try the better readings in turn
        (docs/decoding.md, "Deframing")."""
        buf, base = self._buf, self._base
        total = length + 7
        end_abs = base + len(buf)
        # 1. a valid frame starting inside it wins
        limit_r = (cut if cut is not None else min(p + total, end_abs)) - base
        q = buf.find(START, p - base + 1, limit_r)
        while q != -1:
            v = self._valid_at(base + q, final)
            if v is None:
                return None
            if v > 0:
                return self._before_resync(out, p, base + q, length)
            q = buf.find(START, q + 1, limit_r)
        # 2. the length byte was corrupted: an end before the next start byte checks out.
        # No frame spans a silence, so the first silence after p bounds the search.
        bound = cut if cut is not None or not self._gaps else self._gap_in(p, end_abs + 1)
        repaired = self._length_repair(p, length, bound, final)
        if repaired is None:
            return None
        if repaired > 0:
            self._flush_noise(out, p)
            m = repaired - p - 7
            ev = self._frame_event(p, repaired, False)
            ev.add_problem(LENGTH, f"says {length}, frame carries {m} payload bytes (the checksum holds with {m})")
            out.append(ev)
            return repaired
        # 3. no better reading: a complete frame with a bad checksum, or a cut one
        if cut is None and end_abs >= p + total:
            return self._checksum_failed(out, p, total, final)
        return self._cut_short(out, p, total, cut)

    def _checksum_failed(self, out: list[Event], p: int, total: int, final: bool) -> int | None:
        """A complete frame at p whose checksum fails, with no better reading. It is
        reported as a frame when it ends exactly where something else begins (a
        start byte, a simple response on B, a silence, the end: the length held) or
        when its payload looks like one (mostly printable); else its start byte is
        noise."""
        buf = self._buf
        rp = p - self._base
        end_r = rp + total
        if end_r < len(buf):
            nxt = buf[end_r]
            bounded = nxt == START or (self.simple and nxt in _SIMPLE) or \
                self._gap_in(p + total - 1, p + total + 1) == p + total
        elif final:
            bounded = True
        else:
            return None   # the next byte decides
        if not bounded and _printable_share(buf[rp + 6:end_r - 1]) < 0.75:
            return self._as_noise(out, p)
        self._flush_noise(out, p)
        got = buf[end_r - 1]
        want = sum(buf[rp + 1:end_r - 1]) & 0xFF
        ev = self._frame_event(p, p + total, False)
        ev.add_problem(CHECKSUM, f"expected 0x{want:02x}, got 0x{got:02x}")
        out.append(ev)
        return p + total

    def _cut_short(self, out: list[Event], p: int, total: int, cut: int | None) -> int:
        """A frame at p cut by a silence (at ``cut``) or the end of the data: reported
        only when what arrived looks like a frame (a mostly printable payload)."""
        base = self._base
        stop = cut if cut is not None else base + len(self._buf)
        if _printable_share(self._buf[p - base + 6:stop - base]) < 0.75:
            return self._as_noise(out, p)
        then = ", then silence" if cut is not None else f", then {self._ends}"
        return self._broken(out, p, stop, TRUNCATED.problem(f"{stop - p} of {total} bytes{then}"))

    def _plausible_inside(self, rq: int, rend: int) -> bool:
        """Does a whole frame with a mostly printable payload start at buffer index
        rq and end by rend?"""
        buf = self._buf
        if rend - rq < 8:
            return False
        end = rq + (buf[rq + 5] or 256) + 7
        return end <= rend and _printable_share(buf[rq + 6:end - 1]) >= 0.75

    def _as_noise(self, out: list[Event], p: int) -> int:
        """Treat the byte at p as noise and go on after it."""
        return self._noise(out, p, p + 1)

    def _noise(self, out: list[Event], p: int, q: int) -> int:
        """Bytes [p, q) are noise: extend the pending run (or start one). A run is
        cut at a silence and ``NOISE_PIECE`` bytes after each piece's start, so the
        pieces end at the same offsets however the stream was split, and a flood
        of noise is never held whole."""
        ns = self._noise_start
        if ns is None:
            ns = p
        while True:
            cut = ns + NOISE_PIECE
            if self._gaps:
                g = self._gap_in(ns, cut)
                if g is not None:
                    cut = g
            if cut >= q:
                break
            self._noise_start = ns
            self._flush_noise(out, cut)
            ns = cut
        self._noise_start = ns
        return q

    def _broken(self, out: list[Event], p: int, stop: int, problem: Problem) -> int:
        """Bytes [p, stop) are a frame that cannot be read: one noise event."""
        self._flush_noise(out, p)
        ev = self._event(NOISE, p, stop)
        ev.note(problem)
        out.append(ev)
        return stop

    def _before_resync(self, out: list[Event], p: int, q: int, length: int) -> int:
        """A valid frame starts at q inside the bad one at p: report [p, q)."""
        buf, base = self._buf, self._base
        rp, rq = p - base, q - base
        m = q - p - 7
        if 1 <= m <= 256 and _printable_share(buf[rp + 6:rq - 1]) == 1.0:
            implied = (sum(buf[rp + 1:rp + 5]) + (m & 0xFF) + sum(buf[rp + 6:rq - 1])) & 0xFF
            if implied == buf[rq - 1]:
                self._flush_noise(out, p)
                ev = self._frame_event(p, q, False)
                ev.add_problem(LENGTH, f"says {length}, frame carries {m} payload bytes "
                                       f"(the checksum holds with {m})")
                out.append(ev)
                return q
        return self._broken(out, p, q, CHECKSUM.problem(f"broken frame, resynchronised on the frame at offset {q}"))

    def _length_repair(self, p: int, length: int, cut: int | None, final: bool) -> int | None:
        """End offset of a repaired frame at p, 0 if none, None if more bytes are needed.

        A candidate end e must be followed by a start byte (or a silence, or the end
        of the capture), the payload before it must be printable, and the checksum
        must hold with length e-p-7 in place of the received length byte.
        """
        buf, base = self._buf, self._base
        rp = p - base
        n = len(buf)
        hard = cut - base if cut is not None else (n if final else None)
        stop_r = rp + _MAX_FRAME
        if hard is not None:
            stop_r = min(stop_r, hard)
        elif n < stop_r:
            # Not enough bytes yet to rule out every candidate end.
            return None
        head = sum(buf[rp + 1:rp + 5])
        ends = []
        e = buf.find(START, rp + 8, stop_r)
        while e != -1:
            ends.append(e)
            e = buf.find(START, e + 1, stop_r)
        if hard is not None and hard <= rp + _MAX_FRAME:
            ends.append(hard)
        for e in ends:
            m = e - rp - 7
            if not 1 <= m <= 256 or m == length:
                continue
            payload = buf[rp + 6:e - 1]
            if (head + (m & 0xFF) + sum(payload)) & 0xFF != buf[e - 1]:
                continue
            if _printable_share(payload) == 1.0:
                return base + e
        return 0
