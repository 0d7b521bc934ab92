"""Every problem gimbalscope attaches to an event, in one table (like a dissector's
expert-info fields): an id, the category text JSON Lines shows, a severity and a
one-line summary for people.

A problem on an event is a ``Problem``: a ``str`` whose text is "category: detail"
(the JSON Lines contract, docs/decoding.md "Problems"; filters match the text,
``"bad checksum" in problems``), which also carries its id, so code tests
``p.id is UNANSWERED_SUPERSEDED`` rather than searching the prose. Some categories
have sub-cases with ids of their own; they share their category's text.

Make one with ``CHECKSUM.problem("expected 0x12, got 0x34")`` or
``Event.add_problem(CHECKSUM, detail)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

ERROR = "error"       # the bytes or the exchange are broken
WARNING = "warning"   # readable, but not what the protocol says
NOTE = "note"         # worth knowing, nothing wrong on the wire


class Problem(str):
    """A problem's text, "category: detail", carrying its ``id`` (a ``ProblemInfo``).

    Each table entry has its own subclass holding the id as a class attribute, so a
    problem carries no per-instance dictionary (noise floods make millions)."""
    __slots__ = ()
    id: ProblemInfo

    @property
    def category(self) -> ProblemInfo:
        """The id of the problem's category (itself when it has no sub-cases)."""
        return self.id.category

    def __reduce__(self) -> tuple[Callable[[str, str], Problem], tuple[str, str]]:
        # by the id's name: unpickled, ``p.id`` is the very table entry again
        return _restore, (self.id.name, str(self))


@dataclass(frozen=True, eq=False)
class ProblemInfo:
    """One entry of the table. Compared by identity: ``p.id is CHECKSUM``."""
    name: str        # the id as code and docs name it, "UNANSWERED_SUPERSEDED"
    text: str        # the category as JSON Lines writes it, "unanswered"
    severity: str    # ERROR, WARNING or NOTE
    summary: str
    parent: ProblemInfo | None = None   # the category of a sub-case
    _cls: type[Problem] = field(init=False, repr=False)     # this entry's Problem subclass
    _prefix: str = field(init=False, repr=False)  # "category: "

    def __post_init__(self) -> None:
        cls = type("Problem_" + self.name, (Problem,), {"__slots__": (), "id": self})
        object.__setattr__(self, "_cls", cls)
        object.__setattr__(self, "_prefix", self.text + ": ")

    @property
    def category(self) -> ProblemInfo:
        return self.parent if self.parent is not None else self

    def problem(self, detail: str = "") -> Problem:
        """This problem with its detail, as events carry it."""
        return self._cls(self._prefix + detail if detail else self.text)

    def with_text(self, text: str) -> Problem:
        """This problem carrying ``text`` whole ("category: detail"), as a problem
        written out and read back is."""
        return self._cls(text)

    def matches(self, p: str) -> bool:
        """Is ``p`` this problem, or one of its sub-cases? A plain string (an event
        built by hand) carries no id: its category text decides, for categories."""
        if isinstance(p, Problem):
            info = p.id
            return info is self or info.parent is self
        return self.parent is None and (p == self.text or p.startswith(self.text + ":"))

    def __reduce__(self) -> tuple[Callable[[str], ProblemInfo], tuple[str]]:
        return by_name, (self.name,)


TABLE: list[ProblemInfo] = []


def _info(name: str, text: str, severity: str, summary: str,
          parent: ProblemInfo | None = None) -> ProblemInfo:
    info = ProblemInfo(name, text, severity, summary, parent)
    TABLE.append(info)
    return info


def _case(parent: ProblemInfo, name: str, severity: str, summary: str) -> ProblemInfo:
    """A sub-case of ``parent``: its own id and severity, the category text JSON shows."""
    return _info(name, parent.text, severity, summary, parent)


# ---------------------------------------------------------------- frames (deframer)
CHECKSUM = _info("CHECKSUM", "bad checksum", ERROR,
                 "a frame's checksum does not hold, or a broken frame's bytes")
LENGTH = _info("LENGTH", "bad length byte", ERROR,
               "the length byte was corrupted: the checksum holds with another length")
TRUNCATED = _info("TRUNCATED", "truncated frame", ERROR,
                  "a frame cut short by a silence, the end of the capture or bytes not decoded")
