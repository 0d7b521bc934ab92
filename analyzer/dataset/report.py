"""The fleet report (``gimbalscope report``): each device over time, from an
exported dataset (docs/dataset.md), and which devices are getting worse.

Per device and period (a day or a week): commands, each status (spec
§1.4.2-1.4.3: ok, nak, nic, no_ack, no_result, pending), the error and NAK
rates, and the ACK and result latency percentiles; per capture, the wiring
doctor's findings. The sums and percentiles are DuckDB's, over the
``transactions`` view, so a report of months of traffic costs one pass over it.

A device is *trending worse* when, over its periods with enough commands, the
least-squares line through its p95 ACK latency (or its error rate) rises, and
rises by enough to matter between its first and last period: see
``LATENCY_RISE`` and ``ERROR_RISE``. The line, not the first and last points,
so that one bad day at either end does not decide.

No printing here: ``cli/report.py`` writes text, ``report_html.py`` the page.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field
from typing import Any, Protocol

from ..output import fmt_seconds

STATUSES = ("ok", "nak", "nic", "no_ack", "no_result", "pending")
ERRORS = ("nak", "nic", "no_ack", "no_result")   # a command that did not get what it asked for

# The columns of a device's periods, in the text report and the HTML page alike: a
# count or rate by its key in the JSON (``to_dict``); a latency as ``stats`` and the
# TUI name it (``ACK median`` for ``ack_p50_ms``: one name for one quantity wherever
# it shows); the counts as ``stats`` names them. In groups kept side by side when a
# table is split to fit the terminal.
PERIOD_COLUMNS = (("commands", *STATUSES), ("error_rate", "nak_rate"),
                  ("ACK median", "ACK p95", "result median", "result p95"))

# A period counts toward a trend only with this many commands: a handful of
# commands give percentiles and rates that are mostly noise.
MIN_COMMANDS = 20
# Trends need at least this many such periods: two points always make a line.
MIN_PERIODS = 3
# p95 ACK latency: the fitted line must rise by this share of its first value
# (20%: well above the day-to-day spread of a healthy link's p95, which is set by
# the controller's and gimbal's firmware, not by chance).
LATENCY_RISE = 0.20
# Error rate: the fitted line must rise by this many points of rate (0.02 = 2
# percentage points: a link that loses one command in fifty more than before).
ERROR_RISE = 0.02


@dataclass
class Period:
    start: dt.date
    commands: int
    statuses: dict[str, int]
    ack_p50: float | None
    ack_p95: float | None
    result_p50: float | None
    result_p95: float | None

    @property
    def errors(self) -> int:
        return sum(self.statuses.get(s, 0) for s in ERRORS)

    @property
    def error_rate(self) -> float:
        return self.errors / self.commands if self.commands else 0.0

    @property
    def nak_rate(self) -> float:
        return self.statuses.get("nak", 0) / self.commands if self.commands else 0.0


def period_cells(p: Period) -> list[str]:
    """A period's row under ``PERIOD_COLUMNS``, as people read it."""
    return [f"{p.commands:,}", *(f"{p.statuses.get(s, 0):,}" for s in STATUSES),
            f"{p.error_rate:.1%}", f"{p.nak_rate:.1%}",
            *(fmt_seconds(v) for v in (p.ack_p50, p.ack_p95, p.result_p50, p.result_p95))]


@dataclass
class Trend:
    what: str            # "ack_p95" or "error_rate"
    first: float         # the fitted line at the first and last period
    last: float
    slope_per_day: float

    def text(self) -> str:
        if self.what == "ack_p95":
            return (f"p95 ACK latency {self.first * 1000:.1f} → {self.last * 1000:.1f} ms "
                    f"({self.slope_per_day * 1000:+.2f} ms/day)")
        return (f"error rate {self.first:.1%} → {self.last:.1%} "
                f"({self.slope_per_day * 100:+.2f} points/day)")


@dataclass
class DeviceReport:
    device: str
    periods: list[Period]
    worse: list[Trend] = field(default_factory=list)

    @property
    def commands(self) -> int:
        return sum(p.commands for p in self.periods)


@dataclass
class Finding:
    severity: str
    code: str
    subject: str
    title: str


@dataclass
class CaptureReport:
    capture: str
    site: str | None
    start: dt.datetime | None
    findings: list[Finding]


@dataclass
class Report:
    period: str
    devices: list[DeviceReport]
    captures: list[CaptureReport]

    @property
    def worse(self) -> list[DeviceReport]:
        return [d for d in self.devices if d.worse]


def _fit(xs: list[float], ys: list[float]) -> tuple[float, float]:
    """Least squares: (slope, intercept)."""
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    if sxx == 0:
        return 0.0, my
    slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx
    return slope, my - slope * mx


