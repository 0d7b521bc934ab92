"""The filter language of ``decode --filter`` and the TUI's filter bar.

A small, safe expression language over the JSON Lines names; it is parsed into
closures, never ``eval``-ed::

    status == "nak" or problems
    command in ["P?", "P"] and latency > 0.05
    kind == "result" and azimuth_deg < -10
    dst[2] == 3 and not checksum_ok
    device == "1.1.2"
    "bad checksum" in problems

Names are the event's JSON keys, or a decoded field's name (``azimuth_deg`` is
``fields.azimuth_deg``). A name the event does not have (an ACK's ``status``,
a command's ``latency``) is absent: its value is ``null``. Wireshark's prefix
is accepted (``gimbal.status`` is ``status``), so a filter can come from tshark.

An error names the column and the fault, and the fix where one is likely
(filter_hints.py): ``status == nak`` offers ``status == "nak"``.

Comparisons between values of different types are false, never errors. The
types are null, booleans, numbers, strings, lists and objects; ``true`` is not
the number 1. Like Wireshark's for absent fields, this holds for ``!=`` too:

- ``x == y`` and ``x != y`` are true only when both are present, of the same
  type, and equal (``==``) or different (``!=``). So ``status != "ok"`` selects
  the commands whose status is something else, not the ACKs and results that
  have no status; ``not status == "ok"`` selects those too.
- Against the literal ``null`` they test presence: ``x == null`` is true where
  x is absent, ``x != null`` where it is present; ``null == null`` is true and
  ``null != null`` false.
- ``<`` ``>`` ``<=`` ``>=`` compare two numbers or two strings.
- ``x in list`` is true when an element equals x by the rules above; on a list of
  strings it also matches an element that starts with ``x:``, so a problem
  category matches its detailed problems. ``x in "text"`` is a substring test,
  ``x in fields`` a key test. ``x not in y`` is ``not (x in y)``, so it also
  holds where x is absent.

Limits, so that no expression can exhaust the stack or the CPU: parentheses,
``not`` and list brackets nest at most 64 levels; a number has at most 30
digits and must be finite. ``and``/``or`` chains are flat (one closure over
all operands, short-circuiting), so a thousand ``or``s are as safe as two, and
a list of constants is built once, at compile time, into a set.
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Callable
from operator import attrgetter
from typing import Any, Protocol, cast

from dissectors.commands import COMMANDS, DERIVED_FIELDS, field_types
from dissectors.event import KINDS, STATUSES, Event

from ..errors import FilterError
from .filter_hints import DST_PARTS, PROTOCOL, Fix, Vocabulary, character_fix, dst_text_fix, operator_fix, value_fix
from .filter_plan import AllOf, AnyOf, Name, Not, Plan, Plans, Value

Getter = Callable[[Event], Any]   # what a part of a filter makes of an event
Token = tuple[str, Any, int]      # (what it is, its value, its column from 1)


class Predicate(Protocol):
    """A compiled filter (``compile_filter``): true for the events it selects.
    ``plan`` says what it tests, for evaluating it over columns (filter_plan.py)."""
    plan: Plan | None

    def __call__(self, ev: Event, /) -> bool: ...


MAX_NESTING = 64     # parentheses, 'not' and list brackets, counted together
MAX_DIGITS = 30      # beyond any value on the wire; int() of thousands of digits is refused by Python

TOP_LEVEL = ("number", "t", "t_end", "line", "offset", "kind", "command", "dst", "src", "payload",
             "checksum_ok", "fields", "problems", "txn", "status", "latency", "retransmission",
             "request", "raw", "device")
ENUMS = {
    "kind": set(KINDS),
    "status": set(STATUSES),
    "line": {"A", "B", "AB"},
}


def _field_names() -> set[str]:
    names = set(DERIVED_FIELDS)
    for c in COMMANDS:
        for layout in (c.layout, *c.result):
            names.update(f.name for f in layout.fields)
    return names


FIELD_NAMES = _field_names()


def _clip(text: str, most: int = 40) -> str:
    return text if len(text) <= most else text[:most] + "…"


# [0-9], not \d: Python's int() would also take other scripts' digits.
_TOKEN = re.compile(r"""
    (?P<ws>\s+)
  | (?P<num>-?[0-9]+(?:\.[0-9]+)?(?:[eE][-+]?[0-9]+)?)
  | (?P<str>"(?:[^"\\]|\\.)*"|'(?:[^'\\]|\\.)*')
  | (?P<op>==|!=|<=|>=|<|>|\(|\)|\[|\]|,|\.)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
