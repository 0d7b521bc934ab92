"""The fix for a filter mistake, said beside the fault.

``filter.py`` names the fault and its column; this module says what to write
instead, as one clause appended to the error's one line: ``did you mean EXPR?``
with the expression rewritten at the bad spot (something to copy back), or the
names it could be when there are several. A hint only reads the source text
and the names; it never raises, and a mistake it does not know gets none.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

PROTOCOL = "gimbal"   # Wireshark's field prefix (docs/wireshark.md): gimbal.status is status here
CONTEXT = 30          # characters of the rewritten expression kept either side of the fix
# difflib's similarity for a did-you-mean; its default (0.6) offers 'name' for 'nak'
NAME_CUTOFF = 0.75
VALUE_CUTOFF = 0.6    # a field's few known values: a looser match still names the right one

# Wireshark's operators (and C's, Python's null) as this language spells them
OPERATOR_WORDS = {"eq": "==", "ne": "!=", "gt": ">", "lt": "<", "ge": ">=", "le": "<=",
                  "&&": "and", "&": "and", "||": "or", "|": "or"}
# Wireshark's own field names (analyzer/wireshark/lua.py) that are spelt differently here
WIRESHARK_NAMES = {"problem": "problems", "wire": "raw", "request_in": "request"}
WIRESHARK_FIELD = "field_"   # its prefix for a decoded field that shares a name with its own
# Wireshark's gimbal.dst is "group.port.device"; here dst is the list [group, port, device]
DST_PARTS = {"group": 0, "port": 1, "device": 2}
_ADDRESS = re.compile(r"([0-9]{1,3})\.([0-9]{1,3})\.([0-9]{1,3})")
_WORD_BEFORE = re.compile(r"[A-Za-z0-9_]+\Z")

QUOTE_TEXT = "text goes in quotes: "
UNIT_IN_NAME = "the unit is part of the name: "


def one_line(text: str) -> str:
    """Control characters (a newline typed into the filter) escaped, so the
    message stays one line."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def rewrite(src: str, start: int, end: int, new: str) -> str:
    """``src`` with ``src[start:end]`` replaced by ``new``, cut to CONTEXT
    characters either side of the change."""
    before, after = src[:start], src[end:]
    if len(before) > CONTEXT:
        before = "…" + before[-CONTEXT:]
    if len(after) > CONTEXT:
        after = after[:CONTEXT] + "…"
    return one_line(before + new + after)


@dataclass(frozen=True)
class Fix:
    """Replace ``src[start:end]`` (0-based) by ``text``; ``why`` says what rule it
    follows when the rewritten expression alone would not show it."""
    start: int
    end: int
    text: str
    why: str = ""

    def clause(self, src: str) -> str:
        return f"; {self.why}did you mean {rewrite(src, self.start, self.end, self.text)}?"


def choices(names: list[str]) -> str:
    """``; did you mean a, b or c?`` for a name with several likely fixes."""
    shown = names[:-1]
    listed = f"{', '.join(shown)} or {names[-1]}" if shown else names[0]
    return f"; did you mean {listed}?"


def spaced(src: str, start: int, end: int, word: str) -> Fix:
    """``word`` in place of ``src[start:end]``, with a space either side where a
    neighbour would otherwise run into it (``!ok`` → ``not ok``)."""
    before = "" if start == 0 or src[start - 1].isspace() else " "
    after = "" if end >= len(src) or src[end].isspace() else " "
    return Fix(start, end, before + word + after)


def character_fix(src: str, pos: int) -> Fix | None:
    """The fix for a character the language has no use for at ``pos``."""
    c = src[pos]
    if c == "=":
        if pos and src[pos - 1] in "=!<>":   # '===': one too many
            return Fix(pos, pos + 1, "")
        if src[pos + 1:].lstrip().startswith("="):   # '= =': which was meant is not clear
            return None
        return Fix(pos, pos + 1, "==")       # 'status = "nak"': '=' assigns nothing here
    if c in "&|":
        end = pos
        while end < len(src) and src[end] == c:
            end += 1
        return spaced(src, pos, end, OPERATOR_WORDS[c])
    if c == "!":                              # '!=' was taken whole: this is a lone '!'
        return spaced(src, pos, pos + 1, "not")
    if c in "\"'":                            # a quote the tokenizer could not close
        return Fix(len(src), len(src), c, "the text needs its closing quote: ")
    if c == "?":                              # a command written bare: command == P?
        word = _WORD_BEFORE.search(src, 0, pos)
        if word:
            return Fix(word.start(), pos + 1, f'"{src[word.start():pos + 1]}"', QUOTE_TEXT)
    return None


