"""Listeners of the tap runner (analyzer/runner.py) that are not file writers
(those are in analyzer/writers): printing events and notes, the wiring doctor,
the live Foxglove server."""

from .doctor import DoctorListener
from .printer import EventPrinter, NotePrinter

__all__ = ["DoctorListener", "EventPrinter", "FoxgloveServer", "NotePrinter"]


def __getattr__(name: str):
    # imported when asked for: the Foxglove SDK takes a noticeable part of every
    # command's start, and only --foxglove needs it
    if name == "FoxgloveServer":
        from .foxglove import FoxgloveServer
        return FoxgloveServer
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
