"""Field descriptors for the command table: how a run of payload characters is
matched, decoded, named and checked (spec §1.4.1.2: numbers are upper-case ASCII
hex unless a table says otherwise).

A ``Field`` is one named value; a layout is a tuple of literal ``bytes`` and
``Field`` objects, compiled into one regular expression. Each field name is the
one used in JSON Lines, filters, statistics, MCAP recordings and the TUI.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Any

from .problems import LOWERCASE_HEX, OUT_OF_RANGE, Problem

# A layout's derived fields: filled into the decoded values, with any problems they show.
Derive = Callable[[dict[str, Any]], list[Problem] | None]

HEX = rb"[0-9A-Fa-f]"
# one shared value: problems are immutable, and lower-case payloads repeat
_LOWERCASE = LOWERCASE_HEX.problem("numbers must be upper-case ASCII hex (§1.4.1.2)")


@dataclass(frozen=True)
class Field:
    name: str
    regex: bytes
    decode: Callable[[bytes], Any]
    unit: str = ""
    desc: str = ""
    hexdigits: bool = False   # lower-case letters earn a warning
    valid: tuple[float, float] | None = None  # warn when the decoded value is outside
    lead: bytes = rb"[\s\S]"  # what the field's first character can be
    # the decoded value's JSON type ("integer", "number", "string", "boolean"):
    # MCAP schemas type every field with it (analyzer/formats/mcap_schemas.py)
    type: str = "string"
    # how ``decode`` reads the characters, said as data for decoders written in
    # other languages (the Wireshark dissector, analyzer/wireshark/lua.py):
    # "hex" (``divisor``, ``signed``: 16-bit two's complement), "decimal",
    # "text" (``strip``) or "choice" (``choices``: character -> value)
    codec: str = "text"
    divisor: int | None = None
    signed: bool = False
    strip: bool = False
    choices: tuple = ()

    def check(self, value: Any) -> Problem | None:
        if self.valid is not None and isinstance(value, (int, float)):
            lo, hi = self.valid
            if not lo <= value <= hi:
                return OUT_OF_RANGE.problem(f"{self.name} {value} outside {lo}..{hi}")
        return None


def _s16(raw: bytes) -> int:
    v = int(raw, 16)
    return v - 0x10000 if v & 0x8000 else v


def hexnum(name: str, digits: int | tuple[int, int], *, scale: float | None = None,
           signed: bool = False, unit: str = "", desc: str = "",
           valid: tuple[float, float] | None = None) -> Field:
    """An ASCII-hex number of ``digits`` characters (or a (min, max) range)."""
    rx = HEX + (b"{%d}" % digits if isinstance(digits, int) else b"{%d,%d}" % digits)
    if signed:
        base = _s16
    else:
        def base(raw: bytes) -> int:
            return int(raw, 16)
    dec: Callable[[bytes], float]
    if scale is None:
        dec = base
    else:
        # dividing by 10 or 100 is correctly rounded (1025 / 100 is the float
        # nearest 10.25); multiplying by 0.01 is not (3 * 0.1 = 0.30000000000000004)
        divisor = round(1 / scale)

        def dec(raw: bytes, _b: Callable[[bytes], int] = base, _d: int = divisor) -> float:
            return _b(raw) / _d
    return Field(name, rx, dec, unit, desc, hexdigits=True, valid=valid, lead=HEX,
                 type="integer" if scale is None else "number", codec="hex",
                 divisor=None if scale is None else round(1 / scale), signed=signed)


def decimal(name: str, max_digits: int = 6, *, unit: str = "", desc: str = "",
            valid: tuple[float, float] | None = None) -> Field:
    return Field(name, rb"[0-9]{1,%d}" % max_digits, int, unit, desc, valid=valid, lead=rb"[0-9]",
                 type="integer", codec="decimal")


def text(name: str, width: int | None = None, *, strip: bool = False, desc: str = "",
         min_width: int = 0) -> Field:
    """Characters kept as text: ``width`` exactly, or the rest of the payload."""
    rx = rb"[\s\S]{%d}" % width if width is not None else rb"[\s\S]{%d,}" % min_width
    if strip:
        def dec(raw: bytes) -> str:
            return raw.decode("latin-1").strip()
    else:
        def dec(raw: bytes) -> str:
            return raw.decode("latin-1")
    return Field(name, rx, dec, "", desc, strip=strip)


def choice(name: str, mapping: dict[bytes, Any], *, desc: str = "", regex: bytes = rb".") -> Field:
    """One character mapped to a value. A character outside the map decodes to
    None (no value of the field's type stands for it) and is out of range; the
    payload still shows it."""
    def dec(raw: bytes) -> Any:
        return mapping.get(raw)
    types = {_json_type(v) for v in mapping.values()}
    if len(types) != 1:
        raise ValueError(f"choice {name!r}: values of one JSON type, not {sorted(types)}")
    f = Field(name, regex, dec, "", desc, type=types.pop(), codec="choice", choices=tuple(mapping.items()))
    allowed = ", ".join(f"{k.decode('latin-1')} ({v})" for k, v in mapping.items())

    def check(value: Any) -> Problem | None:
        if value is None:
            return OUT_OF_RANGE.problem(f"{name} is none of {allowed}")
        return None
    object.__setattr__(f, "check", check)
    return f


def _json_type(value: Any) -> str:
    """The JSON Schema type of a Python value a field decodes to."""
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    return "string"


@dataclass(frozen=True)
class Layout:
    """A payload layout: literals and fields in order, plus derived fields."""
    parts: tuple
    derive: Derive | None = None
    regex: re.Pattern = dc_field(init=False, repr=False, compare=False)
    fields: tuple[Field, ...] = dc_field(init=False, repr=False, compare=False)
    _checked: tuple = dc_field(init=False, repr=False, compare=False)
    _hex_groups: tuple = dc_field(init=False, repr=False, compare=False)
    _whole_payload_case: bool = dc_field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        rx = b""
        fields = []
        for part in self.parts:
            if isinstance(part, bytes):
                rx += re.escape(part)
            else:
                rx += b"(" + part.regex + b")"
                fields.append(part)
        object.__setattr__(self, "regex", re.compile(rx, re.DOTALL))
        object.__setattr__(self, "fields", tuple(fields))
        # only fields that can complain are checked on the hot path
        object.__setattr__(self, "_checked", tuple(
            f for f in fields if f.valid is not None or "check" in f.__dict__))
        object.__setattr__(self, "_hex_groups", tuple(k for k, f in enumerate(fields) if f.hexdigits))
        # all-hex layouts with upper-case literals: one test of the whole payload
        # tells whether any hex digit is lower case
        literals = b"".join(p for p in self.parts if isinstance(p, bytes))
        object.__setattr__(self, "_whole_payload_case", bool(fields) and all(f.hexdigits for f in fields)
                           and literals == literals.upper())

    @property
    def prefix(self) -> bytes:
        """The literal characters the layout starts with."""
        return self.parts[0] if self.parts and isinstance(self.parts[0], bytes) else b""

    @property
    def width(self) -> int | None:
        """Characters a matching payload has, when fixed."""
        total = 0
        for part in self.parts:
            if isinstance(part, bytes):
                total += len(part)
                continue
            m = re.fullmatch(rb".*\{(\d+)\}", part.regex)
            if m is None:
                return None
            total += int(m.group(1))
        return total

    def lead_ok(self, rest: bytes) -> bool:
        """Does ``rest`` (the payload after the leading literal) start like this layout's first field?"""
        for part in self.parts[1:] if self.prefix else self.parts:
            if isinstance(part, bytes):
                return rest.startswith(part[:1])
            return bool(rest) and re.match(part.lead, rest[:1]) is not None
        return False

    def describe(self) -> str:
        out = []
        for part in self.parts:
            if isinstance(part, bytes):
                out.append(part.decode("latin-1"))
            else:
                out.append("<" + part.name + ">")
        return "".join(out)

    def match(self, payload: bytes) -> tuple[dict, list[Problem]] | None:
        """Decode ``payload`` if it fits: (fields, problems), or None."""
        m = self.regex.fullmatch(payload)
        if m is None:
            return None
        groups = m.groups()
        values = {f.name: f.decode(raw) for f, raw in zip(self.fields, groups)}
        problems: list[Problem] = []
        for f in self._checked:
            problem = f.check(values[f.name])
            if problem:
                problems.append(problem)
        if self._whole_payload_case:
            lower = payload != payload.upper()
        else:
            hexes = self._hex_groups
            lower = bool(hexes) and any(groups[k] != groups[k].upper() for k in hexes)
        if lower:
            problems.append(_LOWERCASE)
        if self.derive is not None:
            extra = self.derive(values)
            if extra:
                problems.extend(extra)
        return values, problems

    def spans(self, payload: bytes) -> list[tuple[str, int, int]]:
        """(field name, start, end) character ranges of each field in ``payload``
        (for highlighting); empty when the payload does not fit."""
        m = self.regex.fullmatch(payload)
        if m is None:
            return []
        return [(f.name, m.start(k), m.end(k)) for k, f in enumerate(self.fields, 1)]
