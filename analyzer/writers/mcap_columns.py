"""The decoded columns a recording carries (docs/mcap.md, "Stored columns"): the
recorder's events, stored as the TUI's store stores them and written every
``BATCH`` events (and whenever a live recording flushes) as one Arrow IPC
message on ``COLUMNS_TOPIC``, so that opening the recording needs no decoding.

Memory stays bounded by one batch. Events must come numbered one after the
other (a tap's always are); anything else (events made by hand) stops the
columns, and the recording then says nothing of them: readers decode its raw
bytes, which every recording keeps.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import orjson

from dissectors.event import Event

from ..analysis.doctor import WiringDoctor
from ..analysis.stats import Stats
from ..formats.store import EventStore
from ..formats.store_ipc import VERSION, Tables, decoder_version, encode, sets_a_rate
from ..lines import Chunk

BATCH = 16_384      # events a message: about 300 kB of columns, one MCAP chunk of its own
STORE_EVERY = 4_096   # events held as objects before the store takes them


class RecordingTally:
    """What the columns of a recording's parts share: the wiring doctor fed every
    event so far (its wiring signs among its tallies), the statistics of every
    event so far, whether a rate was set, and the bytes and events recorded so
    far. ``ack_timeout``: the tap's, which the doctor's rules judge by."""

    def __init__(self, lines: tuple[str, ...], ack_timeout: float = 0.5) -> None:
        self.doctor = WiringDoctor(lines, ack_timeout)
        self.signs = self.doctor.signs
        self.stats = Stats()
        # a rate change, or a frame asking for one (store_ipc.sets_a_rate): following
        # a rate warns as it decodes, so such a recording's statistics are not kept
        self.sets_rate = False
        self.raw_bytes = 0
        self.events = 0


class ColumnBatches:
    """Events in, a message out (``write(data, log_time)``) per batch."""

    def __init__(self, write: Callable[[bytes, int], None], shared: RecordingTally) -> None:
        self._write = write
        self.shared = shared
        # the wiring doctor's tallies of every event (its signs: analyzer/analysis/signs.py),
        # kept in the record: what `stats`, `export` and the like say of the wiring and
        # the doctor's findings, without a pass over the events
        self.doctor = shared.doctor
        self.decoder = decoder_version()
        self.store = EventStore()
        self._pending: list[Event] = []
        self._positions: dict[int, dict] = {}   # row in the batch -> fields of a position command or answer
        self._ts: int | None = None      # the batch's first event's log time
        self.started = False
        self.stopped: str | None = None  # why the columns stopped (the recording then has none)
        self.events = 0                  # events written in messages
        self.messages = 0

    def raw(self, chunk: Chunk) -> None:
        """Bytes recorded: the columns hold their events, unless the tap passed
        over them (``Chunk.undecoded``: decoding fell behind a live line), when
        they stop (decoding the recording gives events the tap never made)."""
        if chunk.data:
            self.shared.raw_bytes += len(chunk.data)
            if chunk.undecoded and self.stopped is None:
                self.stopped = f"the tap passed over bytes it did not decode ({chunk.undecoded})"

    def add(self, ev: Event, ts_of: Callable[[Event], int]) -> None:
        """``ev``, whose log time ``ts_of`` gives (asked of a batch's first event only)."""
        if self.stopped is not None:
            return
        if self._ts is None:
            self._ts = ts_of(ev)
        self._pending.append(ev)
        if len(self._pending) >= STORE_EVERY:
            self._store()

    def _store(self) -> None:
        events, self._pending = self._pending, []
        if not events or self.stopped is not None:
            return
        store = self.store
        if not self.started:
            first = events[0].number
            if first is None:
                self.stopped = "events without numbers"
                return
            store.base = first - 1
            self.started = True
        expected = store.base + len(store) + 1
        if events[0].number != expected or events[-1].number != expected + len(events) - 1:
            self.stopped = f"event {events[0].number} came where event {expected} was due"
            return
        n = len(store) - 1
        store.append(events)
        self.shared.events += len(events)
        add = self.doctor.add
        for ev in events:
            add(ev)
        self.shared.stats.add_events(events)
        positions = self._positions
        for k, ev in enumerate(events, n + 1):   # the plots' points (store_ipc's position columns)
            command = ev.command
            if (command == "P" or command == "P?") and ev.fields and "azimuth_deg" in ev.fields:
                positions[k] = ev.fields
        if len(store) >= BATCH:
            self.flush()

    def flush(self) -> None:
        """Write the events so far as one message (none if there are none)."""
        if self._pending:
            self._store()
        store = self.store
        if self.stopped is not None or not len(store):
            return
        tables = Tables(store.line_values, store.device_values, store.command_places)
        n = len(store)
        ts = self._ts if self._ts is not None else 0
        self._ts = None
        azimuth, elevation = np.full(n, np.nan), np.full(n, np.nan)
        for k, fields in self._positions.items():
            azimuth[k] = fields["azimuth_deg"]
            elevation[k] = fields.get("elevation_deg", np.nan)
        self._positions = {}
        chunk = store.take()
        if not self.shared.sets_rate and sets_a_rate(chunk):
            self.shared.sets_rate = True
        self._write(encode(chunk, tables, self.decoder, (azimuth, elevation)), ts)
        self.events += n
        self.messages += 1

    def record(self, part: bool = False) -> dict[str, str] | None:
        """The ``gimbalscope.columns`` metadata record of a recording whose
        columns are complete (None if they stopped): written last, it says that
        the messages hold every event."""
        if self.stopped is not None:
            return None
        if self.shared.raw_bytes and not self.shared.events and not part:
            # bytes and not one event: a recorder fed only the bytes (the API allows
            # it; a tap feeds both). A part may hold bytes whose events the next holds
            return None
        record = {"version": VERSION, "decoder": self.decoder, "events": str(self.events),
                  "messages": str(self.messages), "media_type": "application/vnd.apache.arrow.stream",
                  "wiring_signs": orjson.dumps(self.doctor.signs.state()).decode(),
                  "doctor": orjson.dumps(self.doctor.kept()).decode(), "ack_timeout": f"{self.doctor.ack_timeout!r}"}
        if not self.shared.sets_rate:
            # what `gimbalscope stats` prints of every event so far (Stats.to_dict): of
            # the whole recording when every part is read, from the first on
            record["stats"] = orjson.dumps(self.shared.stats.to_dict()).decode()
        return record
