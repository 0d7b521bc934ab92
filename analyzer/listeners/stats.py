"""Counting a run's events into statistics (analyzer/analysis/stats.py), and the
statistics as people read them: the summary lines and the per-command and
per-device tables, printed by ``gimbalscope stats`` and shown on the TUI's
statistics screen in the same words (one name per column, the JSON's)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from dissectors.event import P_CHECKSUM, P_NOISE, P_TRUNCATED, STATUSES, Event

from ..analysis.stats import COUNT_COLUMNS, LATENCY_COLUMNS, Stats
from ..output import fmt_seconds
from ..runner import Listener
from ..words import counted

if TYPE_CHECKING:
    from ..formats.fit_width import FitTable


class StatsListener(Listener):
    """Counts every event ``keep`` accepts (all without a filter) into ``stats``."""

    def __init__(self, keep: Callable[[Event], bool] | None = None) -> None:
        self.stats = Stats()   # of every event counted so far, whenever read
        self.keep = keep

    def on_events(self, events: list[Event]) -> None:
        keep = self.keep
        self.stats.add_events(events if keep is None else [ev for ev in events if keep(ev)])


# what a noise event is, by its problem category (the deframer's: docs/decoding.md)
_NOISE_NAMES = {P_NOISE: ("noise run", "noise runs"), P_CHECKSUM: ("broken frame", "broken frames"),
                P_TRUNCATED: ("truncated frame", "truncated frames")}


def _broken(data: dict[str, Any]) -> str:
    """Checksum errors count every event with a checksum problem (the problems
    line's `bad checksum` and `bad length byte`); say which are not frames."""
    n = data["broken_frames"]
    if not n:
        return ""
    frames = data["checksum_errors"] - n
    return f" ({frames:,} in frames, {n:,} in {'a broken frame' if n == 1 else 'broken frames'} shown as noise)"


def _noise_kinds(data: dict[str, Any]) -> str:
    """Noise events are unframed bytes (the problems line's `noise`) and frames
    broken or cut short: say how many of each when they are not all noise runs."""
    kinds = data["noise"]["by_problem"]
    if set(kinds) <= {P_NOISE}:
        return ""
    parts = []
    for cat, n in kinds.items():
        one, many = _NOISE_NAMES.get(cat, (cat, cat))
        parts.append(counted(n, one, many))
    return " (" + ", ".join(parts) + ")"


def summary(data: dict[str, Any]) -> list[str]:
    """The lines above the tables, of ``Stats.to_dict()``: each short enough for
    80 columns with everyday counts (the problems line names what it meets)."""
    dur, s, noise = data["duration"], data["status"], data["noise"]
    lines = [f"{counted(data['events'], 'event')}, {counted(data['commands'], 'command')}"
             + (f" over {dur:.3f} s" if dur is not None else " (no time in this capture)")
             + "  bytes: " + ", ".join(f"line {k} {v:,}" for k, v in data["bytes"].items()),
             "  ".join(f"{status} {s[status]:,}" for status in STATUSES),
             f"retransmissions {data['retransmissions']:,}  orphans {data['orphans']:,}",
             f"checksum errors {data['checksum_errors']:,}{_broken(data)}",
             f"noise {counted(noise['events'], 'event')} / {counted(noise['bytes'], 'byte')}{_noise_kinds(data)}"]
    for rate in data.get("rate_changes", ()):
        by = f" (ACKed rate-set #{rate['request']})" if rate.get("request") is not None else ""
        lines.append(f"link rate {rate['previous_baud']} → {rate['baud']} bps at #{rate['number']}{by}")
    if data["problems"]:
        lines.append("problems (events per category): "
                     + ", ".join(f"{k} {v:,}" for k, v in data["problems"].items()))
    return lines


def headers() -> list[str]:
    """The names of a table's columns after its key column, in order."""
    return [name for group in COUNT_COLUMNS for name in group] + \
        [name for group in LATENCY_COLUMNS for name, _key, _stat in group]


def counts_table(key: str, counts: dict[str, dict[str, Any]], title: str = "") -> FitTable:
    """The table of ``Stats.to_dict()``'s ``by_command`` or ``by_device``: a row per
    command or device (``key`` names the column), every column named as the JSON
    names it; split into more tables where the width is short."""
    from ..formats.fit_width import FitTable

    rows = []
    for name, c in counts.items():
        row = [name, *(f"{c[k]:,}" for group in COUNT_COLUMNS for k in group)]
        row += [fmt_seconds(c[which][stat]) if c[which]["count"] else ""
                for group in LATENCY_COLUMNS for _name, which, stat in group]
        rows.append(row)
    groups = [*COUNT_COLUMNS, *([name for name, _k, _s in group] for group in LATENCY_COLUMNS)]
    return FitTable(key, groups, rows, title)
