"""Commands encoded from the command table: a command's code and its fields' values
(named as everywhere else, in their units: ``azimuth_deg=10``) become the payload
the table's layout describes, the inverse of ``dissect_command``.

Values are given by people, not read from the wire, so a mistake raises
``EncodeError``, which says what was wrong and carries what would have been
right (the valid codes or field names) for the caller's "did you mean".
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .commands import COMMANDS, Command
from .dissect import dissect_command
from .fields import Field
from .wire import build_frame

_DIGITS = re.compile(rb"\{(\d+)(?:,(\d+))?\}\Z")


class EncodeError(ValueError):
    """A command or a value that cannot be sent as given. ``valid`` lists what
    would have been accepted where a name was wrong (codes, field names)."""

    def __init__(self, message: str, *, given: str = "", valid: tuple[str, ...] = (), kind: str = "") -> None:
        super().__init__(message)
        self.given = given
        self.valid = valid
        self.kind = kind    # what ``given`` names: "command" or "field"


@dataclass(frozen=True)
class Request:
    """One command ready to send: the table's entry, its values and its payload."""
    command: Command
    values: dict[str, Any] = field(default_factory=dict)
    payload: bytes = b""

    def frame(self, dst: tuple[int, int, int], src: int = 0) -> bytes:
        """The whole frame to ``dst`` from source group ``src`` (the controller's, 0)."""
        return build_frame(dst, src, self.payload)


def codes() -> tuple[str, ...]:
    """Every code a command can be asked for by (the table's ids, as docs/fields.md lists them)."""
    return tuple(c.id for c in COMMANDS)


def find_command(code: str) -> tuple[Command, dict[str, Any]]:
    """The table's command for ``code``: its id (``P``, ``Pnn``, ``*x{aux_port}c``)
    or, for ids with a value in them, the code as sent (``*x0c``, with that value)."""
    for c in COMMANDS:
        if c.id == code:
            return c, {}
    for c in COMMANDS:
        if "{" in c.id:
            pattern = re.escape(c.id).replace(r"\{aux_port\}", "(?P<aux_port>[01])")
            m = re.fullmatch(pattern, code)
            if m:
                return c, {"aux_port": int(m.group("aux_port"))}
    raise EncodeError(f"unknown command {code!r}", given=code, valid=codes(), kind="command")


def encode(code: str, values: Mapping[str, Any]) -> Request:
    """The request for ``code`` with ``values`` (each field of its layout, by name)."""
    command, implied = find_command(code)
    given = {**implied, **values}
    names = [f.name for f in command.layout.fields]
    extra = [name for name in given if name not in names]
    if extra:
        raise EncodeError(f"{command.id} ({command.name}) has no field {extra[0]!r}; its fields: "
                          f"{', '.join(names) or 'none'}", given=extra[0], valid=tuple(names), kind="field")
    missing = [name for name in names if name not in given]
    if missing:
        wanted = ", ".join(f"{f.name}{f' [{f.unit}]' if f.unit else ''}" for f in command.layout.fields
                           if f.name in missing)
        raise EncodeError(f"{command.id} ({command.name}) needs {wanted}", given=missing[0], valid=tuple(names))
    payload = b"".join(part if isinstance(part, bytes) else encode_field(part, given[part.name])
                       for part in command.layout.parts)
    _check_round_trip(command, given, payload)
    return Request(command, {name: given[name] for name in names}, payload)


