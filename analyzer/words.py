"""Counts as every message words them: thousands separated, the noun agreeing
(``1 event``, ``1,024 events``, ``3 device addresses``), so that no line reads
"recorded 1 messages" or "3 device address(es)"; and sizes as the screen shows
them (``571 B``, ``30.1 kB``)."""

from __future__ import annotations


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``: the plural is ``noun + "s"`` unless given."""
    return f"{n:,} {noun if n == 1 else (plural or noun + 's')}"


def byte_size(n: float) -> str:
    """``n`` bytes in decimal units: ``571 B``, ``30.1 kB``, ``2.4 MB``, ``1.2 GB``."""
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return ""