NOISE = _info("NOISE", "noise", WARNING, "bytes outside any frame")

# ---------------------------------------------------------------- the line itself (a UART's own errors)
# What a receiver saw below the bytes: a software UART over a logic capture
# (analyzer/physical/uart.py), or a USB adapter's line status (analyzer/sources/usb.py).
LINE = _info("LINE", "line error", ERROR,
             "the receiver saw a framing or parity error, a break or an overrun on these bytes")
LINE_FRAMING = _case(LINE, "LINE_FRAMING", ERROR, "a byte's stop bit was not at the idle level (framing error)")
LINE_PARITY = _case(LINE, "LINE_PARITY", ERROR, "a byte's parity bit does not hold")
LINE_BREAK = _case(LINE, "LINE_BREAK", ERROR, "the line was held at the active level for longer than a byte (break)")
LINE_OVERRUN = _case(LINE, "LINE_OVERRUN", ERROR, "the receiver lost bytes: its buffer overran")

# ---------------------------------------------------------------- payloads (dissection)
MALFORMED = _info("MALFORMED", "malformed payload", ERROR,
                  "a known command or result whose payload does not fit its layout")
OUT_OF_RANGE = _info("OUT_OF_RANGE", "value out of range", WARNING,
                     "a field's value is outside what the document allows")
RESERVED = _info("RESERVED", "reserved code", WARNING,
                 "a code or bits the document marks reserved")
LOWERCASE_HEX = _info("LOWERCASE_HEX", "lower-case hex", NOTE,
                      "numbers must be upper-case ASCII hex (§1.4.1.2)")
UNKNOWN_COMMAND = _info("UNKNOWN_COMMAND", "unknown command", WARNING,
                        "a command code that is not in protocol rev 1.9")

# ---------------------------------------------------------------- exchanges (pairing)
UNANSWERED = _info("UNANSWERED", "unanswered", ERROR, "a command whose ACK/NAK did not come")
UNANSWERED_TIMEOUT = _case(UNANSWERED, "UNANSWERED_TIMEOUT", ERROR,
                           "no ACK/NAK within the ACK timeout (or, untimed, within the event window)")
UNANSWERED_SUPERSEDED = _case(UNANSWERED, "UNANSWERED_SUPERSEDED", ERROR, "the next command came before any ACK/NAK")
UNANSWERED_NO_ACK = _case(UNANSWERED, "UNANSWERED_NO_ACK", WARNING, "the result arrived, but no ACK was seen before it")
NO_RESULT = _info("NO_RESULT", "missing result", ERROR, "an ACKed command's due result did not come")
NO_RESULT_TIMEOUT = _case(NO_RESULT, "NO_RESULT_TIMEOUT", ERROR,
                          "no result within the result timeout (or, untimed, within the window)")
NO_RESULT_SENT_AGAIN = _case(NO_RESULT, "NO_RESULT_SENT_AGAIN", WARNING,
                             "the same command was sent again before its result came")
NO_RESULT_OVERFLOW = _case(NO_RESULT, "NO_RESULT_OVERFLOW", WARNING,
                           "given up: too many commands were waiting for results")
RETRANSMISSION = _info("RETRANSMISSION", "retransmission", NOTE,
                       "a command repeating the previous one after it failed")
ORPHAN = _info("ORPHAN", "orphan", WARNING, "an ACK, NAK, NIC or result that no command awaits")
LATE = _info("LATE", "late answer", WARNING, "an ACK/NAK that came after the ACK timeout")

BY_NAME: dict[str, ProblemInfo] = {info.name: info for info in TABLE}
# category text -> the category's entry (sub-cases share their category's text)
BY_TEXT: dict[str, ProblemInfo] = {info.text: info for info in TABLE if info.parent is None}


def by_name(name: str) -> ProblemInfo:
    return BY_NAME[name]


def parse(text: str) -> Problem:
    """A problem from its text, "category: detail": for problems made as plain
    strings (by hand, in tests). Raises ``ValueError`` for a category not in the
    table, so no problem goes without an id."""
    if isinstance(text, Problem):
        return text
    info = BY_TEXT.get(text.split(":", 1)[0])
    if info is None:
        raise ValueError(f"{text!r} does not start with a problem category of the table")
    return info.with_text(text)


def _restore(name: str, text: str) -> Problem:
    return BY_NAME[name].with_text(text)
