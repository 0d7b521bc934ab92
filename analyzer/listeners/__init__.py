"""Listeners of the tap runner (analyzer/runner.py) that are not file writers
(those are in analyzer/writers): printing events and notes, the wiring doctor."""

from .doctor import DoctorListener
from .printer import EventPrinter, NotePrinter

__all__ = ["DoctorListener", "EventPrinter", "NotePrinter"]
