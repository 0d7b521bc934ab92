"""Dissection: payload bytes to command ids, named fields and problems, driven by
the command table in ``dissectors.commands`` (Tables 4-18, docs/decoding.md).

Commands are dissected on their own; a result is dissected against the command
it answers, because its layout depends on that command (Table 15, Table 8 …).
Payloads repeat a lot on a real bus (polling), so decodes are memoised.
"""

from __future__ import annotations

import re
from typing import Any, NamedTuple

from .commands import COMMANDS, NONE, Command
from .event import COMMAND, Event
from .fields import Layout
from .problems import MALFORMED, RESERVED, UNKNOWN_COMMAND, Problem
from .wire import payload_text


class Decoded(NamedTuple):
    entry: Command | None
    command: str
    fields: dict[str, Any]
    problems: tuple[Problem, ...]


def _build_index() -> dict[int, list[Command]]:
    index: dict[int, list[Command]] = {}
    for c in COMMANDS:
        first = c.layout.parts[0]
        assert isinstance(first, bytes) and first, c.id
        index.setdefault(first[0], []).append(c)
    return index


_INDEX = _build_index()
_CACHE: dict[bytes, Decoded] = {}
# results by command id, then by payload (a result's layout depends on its command)
_RESULT_CACHE: dict[str, dict[bytes, tuple[dict[str, Any], tuple[Problem, ...]]]] = {}
_result_count = 0   # entries in all of them
_CACHE_MAX = 8192   # per cache (all results together); polls repeat, positions vary: bounded memory
_UNKNOWN_CODE = re.compile(rb"\*[A-Za-z]{1,3}|[\s\S]{1,2}")


def _code_of(payload: bytes) -> str:
    m = _UNKNOWN_CODE.match(payload)
    return payload_text(m.group(0)) if m else ""


def dissect_command(payload: bytes) -> Decoded:
    """Decode a command payload (never raises)."""
    hit = _CACHE.get(payload)
    if hit is not None:
        return hit
    result = _dissect_command(payload)
    if len(_CACHE) >= _CACHE_MAX:
        _CACHE.clear()
    _CACHE[payload] = result
    return result


def _dissect_command(payload: bytes) -> Decoded:
    candidates = _INDEX.get(payload[0], ()) if payload else ()
    for c in candidates:
        m = c.layout.match(payload)
        if m is not None:
            values, problems = m
            if c.reserved:
                problems.insert(0, RESERVED.problem(f"{c.id} is marked reserved ({c.ref})"))
            return Decoded(c, c.command_id(values), values, tuple(problems))
    # A known code whose parameters do not fit: malformed, not unknown.
    best: Command | None = None
    for c in candidates:
        lit = c.layout.prefix
        if not payload.startswith(lit):
            continue
        if len(lit) < 2 and not c.layout.lead_ok(payload[len(lit):]):
            continue
        if best is None or len(lit) > len(best.layout.prefix) or (
                len(lit) == len(best.layout.prefix) and _closer(c.layout, best.layout, len(payload))):
            best = c
    if best is not None:
        cid = best.id if "{" not in best.id else best.id.replace("{aux_port}", payload[2:3].decode("latin-1"))
        return Decoded(best, cid, {}, (MALFORMED.problem(f"expected {best.layout.describe()} ({best.ref})"),))
    code = _code_of(payload)
    return Decoded(None, code, {}, (UNKNOWN_COMMAND.problem(f"'{code}' is not in protocol rev 1.9"),))


def _closer(a: Layout, b: Layout, n: int) -> bool:
    wa, wb = a.width, b.width
    da = abs(wa - n) if wa is not None else 1000
    db = abs(wb - n) if wb is not None else 1000
    return da < db


def dissect_result(entry: Command | None, payload: bytes) -> tuple[dict[str, Any], tuple[Problem, ...]]:
    """Decode a result payload as an answer to ``entry`` (never raises)."""
    if entry is None:
        return {}, ()
    # a memo per command: no key tuple to build and hash on every lookup
    memo = _RESULT_CACHE.get(entry.id)
    if memo is None:
        memo = _RESULT_CACHE[entry.id] = {}
    hit = memo.get(payload)
    if hit is not None:
        return hit
    out: tuple[dict[str, Any], tuple[Problem, ...]] | None = None
    for layout in entry.result:
        m = layout.match(payload)
        if m is not None:
            out = (m[0], tuple(m[1]))
            break
    if out is None:
        if not entry.result or entry.result_due == NONE:
            why = MALFORMED.problem(f"{entry.id} has no result ({entry.ref})")
        else:
            expected = " or ".join(l.describe() for l in entry.result)
            why = MALFORMED.problem(f"expected {expected} ({entry.ref})")
        out = ({}, (why,))
    global _result_count
    _result_count += 1
    if _result_count > _CACHE_MAX:   # all memos together stay bounded
        for results in _RESULT_CACHE.values():
            results.clear()
        _result_count = 1
    memo[payload] = out
    return out


def field_spans(ev: Event) -> list[tuple[str, int, int]]:
    """Byte ranges of an event's decoded fields, as absolute offsets into ``ev.raw``
    (for highlighting the selected field's bytes)."""
    entry = ev.entry
    if entry is None or ev.payload is None:
        return []
    layouts = (entry.layout,) if ev.kind == COMMAND else entry.result
    for layout in layouts:
        spans = layout.spans(ev.payload)
        if spans:
            return [(name, 6 + a, 6 + b) for name, a, b in spans]
    return []


def result_fits(entry: Command | None, payload: bytes | None) -> bool:
    """Does ``payload`` have one of the result layouts of ``entry``? (Decodes it
    through the memo, so decoding it afterwards costs nothing.) An event without
    a payload (not a frame) fits none."""
    if entry is None or not entry.result or payload is None:
        return False
    return bool(dissect_result(entry, payload)[0])


def summary_value(value: Any) -> Any:
    """A field's value as a summary shows it: a list (the names of the bits set)
    as its items, or "none"; any other value as it is, for the template to format."""
    if isinstance(value, list):
        return ", ".join(map(str, value)) if value else "none"
    return value


def summarize(template: str, fields: dict[str, Any]) -> str:
    """Fill a table summary template; falls back to name=value pairs."""
    if not template or "{_values}" in template:
        return " ".join(f"{k}={summary_value(v)}" for k, v in fields.items())
    if any(isinstance(v, list) for v in fields.values()):
        fields = {k: summary_value(v) for k, v in fields.items()}
    try:
        return template.format_map(fields)
    except (KeyError, ValueError, TypeError, IndexError):
        return " ".join(f"{k}={v}" for k, v in fields.items())


def apply_command(ev: Event) -> None:
    """Fill a command event's id, fields, problems and table entry."""
    payload = ev.payload
    assert payload is not None   # a command is a frame
    decoded = _CACHE.get(payload)   # dissect_command's memo, looked up here: once per command
    if decoded is None:
        decoded = dissect_command(payload)
    ev.entry, ev.command, ev.fields, problems = decoded
    if problems:
        ev.note(*problems)