""", re.VERBOSE)
KEYWORDS = {"and", "or", "not", "in", "true", "false", "null"}
COMPARISONS = ("==", "!=", "<", ">", "<=", ">=")
# what a wrong name was meant to be (filter_hints.py): every name, and each field's unit
VOCABULARY = Vocabulary((*TOP_LEVEL, *FIELD_NAMES), {n: t.unit for n, t in field_types().items()}, KEYWORDS,
                        FIELD_NAMES)
_ESCAPE = re.compile(r"\\(.)")


def _number(text: str, col: int, src: str) -> int | float:
    """A number literal, refused when it has more digits than any value could
    need (Python's int() raises beyond 4300 digits) or overflows to infinity."""
    mantissa = re.split("[eE]", text)[0]
    if sum(c.isdigit() for c in mantissa) > MAX_DIGITS:
        raise FilterError(f"number {_clip(text, 20)} has more than {MAX_DIGITS} digits", col, src)
    if any(c in text for c in ".eE"):
        value = float(text)
        if math.isinf(value):
            raise FilterError(f"number {_clip(text, 20)} is out of range", col, src)
        return value
    return int(text)


def _tokenize(src: str) -> list[Token]:
    out: list[Token] = []
    pos = 0
    while pos < len(src):
        m = _TOKEN.match(src, pos)
        if m is None:
            fix = character_fix(src, pos)
            raise FilterError(f"unexpected character {src[pos]!r}{fix.clause(src) if fix else ''}", pos + 1, src)
        kind = m.lastgroup
        text = m.group()
        if kind == "num":
            out.append(("num", _number(text, pos + 1, src), pos + 1))
        elif kind == "str":
            body = text[1:-1]
            if "\\" in body:
                body = _ESCAPE.sub(r"\1", body)
            out.append(("str", body, pos + 1))
        elif kind == "op":
            out.append(("op", text, pos + 1))
        elif kind == "name":
            out.append(("kw" if text in KEYWORDS else "name", text, pos + 1))
        pos = m.end()
    out.append(("end", None, len(src) + 1))
    return out


# ------------------------------------------------------------------ values
def _kind(v: Any) -> str | None:
    """The filter type of a value; None for null (and anything no literal can be)."""
    if isinstance(v, bool):      # before int: True is an int to Python, not here
        return "bool"
    if isinstance(v, (int, float)):
        return "number"
    if isinstance(v, str):
        return "string"
    if isinstance(v, (list, tuple)):
        return "list"
    if isinstance(v, dict):
        return "object"
    return None


_SCALAR_TYPES = (str, int, float, bool)


def _equal(a: Any, b: Any) -> bool:
    """Both present, the same type, equal; lists element by element."""
    t = type(a)
    if t is type(b) and t in _SCALAR_TYPES:   # the usual case, without classifying
        return a == b
    k = _kind(a)
    if k is None or k != _kind(b):
        return False
    if k == "list":
        return len(a) == len(b) and all(_element_equal(x, y) for x, y in zip(a, b))
    return a == b


def _element_equal(x: Any, y: Any) -> bool:
    return (x is None and y is None) or _equal(x, y)


def _differ(a: Any, b: Any) -> bool:
    """Both present, the same type, different (module docstring)."""
    k = _kind(a)
    return k is not None and k == _kind(b) and not _equal(a, b)


def _num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _ordered(a: Any, b: Any) -> bool:
    return (_num(a) and _num(b)) or (isinstance(a, str) and isinstance(b, str))


def _contains(container: Any, item: Any) -> bool:
    """``item in container`` for a container known only when evaluating."""
    if isinstance(container, str):
        return isinstance(item, str) and item in container
    if isinstance(container, (list, tuple)):
        if isinstance(item, str):
            # str == only matches str, so Python's own membership is exact here
            if item in container:
                return True
            prefix = item + ":"
            return any(isinstance(x, str) and x.startswith(prefix) for x in container)
        return any(_element_equal(item, x) for x in container)
    if isinstance(container, dict):
        return isinstance(item, str) and item in container
    return False


_NO_KEY = object()


def _key(v: Any) -> Any:
    """A hashable key equal exactly when the filter's equality holds (the type
    is part of it: True and 1 differ); _NO_KEY for what no constant equals."""
    k = _kind(v)
    if k == "list":
        keys = tuple(_key(x) for x in v)
        return _NO_KEY if _NO_KEY in keys else ("list", keys)
    if k == "object":
        return _NO_KEY
    try:
        hash(v)
    except TypeError:
        return _NO_KEY
    return (k, v)


class _Members:
    """A constant list on the right of ``in``, built once: a set of keys for
    exact matches and the set of ``category`` prefixes its ``category: detail``
    strings have, so a lookup costs the same for three elements or 30 000."""
    __slots__ = ("keys", "prefixes")

    def __init__(self, items: list) -> None:
        self.keys = frozenset(_key(x) for x in items)
        prefixes: set[str] = set()
        for s in items:
            if isinstance(s, str):
                prefixes.update(s[:i] for i, c in enumerate(s) if c == ":")
        self.prefixes = frozenset(prefixes)

    def has(self, item: Any) -> bool:
        if isinstance(item, str):   # the usual case: command in ["P?", "HO"]
            return ("string", item) in self.keys or item in self.prefixes
        key = _key(item)
        return key is not _NO_KEY and key in self.keys


class _Const:
    """A constant operand. A class (not a closure) so the parser can see that
    an operand is constant and fold it at compile time."""
    __slots__ = ("value",)

    def __init__(self, value: Any) -> None:
        self.value = value

    def __call__(self, ev: Event) -> Any:
        return self.value


def _is_null(f: Callable) -> bool:
    return isinstance(f, _Const) and f.value is None


_ORDER = {
    "<": lambda a, b: _ordered(a, b) and a < b,
    ">": lambda a, b: _ordered(a, b) and a > b,
    "<=": lambda a, b: _ordered(a, b) and a <= b,
    ">=": lambda a, b: _ordered(a, b) and a >= b,
}


def _comparison(op: str, left: Callable, right: Callable, negate: bool) -> Callable[[Event], bool]:
    """One comparison as a closure, with constant operands taken out of the loop."""
    if op in ("==", "!=") and (_is_null(left) or _is_null(right)):
        other = right if _is_null(left) else left
        if op == "==":
            return lambda ev: other(ev) is None
        return lambda ev: other(ev) is not None
    if op == "in":
        if isinstance(right, _Const) and _kind(right.value) == "list":
            has = _Members(right.value).has
            if negate:
                return lambda ev: not has(left(ev))
            return lambda ev: has(left(ev))
        test = lambda a, b: _contains(b, a)
        if negate:
            return lambda ev: not test(left(ev), right(ev))
    elif isinstance(right, _Const) and _kind(right.value) in ("string", "number"):
        return _against_scalar(op, left, right.value)
    else:
        test = {"==": _equal, "!=": _differ}.get(op) or _ORDER[op]
    if isinstance(right, _Const):
        value = right.value
        return lambda ev: test(left(ev), value)
    return lambda ev: test(left(ev), right(ev))


_NUMBER_TYPES = (int, float)   # exact types, checked first because it is quick (bool is not one)
_OPERATORS = {"==": operator.eq, "!=": operator.ne, "<": operator.lt, ">": operator.gt,
              "<=": operator.le, ">=": operator.ge}


def _against_scalar(op: str, left: Callable, c: Any) -> Callable[[Event], bool]:
    """``x op "text"`` or ``x op 12.5``: the common case, one closure with the
    type check inlined (a filter runs once per event of a capture)."""
    if isinstance(c, str) and op == "==":
        return lambda ev: left(ev) == c    # a str equals only a str: no check needed
    compare = _OPERATORS[op]
    if isinstance(c, str):
        def test(ev: Event) -> bool:
            v = left(ev)
            return isinstance(v, str) and compare(v, c)
    else:
        def test(ev: Event) -> bool:
            v = left(ev)
            return (type(v) in _NUMBER_TYPES or _kind(v) == "number") and compare(v, c)
    return test


def _any_of(operands: tuple) -> Callable[[Event], bool]:
    """``a or b or …`` as one closure: short-circuits, never recurses per operand."""
    if len(operands) == 2:
        a, b = operands
        # a jump, not a call of bool(): a tenth quicker, and it runs once an event
        return lambda ev: True if a(ev) or b(ev) else False  # noqa: SIM210 - see above

    def any_of(ev: Event) -> bool:
        for f in operands:
            if f(ev):
                return True
        return False
    return any_of


def _all_of(operands: tuple) -> Callable[[Event], bool]:
    """``a and b and …`` as one closure (see ``_any_of``)."""
    if len(operands) == 2:
        a, b = operands
        return lambda ev: True if a(ev) and b(ev) else False  # noqa: SIM210 - as in _any_of

    def all_of(ev: Event) -> bool:
        for f in operands:
            if not f(ev):
                return False
        return True
    return all_of


def _path(base: Callable, keys: tuple) -> Callable[[Event], Any]:
    """``name.key[2]…`` as one closure, walking the keys in a loop."""
    def get(ev: Event) -> Any:
        v = base(ev)
        for k in keys:
            if v is None:
                return None
            v = _get(v, k)
        return v
    return get


def _get(obj: Any, key: Any) -> Any:
    if isinstance(obj, dict):
        return obj.get(key) if isinstance(key, (str, int)) else None
    if isinstance(obj, (list, tuple)) and isinstance(key, int) and not isinstance(key, bool):
        return obj[key] if -len(obj) <= key < len(obj) else None
    return None


# ------------------------------------------------------------------ parser
class _Parser:
    def __init__(self, src: str) -> None:
        self.src = src
        self.toks = _tokenize(src)
        self.i = 0
        self.depth = 0
        # the comparison being parsed: its operator's token index, the bare name on its left
        self.left: tuple[int, str | None] = (-1, None)
        # what each closure made here is, for evaluating the filter over columns (filter_plan.py)
        self.plans = Plans()

    def peek(self) -> Token:
        return self.toks[self.i]

    def take(self) -> Token:
        tok = self.toks[self.i]
        self.i += 1
        return tok

    def error(self, what: str, tok: Token | None = None, hint: str = "") -> FilterError:
        tok = tok or self.peek()
        if tok[0] == "end":
            got = "end of filter"
        else:
            got = repr(_clip(f'"{tok[1]}"' if tok[0] == "str" else str(tok[1])))
        return FilterError(f"{what}, got {got}{hint}", tok[2], self.src)

    def expect(self, kind: str, value: Any) -> None:
        tok = self.take()
        if tok[0] != kind or tok[1] != value:
            raise self.error(f"expected {value!r}", tok, self.stray_hint(self.i - 1))

    def end_of(self, at: int) -> int:
        """Where token ``at`` ends in the source (0-based): a string's quotes and
        escapes are not in its value."""
        tok = self.toks[at]
        if tok[0] == "end":
            return len(self.src)
        m = _TOKEN.match(self.src, tok[2] - 1)
        return m.end() if m else tok[2]

    def stray_hint(self, at: int) -> str:
        """The fix for token ``at`` where an operator, 'and', 'or' or ')' belongs:
        Wireshark's ``eq``, a keyword in capitals, a left-out ``==``."""
        kind, val, col = self.toks[at]
        fix = None
        if kind == "name":
            fix = operator_fix(val, col - 1)
        elif kind in ("str", "num") and at and self.toks[at - 1][0] == "name":
            fix = Fix(col - 1, col - 1, "== ")     # status "nak"
        return fix.clause(self.src) if fix else ""

    def enter(self, tok: Token) -> None:
        """One level deeper (parenthesis, 'not', list): bounded, so the parser's
        recursion and the closures' depth stay far from Python's stack limit."""
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise FilterError(f"nested more than {MAX_NESTING} levels deep "
                              f"(parentheses, 'not' and lists together)", tok[2], self.src)

    def leave(self, levels: int = 1) -> None:
        self.depth -= levels

    # expr := or
    def parse(self) -> Getter:
        if self.peek()[0] == "end":
            raise self.error("empty filter: expected an expression")
        fn = self.parse_or()
        if self.peek()[0] != "end":
            raise self.error("expected 'and', 'or' or the end of the filter", hint=self.stray_hint(self.i))
        return fn

    def _chain(self, word: str, operand: Callable[[], Getter],
               combine: Callable[[tuple[Getter, ...]], Getter]) -> Getter:
        """operand (word operand)*: a single operand as it is, more as one closure."""
        operands = [operand()]
        while self.peek()[:2] == ("kw", word):
            self.take()
            operands.append(operand())
        if len(operands) == 1:
            return operands[0]
        plans = tuple(self.plans.test(f) for f in operands)
        return self.plans.made(combine(tuple(operands)), AnyOf(plans) if word == "or" else AllOf(plans))

    def parse_or(self) -> Getter:
        return self._chain("or", self.parse_and, _any_of)

    def parse_and(self) -> Getter:
        return self._chain("and", self.parse_not, _all_of)

    def _at_not(self) -> bool:
        return self.peek()[:2] == ("kw", "not") and self.toks[self.i + 1][:2] != ("kw", "in")

    def parse_not(self) -> Getter:
        """'not'* comparison, in a loop: an odd count negates, an even one tests truth."""
        count = 0
        while self._at_not():
            self.enter(self.take())
            count += 1
        inner = self.parse_cmp()
        self.leave(count)
        if count == 0:
            return inner
        test = self.plans.test(inner)
        if count % 2:
            return self.plans.made(lambda ev: not inner(ev), Not(test))
        return self.plans.made(lambda ev: bool(inner(ev)), test)

    def parse_cmp(self) -> Getter:
        left_at = self.i
        left = self.parse_value()
        tok = self.peek()
        negate = False
        if tok[:2] == ("kw", "not") and self.toks[self.i + 1][:2] == ("kw", "in"):
            self.take()
            negate = True
            tok = self.peek()
        if (tok[0] == "op" and tok[1] in COMPARISONS) or tok[:2] == ("kw", "in"):
            op_at = self.i
            self.take()
            name = self.bare_name(left_at, op_at)
            self.left = (op_at, name)
            right = self.parse_value()
            if self.i == op_at + 2:    # the right side is one token: a literal or a name
                self.check_value(name, tok[1], op_at + 1)
            test = _comparison(tok[1], left, right, negate)
            return self.plans.made(test, self.plans.comparison(test, tok[1], left, right, negate))
        if negate:
            raise self.error("expected a value after 'not in'")
        return left

    def bare_name(self, start: int, stop: int) -> str | None:
        """The name that tokens start..stop-1 are (alone or after ``gimbal.``), else None."""
        if not 1 <= stop - start <= 3:
            return None
        toks = self.toks[start:stop]
        if len(toks) == 3 and toks[0][:2] == ("name", PROTOCOL) and toks[1][:2] == ("op", "."):
            toks = toks[2:]
        return toks[0][1] if len(toks) == 1 and toks[0][0] == "name" else None

    def check_value(self, name: str | None, op: str, at: int) -> None:
        """Catch comparisons that would silently match nothing: a misspelt value
        (``status == "nack"``), Wireshark's text address (``dst == "1.1.2"``)."""
        kind, value, col = self.toks[at]
        if kind != "str" or op not in ("==", "!="):
            return
        start, end = col - 1, self.end_of(at)
        if name in ENUMS and value not in ENUMS[name]:
            allowed = ", ".join(sorted(ENUMS[name]))
            meant = value_fix(value, ENUMS[name])
            quote = self.src[start]
            hint = Fix(start, end, f"{quote}{meant}{quote}").clause(self.src) if meant else ""
            raise FilterError(f"{name} is never {_clip(value)!r} (it is one of: {allowed}){hint}", col, self.src)
        if name == "dst":
            fix = dst_text_fix(value, start, end)
            raise FilterError(f"dst is a list of numbers (group, port, device), never text"
                              f"{fix.clause(self.src) if fix else ''}", col, self.src)

    def parse_value(self) -> Getter:
        tok = self.take()
        kind, val, col = tok
        if kind in ("num", "str"):
            return self.constant(val)
        if kind == "kw" and val in ("true", "false", "null"):
            return self.constant({"true": True, "false": False, "null": None}[val])
        if kind == "op" and val == "(":
            self.enter(tok)
            inner = self.parse_or()
            self.expect("op", ")")
            self.leave()
            return inner
        if kind == "op" and val == "[":
            self.enter(tok)
            items = self.parse_items()
            self.leave()
            return self.list_value(items)
        if kind == "name":
            return self.parse_path(val, col, self.i - 1)
        raise self.error("expected a value (a name, number, string, list or '(')", tok)

    def parse_items(self) -> list[Getter]:
        items: list[Getter] = []
        if self.peek()[:2] != ("op", "]"):
            while True:
                items.append(self.parse_value())
                if self.peek()[:2] != ("op", ","):
                    break
                self.take()
        self.expect("op", "]")
        return items

    def constant(self, value: Any) -> _Const:
        return self.plans.made(_Const(value), Value(value))

    def list_value(self, items: list[Getter]) -> Getter:
        """A list of constants is a constant, built here once (not per event)."""
        values = [f.value for f in items if isinstance(f, _Const)]
        if len(values) == len(items):
            return self.constant(values)
        its = tuple(items)
        return lambda ev: [f(ev) for f in its]

    def parse_path(self, name: str, col: int, at: int) -> Getter:
        """``name``, ``name.key``, ``name[2]``…; ``at`` is the index of the name's token."""
        base_col = col
        if name == PROTOCOL and self.peek()[:2] == ("op", ".") and self.toks[self.i + 1][0] == "name":
            self.take()                   # Wireshark's prefix: gimbal.status is status
            at = self.i
            name, col = self.take()[1:]
        base = self.plans.made(self.name_getter(name, col, at), Name(name))
        keys: list[str | int] = []
        while True:
            tok = self.peek()
            if tok[:2] == ("op", "."):
                self.take()
                key = self.take()
                if key[0] != "name":
                    raise self.error("expected a field name after '.'", key)
                if not keys:
                    self.check_key(name, base_col, tok, key)
                keys.append(key[1])
            elif tok[:2] == ("op", "["):
                self.take()
                idx = self.take()
                if idx[0] != "num" or not isinstance(idx[1], int):
                    raise self.error("expected a whole number index", idx)
                self.expect("op", "]")
                keys.append(idx[1])
            else:
                if not keys:
                    return base
                return self.plans.made(_path(base, tuple(keys)), Name(name, tuple(keys)))

    def check_key(self, base: str, base_col: int, dot: tuple, key: tuple) -> None:
        """A key no event has under ``base`` (always null) is a mistake: Wireshark's
        ``gimbal.dst.device``, a misspelt field after ``fields.``."""
        _, word, col = key
        end = col - 1 + len(word)
        if base == "dst":
            part = DST_PARTS.get(word.lower())
            hint = (Fix(dot[2] - 1, end, f"[{part}]").clause(self.src) if part is not None
                    else "; write dst[0], dst[1] or dst[2]")
            raise FilterError(f"dst is a list (group, port, device): it has no {word!r}{hint}", col, self.src)
        if base == "fields" and word not in FIELD_NAMES:
            if word in TOP_LEVEL:     # fields.latency: an event key, not a decoded field
                hint = Fix(base_col - 1, end, word).clause(self.src)
            else:
                hint = VOCABULARY.name_hint(self.src, word, col - 1)
            raise FilterError(f"no decoded field is named {word!r}{hint}", col, self.src)

    def unknown_hint(self, name: str, col: int, at: int) -> str:
        """The fix for an unknown name: quoted, where a value belongs (``status ==
        nak``, a list's element); else, as after ``in`` (a list or text follows it,
        most often a name: ``"x" in problem``), the name it was likely meant to be."""
        prev = self.toks[at - 1] if at else ("end", None, 0)
        if prev[:2] in (("op", "["), ("op", ",")) or (prev[0] == "op" and prev[1] in COMPARISONS):
            allowed = ENUMS.get(self.left[1] or "") if self.left[0] == at - 1 else None
            return VOCABULARY.text_hint(self.src, name, col - 1, allowed)
        return VOCABULARY.name_hint(self.src, name, col - 1)

    def name_getter(self, name: str, col: int, at: int) -> Getter:
        if name == "payload":
            from dissectors.wire import payload_text
            return lambda ev: payload_text(ev.payload) if ev.payload is not None else None
        if name == "raw":
            return lambda ev: ev.raw.hex()
        if name in TOP_LEVEL:
            return attrgetter(name)
        if name in FIELD_NAMES:
            return lambda ev: ev.fields.get(name)
        hint = self.unknown_hint(name, col, at)
        if hint:
            raise FilterError(f"unknown name {name!r}{hint}", col, self.src)
        raise FilterError(f"unknown name {name!r}: use an event key ({', '.join(TOP_LEVEL)}) "
                          f"or a field name (docs/json-lines.md)", col, self.src)


def compile_filter(src: str) -> Predicate:
    """Compile a filter expression; raises ``FilterError`` pointing at the bad token.
    The predicate's ``plan`` says what it tests, for evaluating it over columns
    (filter_plan.py); the predicate itself is the ground truth."""
    parser = _Parser(src)
    fn = parser.parse()
    # a plain function carrying its plan as an attribute: called once an event,
    # it costs half what an object's __call__ would; the Protocol names the attribute
    def pred(ev: Event) -> bool:
        return bool(fn(ev))

    compiled = cast(Predicate, pred)
    compiled.plan = parser.plans.test(fn)
    return compiled
