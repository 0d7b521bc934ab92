"""The statistics of stored events from the store's columns (``stats_of``), for
the statistics screen: of every event, or of the rows a filter shows.

The TUI counted every event into a ``Stats`` as it arrived, a sixth of loading a
file. The same figures come from the columns when the screen asks, with numpy:
counts by kind, line and status are ``bincount``s, the per-command and
per-device tables are counts over (command, device) codes, and the latencies go
into the same log-spaced buckets (``math.log``, as ``Stats`` computes them, so
every bucket, and so every median and p95, is the same). The result is a
``Stats`` (analyzer/analysis/stats.py), so the screen and ``stats --format json``
word it alike; tests/pure/test_store_stats.py holds it equal to ``Stats`` fed
the events themselves.

Problems are kept sparsely (most events have none) and counted from there; rate
changes, a handful a capture, are rebuilt as events.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from dissectors.event import ACK, COMMAND, NAK, NOISE, P_NOISE, PENDING, RATE, RESULT

from ..analysis.stats import _CHECKSUM_PROBLEMS, _LOG_STEP, Counts, Latency, Stats, problem_categories
from .store import CHECKSUM_BAD, KINDS, LINKED, RETRANSMISSION, STATUSES, UNTIMED, EventStore
from .store_filter import Columns

_K = {k: i for i, k in enumerate(KINDS)}


def stats_of(store: EventStore, stop: int, rows: np.ndarray | None = None) -> Stats:
    """The statistics of the first ``stop`` stored events, or of those among them
    at ``rows`` (ascending store indices: a filtered view)."""
    out = Stats()
    if rows is None:
        rows = np.arange(stop, dtype=np.int64)
    else:
        rows = np.asarray(rows, dtype=np.int64)
        rows = rows[rows < stop]
    n = len(rows)
    out.events = n
    if not n:
        return out

    cols = Columns(store, 0, stop)   # each column copied once: the store goes on growing in another thread

    def col(name: str) -> np.ndarray:
        return cols.column(name)[rows]

    kind, line, flags = col("kind"), col("line"), col("flags")
    status, command, device = col("status"), col("command"), col("device")
    end = cols.column("end").astype(np.int64)
    size = (end - np.concatenate(([0], end[:-1])))[rows]

    for code, count in zip(*np.unique(kind, return_counts=True)):
        out.kinds[KINDS[code]] = int(count)
    lines = list(store._lines.values)
    for code in np.unique(line):
        out.bytes[lines[code]] = int(size[line == code].sum())

    timed = np.flatnonzero((flags & UNTIMED) == 0)
    if len(timed):
        out.first_t = float(col("t")[timed[0]])
        out.last_t = float(col("t_end")[timed[-1]])

    # problems: per event, its categories once each
    noise_code = _K[NOISE]
    checksum_rows = set()
    in_rows = set(rows.tolist()) if n < stop else None
    for i, problems in sorted(list(store.problems.items())):
        if i >= stop or (in_rows is not None and i not in in_rows):
            continue
        cats = problem_categories(problems)
        out.problems.update(cats)
        if any(c in _CHECKSUM_PROBLEMS for c in cats):
            checksum_rows.add(i)
        if store.kind[i] == noise_code:
            out.noise_kinds[cats[0] if cats else P_NOISE] += 1
    out.checksum_errors = len(checksum_rows)
    noise = kind == noise_code
    out.noise_bytes = int(size[noise].sum())
    noise_rows = rows[noise]
    out.broken_frames = sum(1 for i in noise_rows.tolist() if i in checksum_rows)
    plain_noise = int(noise.sum()) - sum(out.noise_kinds.values())
    if plain_noise:
        out.noise_kinds[P_NOISE] += plain_noise

    for i in rows[kind == _K[RATE]].tolist():
        ev = store.event(i)
        out.rate_changes.append({"number": ev.number, "t": ev.t, "request": ev.request, **ev.fields})

    linked = (flags & LINKED) != 0
    counted = (kind != _K[RATE]) & (kind != noise_code)
    out.orphans = int(np.count_nonzero(counted & ~linked & (kind != _K[COMMAND])))
    _tables(out, store, cols, rows, kind, status, command, device, flags, counted & linked)
    return out


def _tables(out: Stats, store: EventStore, cols: Columns, rows, kind, status, command, device, flags,
            linked) -> None:
    """``by_command`` and ``by_device``: a command counts for its own id and
    device, an answer for its command's (the request's command column)."""
    if not linked.any():
        return
    # command ids as codes of their own (several table entries can share an id)
    ids: dict[str | None, int] = {}
    id_of = np.array([ids.setdefault(v if v is None else v[0], len(ids)) for v in list(store._commands.values)],
                     dtype=np.int64)
    names = ["?" if v is None else v for v in ids]
    devices = ["?" if v is None else v for v in list(store._devices.values)]
    own = id_of[command]
    request = cols.column("request")[rows].astype(np.int64)
    all_commands = cols.column("command")
    answered = np.where(request > 0, id_of[all_commands[np.maximum(request - 1, 0)]], own)
    is_command = kind == _K[COMMAND]
    cmd_key = np.where(is_command, own, answered)
    checksum_bad = (flags & CHECKSUM_BAD) != 0

    def counts_for(table: dict, label: str) -> Counts:
        c = table.get(label)
        if c is None:
            c = table[label] = Counts()
        return c

    sel = linked & is_command
    for keys, table, labels in ((cmd_key, out.by_command, names), (device, out.by_device, devices)):
        for code in np.unique(keys[linked]).tolist():   # every key an event counts for, even with nothing to add
            counts_for(table, labels[code])
        k = keys[sel]
        for code, count in zip(*np.unique(k, return_counts=True)):
            counts_for(table, labels[code]).commands += int(count)
        st = status[sel]
        for (code, s), count in Counter(zip(k.tolist(), st.tolist())).items():
            counts_for(table, labels[code]).status[STATUSES[s] or PENDING] += count
        retx = ((flags[sel] & RETRANSMISSION) != 0)
        for code, count in Counter(k[retx].tolist()).items():
            counts_for(table, labels[code]).retransmissions += count
        answers = linked & ~is_command
        bad = keys[(sel | answers) & checksum_bad]
        for code, count in Counter(bad.tolist()).items():
            counts_for(table, labels[code]).checksum_errors += count

    latency = cols.column("latency")[rows]
    has = linked & ~is_command & ~np.isnan(latency)
    for which, kinds in (("ack_latency", (_K[ACK], _K[NAK])), ("result_latency", (_K[RESULT],))):
        pick = has & np.isin(kind, kinds)
        if not pick.any():
            continue
        xs = latency[pick].tolist()
        for keys, table, labels in ((cmd_key, out.by_command, names), (device, out.by_device, devices)):
            groups: dict[int, list[float]] = {}
            for code, x in zip(keys[pick].tolist(), xs):
                groups.setdefault(code, []).append(x)
            for code, values in groups.items():
                _fill(getattr(counts_for(table, labels[code]), which), values)


def _fill(lat: Latency, values: list[float]) -> None:
    """The samples ``values`` into ``lat``, bucketed as ``Latency.add`` buckets them."""
    lat.n += len(values)
    lat.min = min(lat.min, min(values))
    lat.max = max(lat.max, max(values))
    log, floor, step = math.log, math.floor, _LOG_STEP
    buckets = lat.buckets
    for x in values:
        if x <= 1e-9:
            lat.zero += 1
        else:
            buckets[int(floor(log(x) / step))] += 1


def devices_of(store: EventStore, stop: int) -> dict:
    """The device map (address -> model/devices.py's ``DeviceInfo``) of the first
    ``stop`` stored events, from the columns: per device, the commands sent to
    it, the ACKs and NAKs it answered, the lines its paired answers (results,
    ACKs, NAKs, NICs) came on, and the commands it answered with NIC. A device
    comes in the order it first appears."""
    from dissectors.event import NIC, ST_NIC

    from .model.devices import DeviceInfo

    out: dict = {}
    if not stop:
        return out

    col = Columns(store, 0, stop).column
    kind, device, flags, line = col("kind"), col("device"), col("flags"), col("line")
    names = list(store._devices.values)
    lines = list(store._lines.values)
    is_command = kind == _K[COMMAND]
    answer = np.isin(kind, [_K[RESULT], _K[ACK], _K[NAK], _K[NIC]]) & ((flags & LINKED) != 0)
    mapped = (is_command | answer) & (device != 0)

    def info(code: int):
        addr = names[code]
        got = out.get(addr)
        if got is None:
            got = out[addr] = DeviceInfo(addr)
        return got

    # in the order devices first appear, as the map fed event by event makes them
    order = np.unique(device[mapped], return_index=True)
    for code in order[0][np.argsort(order[1])].tolist():
        info(code)
    for code, n in zip(*np.unique(device[mapped & is_command], return_counts=True)):
        info(code).commands += int(n)
    acks = mapped & np.isin(kind, [_K[ACK], _K[NAK]])
    for code, n in zip(*np.unique(device[acks], return_counts=True)):
        info(code).answered += int(n)
    pairs = np.unique(device[mapped & answer].astype(np.int64) * 256 + line[mapped & answer])
    for p in pairs.tolist():
        info(p // 256).lines.add(lines[p % 256])
    nic = mapped & is_command & (col("status") == STATUSES.index(ST_NIC))
    commands = list(store._commands.values)
    for code, c in set(zip(device[nic].tolist(), col("command")[nic].tolist())):
        if c and commands[c][0]:
            info(code).nic.add(commands[c][0])
    return out
