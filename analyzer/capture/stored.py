"""A recording read from the decoded columns it carries instead of from its raw
bytes (docs/mcap.md, "Stored columns"): the same events, without decoding.

The columns are used when the recording says they are complete, they were made
by this very decoder (``store_ipc.decoder_version``), and nothing given changes
what decoding would make of the bytes (a rate, the lines swapped, a channel, a
time zone...). Otherwise the raw bytes are decoded, as for any capture, and a
recording that has columns says in one line why they were left aside.
``--redecode`` (``Options.redecode``) leaves them aside silently.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import orjson

from ..analysis.doctor import Invocation, WiringDoctor
from ..analysis.signs import WiringSigns
from ..formats.store import EventStore, StoreChunk
from ..formats.store_ipc import VERSION, ColumnsError, Joiner, decoder_version
from ..sources.mcapfile import McapSource
from .capture import Capture

# the options that change what decoding makes of a recording's bytes, by their
# flags: given, the recording is decoded
_DECODING = {"baud": "--baud", "data_bits": "--data-bits", "parity": "--parity", "stop_bits": "--stop-bits",
             "frame_gap": "--frame-gap", "ack_timeout": "--ack-timeout", "result_timeout": "--result-timeout",
             "timeouts": "--timeout", "swap_lines": "--swap-lines", "follow_rate": "--no-follow-rate"}
_INSTRUMENT = {"tz": "--tz", "start_time": "--start-time", "channels": "--channels", "adapter": "--adapter",
               "usb_device": "--usb-device", "samplerate": "--samplerate"}


@dataclass(frozen=True)
class StoredEvents:
    """A capture's events as stored chunks: ``chunks(joiner)`` reads them in order
    (joined by ``joiner``, whose tables a caller may read between chunks; a new one
    by default) and raises ``ColumnsError`` when they do not read or do not add
    up to ``events``."""
    events: int
    chunks: Callable[[Joiner | None], Iterator[StoreChunk]]
    record: dict[str, str]   # the columns' record (docs/mcap.md)

    def store(self, refuse: Callable[[StoreChunk], bool] | None = None) -> EventStore | None:
        """Every event in one store (``ColumnsError`` as ``chunks``); None as soon
        as ``refuse`` says a chunk is not to be read from the columns (the rest is
        then not read)."""
        store = EventStore()
        for chunk in self.chunks(None):
            if refuse is not None and refuse(chunk):
                return None
            store.append_chunk(chunk)
        return store

    def doctor(self, lines: tuple[str, ...], ack_timeout: float, invocation: Invocation) -> WiringDoctor | None:
        """The wiring doctor of every event, as the recorder kept it (its findings
        as a pass over the events gives them, ``invocation`` naming the command
        that reads them); None when the record has none that read, or the
        recorder judged by another ACK timeout."""
        signs = self.signs(lines)
        if signs is None or "doctor" not in self.record:
            return None
        try:
            state = orjson.loads(self.record["doctor"])
            if float(self.record.get("ack_timeout", "nan")) != ack_timeout:
                return None
            return WiringDoctor.of_kept(signs, ack_timeout, invocation, state)
        except (KeyError, TypeError, ValueError, AttributeError):
            return None

    def figures(self) -> dict[str, Any] | None:
        """What ``gimbalscope stats`` prints of every event (``Stats.to_dict``), as
        the recorder counted them; None when the record keeps none (a rate was set)
        or they are not of exactly these events (parts read from other than the
        first: each part's record counts every event since the first part's)."""
        try:
            figures = orjson.loads(self.record["stats"])
        except (KeyError, ValueError):
            return None
        if not isinstance(figures, dict) or figures.get("events") != self.events:
            return None
        return figures

    def signs(self, lines: tuple[str, ...]) -> WiringSigns | None:
        """The wiring signs of every event, as the recorder kept them; None when
        the record has none that read."""
        try:
            return WiringSigns.of_state(lines, orjson.loads(self.record["wiring_signs"]))
        except (KeyError, TypeError, ValueError, IndexError, AttributeError):
            return None


def stored_events(capture: Capture) -> tuple[StoredEvents | None, str | None]:
    """The capture's stored events, or None and the line saying why they are not
    used (None when there is nothing to say: no columns, or ``--redecode``)."""
    options = capture.options
    if options.redecode:
        return None, None
    source = capture.source
    if isinstance(source, McapSource) and (source.metadata or {}).get("part"):
        # its columns are its events as decoded with the parts before and after it:
        # what decoding the part alone makes at its ends differs
        return None, (f"{source.description}: one part of a recording in parts, read alone: "
                      "decoding its raw bytes, not the stored columns")
    stored = source.stored_columns()
    record = stored.record
    if record is None:
        return None, stored.why
    name = capture.source.description
    if record.get("version") != VERSION:
        return None, f"{name}: stored columns of version {record.get('version')!r} not read: decoding the raw bytes"
    if record.get("decoder") != decoder_version():
        return None, (f"{name}: stored columns made by decoder {record.get('decoder')}, this is "
                      f"{decoder_version()}: decoding the raw bytes")
    given = [flag for key, flag in _DECODING.items() if key in options.explicit]
    instrument = {"tz": options.tz, "start_time": options.start_time, "channels": options.channels,
                  "adapter": options.adapter, "usb_device": options.usb_device, "samplerate": options.samplerate}
    given += [flag for key, flag in _INSTRUMENT.items() if instrument[key] is not None]
    if given:
        return None, f"{name}: {', '.join(given)} given: decoding the raw bytes, not the stored columns"
    count = record.get("events", "")
    if not count.isdigit():
        return None, f"{name}: stored columns not read: their record says {count!r} events"
    events = int(count)

    def chunks(joiner: Joiner | None = None) -> Iterator[StoreChunk]:
        joiner = joiner or Joiner()
        for data in stored.messages():
            yield joiner.chunk(data)
        if joiner.events != events:
            raise ColumnsError(f"the stored columns hold {joiner.events} events, their record says {events}")

    return StoredEvents(events, chunks, record), None
