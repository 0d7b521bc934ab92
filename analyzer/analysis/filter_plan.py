"""What a compiled filter tests, beside the closure that tests it: a plan that an
engine over columns (the TUI's event store, analyzer/formats/store_filter.py) can
evaluate for many events at once.

The closure stays the ground truth. A plan is a tree of

- ``AllOf(plans)``, ``AnyOf(plans)``, ``Not(plan)``, ``Const(bool)``;
- ``Leaf(name, test, op, value, negate)``: one comparison of a name with a
  constant (``status == "nak"``, ``latency > 0.05``, ``command in ["P?", "HO"]``),
  ``op`` ``"truth"`` for a bare name (``problems``), ``"has"`` for a constant
  ``in`` a name (``"bad checksum" in problems``). ``name`` is a ``Name``:
  ``status``, or ``dst`` with the keys of a path (``dst[2]``). ``test`` is the
  leaf's own closure: an engine may run it on a stand-in event holding one
  value (each distinct value of a column of codes), so the leaf's rules (types,
  absent values, lists, prefixes) are the closure's, never written twice;
- ``None``: anything else (two names compared, a computed list), which an
  engine leaves to the closure.

While a filter is parsed, ``Plans`` remembers what each closure made is: a
plan, a name it reads (``Name``) or a constant operand (``Value``), keyed by
the closure itself (kept alive as the key, so no other object can take its
place while the parse lives).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from dissectors.event import Event

Test = Callable[[Event], Any]
_Made = TypeVar("_Made", bound=Test)


@dataclass(frozen=True, slots=True)
class Name:
    """A name an event is read by, or a path into one (``fields.azimuth_deg``, ``dst[2]``)."""
    name: str
    keys: tuple[str | int, ...] = ()


@dataclass(frozen=True, slots=True)
class Value:
    """A constant operand (a literal, a list of literals)."""
    value: Any


@dataclass(frozen=True, slots=True)
class Leaf:
    """One comparison of a name with a constant (module docstring)."""
    name: Name
    test: Test
    op: str
    value: Any
    negate: bool


@dataclass(frozen=True, slots=True)
class Const:
    """A test with the same answer for every event."""
    value: bool


@dataclass(frozen=True, slots=True)
class Not:
    plan: Plan | None


@dataclass(frozen=True, slots=True)
class AllOf:
    plans: tuple[Plan | None, ...]


@dataclass(frozen=True, slots=True)
class AnyOf:
    plans: tuple[Plan | None, ...]


Plan = Leaf | Const | Not | AllOf | AnyOf


class Plans:
    """What each closure one parse makes is (module docstring)."""

    def __init__(self) -> None:
        self._made: dict[Test, Plan | Name | Value | None] = {}

    def made(self, fn: _Made, what: Plan | Name | Value | None) -> _Made:
        self._made[fn] = what
        return fn

    def test(self, fn: Test) -> Plan | None:
        """The plan of ``fn`` used as a test (its truth): a bare name is a truth leaf."""
        what = self._made.get(fn)
        if isinstance(what, Value):
            return Const(bool(what.value))
        if isinstance(what, Name):
            return Leaf(what, lambda ev: bool(fn(ev)), "truth", None, False)
        return what

    def comparison(self, test: Test, op: str, left: Test, right: Test, negate: bool) -> Plan | None:
        """A comparison's plan: a leaf when one side is a name and the other a constant."""
        lp, rp = self._made.get(left), self._made.get(right)
        if isinstance(lp, Name) and isinstance(rp, Value):
            return Leaf(lp, test, op, rp.value, negate)
        if op == "in" and isinstance(rp, Name) and isinstance(lp, Value):
            return Leaf(rp, test, "has", lp.value, negate)
        return None
