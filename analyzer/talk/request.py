"""What a person asks to send, as a frame: ``send``'s command line and the TUI's
talk prompt (``:`` in ``live --talk``) both say it the same way,

    COMMAND [FIELD=VALUE …] --to G.P.D [--allow-motion] [--allow-config]
    --raw HEX [--allow-motion] [--allow-config]

and both get the same frame, or the same one-line refusal (``TalkError``), from
here: the command encoded from the table, the safety rules applied
(analyzer/talk/safety.py), a mistyped name answered with the hint a filter's
mistake gets.
"""

from __future__ import annotations

import difflib
import shlex
from dataclasses import dataclass, field

from dissectors import Deframer
from dissectors.commands import field_types
from dissectors.encode import EncodeError, encode
from dissectors.event import parse_address

from ..analysis.filter_hints import Vocabulary, choices
from ..lines import LINE_A
from .safety import ASK_ONLY, Allowed, refusal

USAGE = "COMMAND [FIELD=VALUE …] --to G.P.D [--allow-motion] [--allow-config], or --raw HEX"


class TalkError(ValueError):
    """What was asked cannot be sent as it is: one line saying why."""


@dataclass
class Asked:
    """A request as given: a command and its fields, or raw bytes."""
    command: str | None = None
    values: dict[str, str] = field(default_factory=dict)
    to: tuple[int, int, int] | None = None
    raw: str | None = None
    allowed: Allowed = ASK_ONLY


def frame_for(asked: Asked) -> bytes:
    """The frame ``asked`` says, or a ``TalkError`` when it may not or cannot be sent."""
    if asked.raw is not None:
        if asked.command is not None or asked.values or asked.to is not None:
            raise TalkError("--raw sends the bytes as given: no COMMAND, fields or --to with it")
        data = raw_bytes(asked.raw)
        why = refusal(frame_payload(data), asked.allowed)
        if why:
            raise TalkError(f"--raw: {why}")
        return data
    if asked.command is None:
        raise TalkError("give a COMMAND (a code of the command table) or --raw HEX")
    if asked.to is None:
        raise TalkError("--to G.P.D: the address of the gimbal to send to")
    try:
        request = encode(asked.command, asked.values)
    except EncodeError as e:
        raise TalkError(f"{e}{did_you_mean(e)}") from None
    why = refusal(request.payload, asked.allowed)
    if why:
        raise TalkError(why)
    return request.frame(asked.to)


def frame_payload(data: bytes) -> bytes | None:
    """The payload of the one frame ``data`` is, as the deframer reads it (a bad
    checksum included, a length byte of 0 meaning 256), or None when ``data`` is
    anything else (several frames, noise, a simple response)."""
    deframer = Deframer(LINE_A)
    events = deframer.feed(data) + deframer.finish()
    if len(events) != 1:
        return None
    return events[0].payload


def field_values(pairs: list[str]) -> dict[str, str]:
    """``FIELD=VALUE`` words as a dict."""
    values: dict[str, str] = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or not name:
            raise TalkError(f"{pair!r}: fields are given as FIELD=VALUE (azimuth_deg=10)")
        values[name] = value
    return values


def raw_bytes(text: str) -> bytes:
    try:
        data = bytes.fromhex(text.replace(":", " "))
    except ValueError:
        raise TalkError(f"--raw {text!r}: hex bytes, e.g. 'F8 01 01 03 00 02 44 3F 8A'") from None
    if not data:
        raise TalkError("--raw: no bytes given")
    return data


def address(text: str) -> tuple[int, int, int]:
    """``G.P.D``, each 0..255 (255: the wildcard)."""
    try:
        return parse_address(text)
    except ValueError:
        raise TalkError(f"--to {text!r}: expected GROUP.PORT.DEVICE, each 0..255") from None


def parse_line(line: str, allowed: Allowed = ASK_ONLY) -> Asked:
    """A prompt's line, in ``send``'s words (``USAGE``); ``allowed``: what the
    session allows already (``live --talk --allow-motion``)."""
    try:
        words = shlex.split(line)
    except ValueError as e:
        raise TalkError(f"{e}: {USAGE}") from None
    asked = Asked(allowed=allowed)
    pairs: list[str] = []
    motion, config = allowed.motion, allowed.config
    it = iter(words)
    for word in it:
        if word == "--to":
            asked.to = address(next(it, ""))
        elif word == "--raw":
            asked.raw = next(it, "")
        elif word == "--allow-motion":
            motion = True
        elif word == "--allow-config":
            config = True
        elif word.startswith("-"):
            raise TalkError(f"{word}: not an option here ({USAGE})")
        elif "=" in word:
            pairs.append(word)
        elif asked.command is None:
            asked.command = word
        else:
            raise TalkError(f"{word!r}: one command at a time ({USAGE})")
    asked.values = field_values(pairs)
    asked.allowed = Allowed(motion=motion, config=config)
    return asked


def did_you_mean(e: EncodeError) -> str:
    """The clause a filter's mistake gets (``; did you mean azimuth_deg?``): a field
    without its unit or spelt nearly right, a code in the wrong case or nearly
    right; else, for an unknown command, where every code is listed."""
    if not e.valid or not e.given:
        return ""
    if e.kind == "field":
        units = {name: t.unit for name, t in field_types().items() if name in e.valid}
        words = Vocabulary(e.valid, units, (), e.valid)
        sure = words.exact(e.given)
        near = [sure[0]] if sure else words.near(e.given)
        return choices(near) if near else ""
    same = [code for code in e.valid if code.upper() == e.given.upper()]
    near = same or difflib.get_close_matches(e.given, e.valid, n=3, cutoff=0.6)
    # codes quoted: most end in a question mark
    if near:
        return choices([f"'{code}'" for code in near])
    return f"; the table's codes: {', '.join(e.valid)} (docs/fields.md)"