def trends(periods: list[Period], *, min_commands: int = MIN_COMMANDS) -> list[Trend]:
    """The ways ``periods`` (of one device, oldest first) are getting worse."""
    used = [p for p in periods if p.commands >= min_commands]
    if len(used) < MIN_PERIODS:
        return []
    origin = used[0].start
    out = []
    for what, value, worse in (
            ("ack_p95", lambda p: p.ack_p95, lambda a, b: a > 0 and (b - a) / a >= LATENCY_RISE),
            ("error_rate", lambda p: p.error_rate, lambda a, b: b - a >= ERROR_RISE)):
        points = [((p.start - origin).days, value(p)) for p in used if value(p) is not None]
        if len(points) < MIN_PERIODS:
            continue
        xs, ys = [float(x) for x, _ in points], [float(y) for _, y in points]
        slope, intercept = _fit(xs, ys)
        first, last = intercept + slope * xs[0], intercept + slope * xs[-1]
        if slope > 0 and worse(max(first, 0.0), last):
            out.append(Trend(what, max(first, 0.0), last, slope))
    return out


@dataclass(frozen=True)
class Dialect:
    """How an engine spells what the report's SQL needs beyond what DuckDB and
    Spark SQL share: the continuous quantile (linear interpolation between the
    two nearest values, in both)."""
    quantile: str   # with {col} and {q}


class Rows(Protocol):
    def fetchall(self) -> list[Any]: ...


class Engine(Protocol):
    """What ``build`` asks of an SQL engine over the dataset's views."""

    def execute(self, sql: str, /) -> Rows: ...


DUCKDB = Dialect(quantile="quantile_cont({col}, {q})")
SPARK = Dialect(quantile="percentile({col}, {q})")


def build(con: Engine, period: str = "day", *, min_commands: int = MIN_COMMANDS, dialect: Dialect = DUCKDB) -> Report:
    """The report of the dataset behind ``con``: anything whose ``execute(sql)``
    gives rows by ``fetchall()`` (a DuckDB connection, ``query.connect``; Spark,
    ``spark/report.py``), in ``dialect``."""
    if period not in ("day", "week"):
        raise ValueError(f"period {period!r}: day or week")
    counts = ", ".join(f"count(*) FILTER (WHERE status = '{s}')" for s in STATUSES)
    quantiles = ", ".join(dialect.quantile.format(col=col, q=q)
                          for col in ("ack_latency", "result_latency") for q in (0.5, 0.95))
    rows = con.execute(f"""
        SELECT device, CAST(date_trunc('{period}', date) AS DATE) AS period, count(*), {counts}, {quantiles}
        FROM transactions
        WHERE date IS NOT NULL AND device IS NOT NULL
        GROUP BY ALL
        ORDER BY device, period""").fetchall()
    devices: dict[str, DeviceReport] = {}
    for row in rows:
        device, start, commands = row[0], row[1], row[2]
        statuses = dict(zip(STATUSES, row[3:3 + len(STATUSES)]))
        p = Period(start, commands, statuses, *row[3 + len(STATUSES):])
        devices.setdefault(device, DeviceReport(device, [])).periods.append(p)
    for d in devices.values():
        d.worse = trends(d.periods, min_commands=min_commands)
    captures: dict[str, CaptureReport] = {}
    for capture, site, start in con.execute(
            "SELECT capture, any_value(site), min(start) FROM findings GROUP BY capture ORDER BY min(start), capture"
    ).fetchall():
        captures[capture] = CaptureReport(capture, site, _utc(start), [])
    for capture, severity, code, subject, title in con.execute(
            "SELECT capture, severity, code, subject, title FROM findings "
            "ORDER BY capture, CASE severity WHEN 'error' THEN 0 WHEN 'warning' THEN 1 ELSE 2 END, code, subject"
    ).fetchall():
        captures[capture].findings.append(Finding(severity, code, subject, title))
    ordered = sorted(devices.values(), key=lambda d: (not d.worse, _device_key(d.device)))
    return Report(period, ordered, list(captures.values()))


def _utc(when: dt.datetime | None) -> dt.datetime | None:
    """A capture's start in UTC, the dataset's time zone, whatever zone the
    engine gave it in (DuckDB: its session's; Spark: the Python process's,
    without saying)."""
    return None if when is None else when.astimezone(dt.UTC)


def _device_key(device: str) -> tuple[tuple[int, ...], str]:
    """1.1.10 after 1.1.9: addresses sort by their numbers."""
    parts = device.split(".")
    return tuple(int(p) if p.isdigit() else 1 << 30 for p in parts), device


def to_dict(report: Report) -> dict:
    """The report as JSON (``--format json``)."""
    def ms(v):
        return None if v is None else round(v * 1000, 3)
    return {
        "period": report.period,
        "devices": [{
            "device": d.device,
            "trending_worse": [{"what": t.what, "first": t.first, "last": t.last, "slope_per_day": t.slope_per_day,
                                "text": t.text()} for t in d.worse],
            "periods": [{"start": p.start.isoformat(), "commands": p.commands, **p.statuses,
                         "error_rate": round(p.error_rate, 6), "nak_rate": round(p.nak_rate, 6),
                         "ack_p50_ms": ms(p.ack_p50), "ack_p95_ms": ms(p.ack_p95),
                         "result_p50_ms": ms(p.result_p50), "result_p95_ms": ms(p.result_p95)}
                        for p in d.periods]} for d in report.devices],
        "captures": [{"capture": c.capture, "site": c.site,
                      "start": c.start.isoformat() if c.start is not None else None,
                      "findings": [f.__dict__ for f in c.findings]} for c in report.captures],
    }
