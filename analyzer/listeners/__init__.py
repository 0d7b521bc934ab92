"""Listeners of the tap runner (analyzer/runner.py) that are not file writers
(those are in analyzer/writers): printing events and notes, the wiring doctor
and its live findings, statistics, the gimbals with positions, the live Foxglove
server. A command module builds its listeners from here and hands them to the
runner; none of them touches the capture."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .doctor import DoctorListener, FindingTeller
from .positions import PositionFinder
from .printer import EventPrinter, NotePrinter
from .stats import StatsListener

if TYPE_CHECKING:
    from .foxglove import FoxgloveServer

__all__ = ["DoctorListener", "EventPrinter", "FindingTeller", "FoxgloveServer", "NotePrinter", "PositionFinder",
           "StatsListener"]


def __getattr__(name: str) -> type[FoxgloveServer]:
    # imported when asked for: the Foxglove SDK takes a noticeable part of every
    # command's start, and only --foxglove needs it
    if name == "FoxgloveServer":
        from .foxglove import FoxgloveServer
        return FoxgloveServer
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