def operator_fix(word: str, start: int) -> Fix | None:
    """Where an operator or 'and'/'or' belongs: Wireshark's ``eq`` or a keyword
    in capitals (``AND``)."""
    low = word.lower()
    if low in OPERATOR_WORDS:
        return Fix(start, start + len(word), OPERATOR_WORDS[low])
    if low in ("and", "or", "in", "not") and word != low:
        return Fix(start, start + len(word), low)
    return None


def value_fix(value: str, allowed: Iterable[str]) -> str | None:
    """The known value ``value`` was most likely meant to be, or None."""
    allowed = sorted(allowed)
    for a in allowed:
        if a.lower() == value.lower():
            return a
    close = difflib.get_close_matches(value.lower(), allowed, n=1, cutoff=VALUE_CUTOFF)
    return close[0] if close else None


def unit_suffix(unit: str) -> str:
    """The suffix a unit gives a field's name: deg/s^2 → _deg_s2."""
    return "_" + unit.replace("/", "_").replace("^", "")


class Vocabulary:
    """The names a filter can use, and what a wrong name was most likely meant
    to be: a keyword in capitals, Wireshark's spelling, a field without its
    unit (``azimuth`` for ``azimuth_deg``), or a near spelling."""

    def __init__(self, names: Iterable[str], units: Mapping[str, str], keywords: Iterable[str],
                 field_names: Iterable[str]) -> None:
        self.names = frozenset(names)
        self.keywords = frozenset(keywords)
        self.field_names = frozenset(field_names)
        self.stems = {}
        for name, unit in units.items():
            suffix = unit_suffix(unit) if unit else ""
            if suffix and name.endswith(suffix):
                self.stems[name[:-len(suffix)]] = name

    def exact(self, word: str) -> tuple[str, str] | None:
        """The name ``word`` surely means, and the rule that says why when it is
        not plain spelling; None when only a near spelling could tell."""
        low = word.lower()
        if low in self.keywords and word != low:
            return low, ""
        if low == "none":
            return "null", ""
        if low.startswith(WIRESHARK_FIELD) and low[len(WIRESHARK_FIELD):] in self.field_names:
            return f"fields.{low[len(WIRESHARK_FIELD):]}", "Wireshark's field_ is fields. here: "
        if low in WIRESHARK_NAMES:
            return WIRESHARK_NAMES[low], ""
        if low in self.names:
            return low, ""
        if low in self.stems:
            return self.stems[low], UNIT_IN_NAME
        return None

    def near(self, word: str) -> list[str]:
        """Names spelt like ``word`` (best first); a unit-less stem counts as its field."""
        pool = {**{n: n for n in self.names}, **self.stems}
        close = difflib.get_close_matches(word.lower(), list(pool), n=3, cutoff=NAME_CUTOFF)
        return list(dict.fromkeys(pool[c] for c in close))

    def name_hint(self, src: str, word: str, start: int) -> str:
        """The clause for an unknown name at ``start``, or "" when none is near."""
        sure = self.exact(word)
        if sure:
            return Fix(start, start + len(word), *sure).clause(src)
        if word.lower() == PROTOCOL:
            return f"; Wireshark's {PROTOCOL}. goes before a name, as in {PROTOCOL}.status"
        near = self.near(word)
        if len(near) == 1:
            return Fix(start, start + len(word), near[0]).clause(src)
        return choices(near) if near else ""

    def text_hint(self, src: str, word: str, start: int, allowed: Iterable[str] | None) -> str:
        """The clause for an unknown name where a value was expected
        (``status == nak``): quote it, as the field's known value when it has
        some. A name that is surely a name (``elevation``) is corrected instead;
        a near spelling is not (``nak`` is not ``name``)."""
        sure = self.exact(word)
        if sure:
            return Fix(start, start + len(word), *sure).clause(src)
        value = word
        if allowed is not None:
            value = value_fix(word, allowed) or word
        return Fix(start, start + len(word), f'"{value}"', QUOTE_TEXT).clause(src)


def dst_text_fix(value: str, start: int, end: int) -> Fix | None:
    """``dst == "1.1.2"`` (Wireshark's gimbal.dst is text): the list it means."""
    m = _ADDRESS.fullmatch(value)
    if m is None:
        return None
    return Fix(start, end, "[" + ", ".join(str(int(g)) for g in m.groups()) + "]")
