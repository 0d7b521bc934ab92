"""The filter language of ``decode --filter`` (and later the TUI's filter bar).

A small, safe expression language over the JSON Lines names; it is parsed into
closures, never ``eval``-ed::

    status == "nak" or problems
    command in ["P?", "P"] and latency > 0.05
    kind == "result" and azimuth_deg < -10
    dst[2] == 3 and not checksum_ok
    "bad checksum" in problems

Names are the event's JSON keys, or a decoded field's name (``azimuth_deg`` is
``fields.azimuth_deg``). ``x in list`` on a list of strings also matches an
element that starts with ``x:``, so a problem category matches its detailed
problems. Comparisons between mismatched types are false, never errors.
"""

from __future__ import annotations

import re
from typing import Any, Callable

from dissectors.commands import COMMANDS, DERIVED_FIELDS
from dissectors.event import Event

Predicate = Callable[[Event], bool]

TOP_LEVEL = ("number", "t", "t_end", "line", "offset", "kind", "command", "dst", "src", "payload",
             "checksum_ok", "fields", "problems", "txn", "status", "latency", "retransmission",
             "request", "raw")
ENUMS = {
    "kind": {"command", "result", "ack", "nak", "nic", "noise"},
    "status": {"ok", "nak", "nic", "no_ack", "no_result", "pending"},
    "line": {"A", "B", "AB"},
}


def _field_names() -> set[str]:
    names = set(DERIVED_FIELDS)
    for c in COMMANDS:
        for layout in (c.layout, *c.result):
            names.update(f.name for f in layout.fields)
    return names


FIELD_NAMES = _field_names()


class FilterError(ValueError):
    def __init__(self, message: str, column: int, source: str) -> None:
        self.column = column
        self.source = source
        super().__init__(f"column {column}: {message}")

    def pointer(self) -> str:
        """The expression with the bad spot marked, for one-line error messages."""
        c = self.column - 1
        return f"{self.source[:c]}>>>{self.source[c:]}"


_TOKEN = re.compile(r"""
    (?P<ws>\s+)
  | (?P<num>-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)
  | (?P<str>"(?:[^"\\]|\\.)*"|'(?:[^'\\]|\\.)*')
  | (?P<op>==|!=|<=|>=|<|>|\(|\)|\[|\]|,|\.)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
""", re.VERBOSE)
KEYWORDS = {"and", "or", "not", "in", "true", "false", "null"}


def _tokenize(src: str) -> list[tuple[str, Any, int]]:
    out = []
    pos = 0
    while pos < len(src):
        m = _TOKEN.match(src, pos)
        if m is None:
            raise FilterError(f"unexpected character {src[pos]!r}", pos + 1, src)
        kind = m.lastgroup
        text = m.group()
        if kind == "num":
            out.append(("num", float(text) if any(c in text for c in ".eE") else int(text), pos + 1))
        elif kind == "str":
            body = text[1:-1]
            out.append(("str", re.sub(r"\\(.)", r"\1", body), pos + 1))
        elif kind == "op":
            out.append(("op", text, pos + 1))
        elif kind == "name":
            out.append(("kw" if text in KEYWORDS else "name", text, pos + 1))
        pos = m.end()
    out.append(("end", None, len(src) + 1))
    return out


def _truthy(v: Any) -> bool:
    return bool(v)


def _contains(container: Any, item: Any) -> bool:
    if isinstance(container, str):
        return isinstance(item, str) and item in container
    if isinstance(container, (list, tuple)):
        if item in container:
            return True
        if isinstance(item, str):
            prefix = item + ":"
            return any(isinstance(x, str) and x.startswith(prefix) for x in container)
        return False
    if isinstance(container, dict):
        return item in container
    return False


def _compare(op: str) -> Callable[[Any, Any], bool]:
    def num(v: Any) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    def ordered(a: Any, b: Any) -> bool:
        return (num(a) and num(b)) or (isinstance(a, str) and isinstance(b, str))

    def eq(a: Any, b: Any) -> bool:
        if isinstance(a, tuple):
            a = list(a)
        if isinstance(b, tuple):
            b = list(b)
        return a == b

    return {
        "==": eq,
        "!=": lambda a, b: not eq(a, b),
        "<": lambda a, b: ordered(a, b) and a < b,
        ">": lambda a, b: ordered(a, b) and a > b,
        "<=": lambda a, b: ordered(a, b) and a <= b,
        ">=": lambda a, b: ordered(a, b) and a >= b,
        "in": lambda a, b: _contains(b, a),
    }[op]