def encode_field(f: Field, value: Any) -> bytes:
    """``value`` as ``f``'s characters (``f.codec`` says how they are read)."""
    if f.codec == "hex":
        return _hex(f, value)
    if f.codec == "decimal":
        number = _integer(f, value)
        if number < 0:
            raise EncodeError(f"{f.name} {value}: a decimal field is 0 or more")
        text = str(number)
        if not re.fullmatch(f.regex, text.encode()):
            raise EncodeError(f"{f.name} {value}: too many digits")
        _check_valid(f, number)
        return text.encode()
    if f.codec == "choice":
        for char, meaning in f.choices:
            if value == meaning or str(value) == str(meaning) or str(value) == char.decode("latin-1"):
                return bytes(char)
        allowed = ", ".join(str(meaning) for _char, meaning in f.choices)
        raise EncodeError(f"{f.name} {value!r}: one of {allowed}")
    raw = str(value).encode("latin-1", errors="strict") if _latin1(value) else b""
    if not _latin1(value) or not re.fullmatch(f.regex, raw, re.DOTALL):
        raise EncodeError(f"{f.name} {value!r}: {_width_text(f)}")
    return raw


def _latin1(value: Any) -> bool:
    try:
        str(value).encode("latin-1")
    except UnicodeEncodeError:
        return False
    return True


def _width_text(f: Field) -> str:
    m = _DIGITS.search(f.regex)
    if m is None:
        return "characters this field cannot hold"
    lo, hi = m.group(1).decode(), (m.group(2) or m.group(1)).decode()
    return f"{lo} characters" if lo == hi else f"{lo} to {hi} characters"


def _hex(f: Field, value: Any) -> bytes:
    m = _DIGITS.search(f.regex)
    if m is None:   # a one-character hex field with a regex of its own (ZA-ZF)
        digit = f"{_integer(f, value):X}".encode()
        if not re.fullmatch(f.regex, digit):
            raise EncodeError(f"{f.name} {value}: must be one of {f.regex.decode()}")
        return digit
    lo, hi = int(m.group(1)), int(m.group(2) or m.group(1))
    if f.divisor is not None:
        scaled = _number(f, value)
        _check_valid(f, scaled)
        raw = round(scaled * f.divisor)
    else:
        raw = _integer(f, value)
        _check_valid(f, raw)
    if f.signed:
        if not -0x8000 <= raw <= 0x7FFF:
            scale = f.divisor or 1
            raise EncodeError(f"{f.name} {value}: a signed 16-bit value, {-0x8000 / scale:g} to {0x7FFF / scale:g}")
        raw &= 0xFFFF
    elif raw < 0:
        raise EncodeError(f"{f.name} {value}: not below 0")
    text = f"{raw:0{lo}X}"
    if len(text) > hi:
        top = (16 ** hi - 1) / (f.divisor or 1)
        raise EncodeError(f"{f.name} {value}: at most {top:g} ({hi} hex digits)")
    return text.encode()


def _number(f: Field, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise EncodeError(f"{f.name} {value!r}: a number{f' in {f.unit}' if f.unit else ''}") from None
    if not math.isfinite(number):
        raise EncodeError(f"{f.name} {value!r}: a finite number")
    return number


def _integer(f: Field, value: Any) -> int:
    if isinstance(value, bool):
        raise EncodeError(f"{f.name} {value!r}: a whole number")
    if isinstance(value, int):
        return value
    text = str(value).strip()
    try:
        return int(text, 0) if text.lower().startswith("0x") else int(text)
    except ValueError:
        raise EncodeError(f"{f.name} {value!r}: a whole number (or 0x… hex)") from None


def _check_valid(f: Field, value: float) -> None:
    if f.valid is not None and not f.valid[0] <= value <= f.valid[1]:
        raise EncodeError(f"{f.name} {value:g}: outside {f.valid[0]:g}..{f.valid[1]:g}")


def _check_round_trip(command: Command, given: dict[str, Any], payload: bytes) -> None:
    """The payload decodes back to the command asked for: values two layouts could
    both read (``P`` with 2 digits is ``Pnn``) are refused rather than sent as another."""
    decoded = dissect_command(payload)
    if decoded.entry is not command:
        other = decoded.entry.id if decoded.entry else "no command"
        raise EncodeError(f"{command.id} with these values would be read as {other} ({payload.decode('latin-1')!r})")
