"""What a compiled filter tests, beside the closure that tests it: a plan that an
engine over columns (the TUI's event store, analyzer/tui/store_filter.py) can
evaluate for many events at once.

The closure stays the ground truth. A plan is a tree of

- ``("and", plans)``, ``("or", plans)``, ``("not", plan)``, ``("const", bool)``;
- ``("leaf", name, test, op, value, negate)``: one comparison of a name with a
  constant (``status == "nak"``, ``latency > 0.05``, ``command in ["P?", "HO"]``),
  ``op`` ``"truth"`` for a bare name (``problems``), ``"has"`` for a constant
  ``in`` a name (``"bad checksum" in problems``). ``name`` is the name plan
  ``("name", "status")``, or ``("name", "dst", 2)`` with the keys of a path.
  ``test`` is the leaf's own closure: an engine may run it on a stand-in event
  holding one value (each distinct value of a column of codes), so the leaf's
  rules (types, absent values, lists, prefixes) are the closure's, never
  written twice;
- ``None``: anything else (two names compared, a computed list), which an
  engine leaves to the closure.
"""

from __future__ import annotations

from collections.abc import Callable

Plan = tuple | None


class Plans:
    """The plans of the closures one parse makes, by the closures' identity (the
    closures are kept, so an identity is never reused while the parse lives)."""

    def __init__(self) -> None:
        self._plans: dict[int, Plan] = {}
        self._kept: list[Callable] = []

    def made(self, fn: Callable, plan: Plan) -> Callable:
        self._plans[id(fn)] = plan
        self._kept.append(fn)
        return fn

    def of(self, fn: Callable) -> Plan:
        return self._plans.get(id(fn))

    def test(self, fn: Callable) -> Plan:
        """The plan of ``fn`` used as a test (its truth): a bare name is a truth leaf."""
        if getattr(fn, "is_const", False):
            return ("const", bool(fn.value))
        plan = self.of(fn)
        if plan is not None and plan[0] == "name":
            return ("leaf", plan, lambda ev: bool(fn(ev)), "truth", None, False)
        return plan

    def comparison(self, test: Callable, op: str, left: Callable, right: Callable, negate: bool) -> Plan:
        """A comparison's plan: a leaf when one side is a name and the other a constant."""
        lp, rp = self.of(left), self.of(right)
        if lp is not None and lp[0] == "name" and getattr(right, "is_const", False):
            return ("leaf", lp, test, op, right.value, negate)
        if op == "in" and rp is not None and rp[0] == "name" and getattr(left, "is_const", False):
            return ("leaf", rp, test, "has", left.value, negate)
        return None

