"""The statistics and the device map of stored events, from the store's columns,
for the statistics screen: of every event, or of the rows a filter shows.

The TUI counted every event into a ``Stats`` as it arrived, a sixth of loading a
file. The same figures come from the columns when the screen asks: the store
hands them over as one batch of ``EventColumns`` (``stored_columns``), which
``Stats.add_columns`` counts as it counts the batches of ``gimbalscope stats``
(analyzer/analysis/stats.py: one definition of every figure), so the screen and
``stats --format json`` say the same. An answer counts for its command's id,
the command column at its request's row.

Problems are kept sparsely (most events have none) and handed over as they are;
rate changes, a handful a capture, are rebuilt as events.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from dissectors.event import ACK, COMMAND, NAK, NIC, RATE, RESULT, ST_NIC
from dissectors.problems import Problem

from ..analysis.stats import Coded, EventColumns, Stats, rate_change
from .store import (
    CHECKSUM_BAD,
    KIND_CODE,
    KINDS,
    LINKED,
    RETRANSMISSION,
    STATUS_CODE,
    STATUSES,
    UNTIMED,
    EventStore,
)
from .store_filter import Columns


@dataclass
class DeviceInfo:
    """A device of the device map: which lines its answers came on, how many
    commands it was sent and answered, and which commands it answered with NIC
    (§1.4.2); the TUI's statistics screen shows the map."""
    address: str
    lines: set[str] = field(default_factory=set)       # lines its answers came on
    commands: int = 0
    answered: int = 0
    nic: set[str] = field(default_factory=set)         # commands it answered with NIC

def stats_of(store: EventStore, stop: int, rows: np.ndarray | None = None) -> Stats:
    """The statistics of the first ``stop`` stored events, or of those among them
    at ``rows`` (ascending store indices: a filtered view)."""
    out = Stats()
    out.add_columns(stored_columns(store, stop, rows))
    return out


def stored_columns(store: EventStore, stop: int, rows: np.ndarray | None = None) -> EventColumns:
    """The first ``stop`` stored events, or those among them at ``rows``, as the
    statistics read them."""
    cols = Columns(store, 0, stop)   # each column copied once: the store goes on growing in another thread
    if rows is None:
        rows = np.arange(stop, dtype=np.int64)
    else:
        rows = np.asarray(rows, dtype=np.int64)
        rows = rows[rows < stop]

    def col(name: str) -> np.ndarray:
        return cols.column(name)[rows]

    kind, flags = col("kind"), col("flags")
    end = cols.column("end").astype(np.int64)
    size = (end - np.concatenate(([0], end[:-1])))[rows] if stop else np.zeros(0, np.int64)
    # a command counts for its own id, an answer for its command's (at its request's row)
    own, request = col("command"), col("request").astype(np.int64)
    answered = cols.column("command")[np.maximum(request - 1, 0)] if stop else own
    command = np.where((request > 0) & (kind != KIND_CODE[COMMAND]), answered, own)
    rate_rows = rows[kind == KIND_CODE[RATE]].tolist()
    return EventColumns(
        Coded(kind, KINDS), Coded(col("line"), store.line_values), Coded(col("status"), STATUSES),
        Coded(command, store.command_ids), Coded(col("device"), store.device_values),
        size, col("t"), col("t_end"), (flags & UNTIMED) == 0, (flags & LINKED) != 0, (flags & CHECKSUM_BAD) != 0,
        (flags & RETRANSMISSION) != 0, col("latency"), _problems(store, stop, rows),
        [rate_change(store.event(i)) for i in rate_rows])


def _problems(store: EventStore, stop: int, rows: np.ndarray) -> list[tuple[int, Sequence[Problem]]]:
    """(place in ``rows``, the problems) of the rows with problems, in order."""
    found = sorted((i, p) for i, p in list(store.problems.items()) if i < stop)
    if not found:
        return []
    at = np.searchsorted(rows, [i for i, _ in found])
    return [(k, p) for k, (i, p) in zip(at.tolist(), found) if k < len(rows) and rows[k] == i]


def devices_of(store: EventStore, stop: int) -> dict[str, DeviceInfo]:
    """The device map (address -> ``DeviceInfo``) of the first
    ``stop`` stored events, from the columns: per device, the commands sent to
    it, the ACKs and NAKs it answered, the lines its paired answers (results,
    ACKs, NAKs, NICs) came on, and the commands it answered with NIC. A device
    comes in the order it first appears."""
    out: dict[str, DeviceInfo] = {}
    if not stop:
        return out

    col = Columns(store, 0, stop).column
    kind, device, flags, line = col("kind"), col("device"), col("flags"), col("line")
    names, lines = store.device_values, store.line_values
    is_command = kind == KIND_CODE[COMMAND]
    answer = np.isin(kind, [KIND_CODE[RESULT], KIND_CODE[ACK], KIND_CODE[NAK], KIND_CODE[NIC]]) & ((flags & LINKED) != 0)
    mapped = (is_command | answer) & (device != 0)

    def info(code: int) -> DeviceInfo:
        addr = names[code]
        assert addr is not None   # code 0, no device, is not mapped
        got = out.get(addr)
        if got is None:
            got = out[addr] = DeviceInfo(addr)
        return got

    # in the order devices first appear
    order = np.unique(device[mapped], return_index=True)
    for code in order[0][np.argsort(order[1])].tolist():
        info(code)
    for code, n in zip(*np.unique(device[mapped & is_command], return_counts=True)):
        info(code).commands += int(n)
    acks = mapped & np.isin(kind, [KIND_CODE[ACK], KIND_CODE[NAK]])
    for code, n in zip(*np.unique(device[acks], return_counts=True)):
        info(code).answered += int(n)
    pairs = np.unique(device[mapped & answer].astype(np.int64) * 256 + line[mapped & answer])
    for p in pairs.tolist():
        line_name = lines[p % 256]
        assert line_name is not None   # every event is on a line
        info(p // 256).lines.add(line_name)
    nic = mapped & is_command & (col("status") == STATUS_CODE[ST_NIC])
    commands = store.command_ids
    for code, c in set(zip(device[nic].tolist(), col("command")[nic].tolist())):
        command = commands[c]
        if command:
            info(code).nic.add(command)
    return out
