"""Counts as every message words them: thousands separated, the noun agreeing
(``1 event``, ``1,024 events``, ``3 device addresses``), so that no line reads
"recorded 1 messages" or "3 device address(es)"."""

from __future__ import annotations


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``: the plural is ``noun + "s"`` unless given."""
    return f"{n:,} {noun if n == 1 else (plural or noun + 's')}"