class _Parser:
    def __init__(self, src: str) -> None:
        self.src = src
        self.toks = _tokenize(src)
        self.i = 0

    def peek(self) -> tuple[str, Any, int]:
        return self.toks[self.i]

    def take(self) -> tuple[str, Any, int]:
        tok = self.toks[self.i]
        self.i += 1
        return tok

    def error(self, what: str, tok: tuple[str, Any, int] | None = None) -> FilterError:
        tok = tok or self.peek()
        got = "end of filter" if tok[0] == "end" else repr(tok[1] if tok[0] != "str" else f'"{tok[1]}"')
        return FilterError(f"{what}, got {got}", tok[2], self.src)

    def expect(self, kind: str, value: Any) -> None:
        tok = self.take()
        if tok[0] != kind or tok[1] != value:
            raise self.error(f"expected {value!r}", tok)

    # expr := or
    def parse(self) -> Callable[[Event], Any]:
        if self.peek()[0] == "end":
            raise self.error("empty filter: expected an expression")
        fn = self.parse_or()
        if self.peek()[0] != "end":
            raise self.error("expected 'and', 'or' or the end of the filter")
        return fn

    def _chain(self, word: str, operand, combine):
        """operand (word operand)*, folded left with ``combine``."""
        left = operand()
        while self.peek()[:2] == ("kw", word):
            self.take()
            left = combine(left, operand())
        return left

    def parse_or(self):
        return self._chain("or", self.parse_and,
                           lambda l, r: lambda ev: _truthy(l(ev)) or _truthy(r(ev)))

    def parse_and(self):
        return self._chain("and", self.parse_not,
                           lambda l, r: lambda ev: _truthy(l(ev)) and _truthy(r(ev)))

    def parse_not(self):
        if self.peek()[:2] == ("kw", "not") and self.toks[self.i + 1][:2] != ("kw", "in"):
            self.take()
            inner = self.parse_not()
            return lambda ev: not _truthy(inner(ev))
        return self.parse_cmp()

    def parse_cmp(self):
        left_tok = self.peek()
        left = self.parse_value()
        tok = self.peek()
        negate = False
        if tok[:2] == ("kw", "not") and self.toks[self.i + 1][:2] == ("kw", "in"):
            self.take()
            negate = True
            tok = self.peek()
        if (tok[0] == "op" and tok[1] in ("==", "!=", "<", ">", "<=", ">=")) or tok[:2] == ("kw", "in"):
            self.take()
            right_tok = self.peek()
            right = self.parse_value()
            self._check_enum(left_tok, right_tok, tok[1])
            cmp = _compare(tok[1])
            if negate:
                return lambda ev: not cmp(left(ev), right(ev))
            return lambda ev: cmp(left(ev), right(ev))
        if negate:
            raise self.error("expected a value after 'not in'")
        return left

    def _check_enum(self, left_tok, right_tok, op) -> None:
        """Catch typos like status == "nack" that would silently match nothing."""
        if left_tok[0] != "name" or left_tok[1] not in ENUMS or op not in ("==", "!="):
            return
        if right_tok[0] == "str" and right_tok[1] not in ENUMS[left_tok[1]]:
            allowed = ", ".join(sorted(ENUMS[left_tok[1]]))
            raise FilterError(f"{left_tok[1]} is never {right_tok[1]!r} (it is one of: {allowed})",
                              right_tok[2], self.src)

    def parse_value(self):
        tok = self.take()
        kind, val, col = tok
        if kind in ("num", "str"):
            return lambda ev, v=val: v
        if kind == "kw" and val in ("true", "false", "null"):
            const = {"true": True, "false": False, "null": None}[val]
            return lambda ev, v=const: v
        if kind == "op" and val == "(":
            inner = self.parse_or()
            self.expect("op", ")")
            return inner
        if kind == "op" and val == "[":
            items = []
            if self.peek()[:2] != ("op", "]"):
                while True:
                    items.append(self.parse_value())
                    if self.peek()[:2] == ("op", ","):
                        self.take()
                        continue
                    break
            self.expect("op", "]")
            return lambda ev, its=tuple(items): [f(ev) for f in its]
        if kind == "name":
            return self.parse_path(val, col)
        raise self.error("expected a value (a name, number, string, list or '(')", tok)

    def parse_path(self, name: str, col: int):
        getter = self.name_getter(name, col)
        while True:
            tok = self.peek()
            if tok[:2] == ("op", "."):
                self.take()
                key = self.take()
                if key[0] != "name":
                    raise self.error("expected a field name after '.'", key)
                getter = (lambda g, k: lambda ev: _get(g(ev), k))(getter, key[1])
            elif tok[:2] == ("op", "["):
                self.take()
                idx = self.take()
                if idx[0] != "num" or not isinstance(idx[1], int):
                    raise self.error("expected a whole number index", idx)
                self.expect("op", "]")
                getter = (lambda g, k: lambda ev: _get(g(ev), k))(getter, idx[1])
            else:
                return getter

    def name_getter(self, name: str, col: int):
        if name == "payload":
            from dissectors.wire import payload_text
            return lambda ev: payload_text(ev.payload) if ev.payload is not None else None
        if name == "raw":
            return lambda ev: ev.raw.hex()
        if name == "dst":
            return lambda ev: list(ev.dst) if ev.dst is not None else None
        if name in TOP_LEVEL:
            return lambda ev, n=name: getattr(ev, n)
        if name in FIELD_NAMES:
            return lambda ev, n=name: ev.fields.get(n)
        raise FilterError(f"unknown name {name!r}: use an event key ({', '.join(TOP_LEVEL)}) "
                          f"or a field name (README, 'Event contract')", col, self.src)


def _get(obj: Any, key: Any) -> Any:
    try:
        if isinstance(obj, dict):
            return obj.get(key)
        if isinstance(obj, (list, tuple)) and isinstance(key, int):
            return obj[key] if -len(obj) <= key < len(obj) else None
    except TypeError:
        return None
    return None


def compile_filter(src: str) -> Predicate:
    """Compile a filter expression; raises ``FilterError`` pointing at the bad token."""
    fn = _Parser(src).parse()
    return lambda ev: _truthy(fn(ev))
