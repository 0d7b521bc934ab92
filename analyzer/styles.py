"""How things look: one table of Rich style strings for the text output
(``decode`` on a terminal), the TUI (event rows, timeline, help legend, findings)
and the doctor's report. No Textual here: the text output imports it.

An event's look follows its *row class* (``row_class``): why the row stands
out, in priority order; ``ROW_STYLE`` gives each class its style. Findings and
problems are coloured by their severity (``SEVERITY_STYLE``).
"""

from __future__ import annotations

from dissectors.event import ACK, COMMAND, NAK, NIC, NO_ACK, NO_RESULT, NOISE, RATE, RESULT, ST_NAK, ST_NIC, Event
from dissectors.problems import ERROR, NOTE, WARNING

# A finding that only informs (the device map): the doctor's third severity. The
# other two, ERROR and WARNING, are the words problems use too (NOTE is theirs).
INFO = "info"

SEVERITY_STYLE = {ERROR: "bold red", WARNING: "yellow", INFO: "cyan", NOTE: "cyan"}
# the same colours in bold, for a one-word summary in a status bar
SEVERITY_BADGE = {ERROR: "bold red", WARNING: "bold yellow", INFO: "bold cyan", NOTE: "bold cyan"}
# a tapped port's state, as the serial source names it (others: "white")
PORT_STATE_STYLE = {"open": "green", "lost": "red", "reconnecting": "yellow"}

# Row classes. ACK and result rows are plain in the event list; the timeline,
# which draws every event in colour, falls back to the kind (ROW_ACK, ROW_RESULT).
ROW_CHECKSUM = "checksum"
ROW_NOISE = NOISE
ROW_NAK = NAK
ROW_NIC = NIC
ROW_UNANSWERED = "unanswered"
ROW_RETRANSMISSION = "retransmission"
ROW_SLOW = "slow"
ROW_PROBLEM = "problem"
ROW_COMMAND = COMMAND
ROW_WAITING = "waiting"
ROW_ACK = ACK
ROW_RESULT = RESULT
ROW_RATE = RATE
ROW_PLAIN = ""

ROW_STYLE = {
    ROW_CHECKSUM: "bold white on red",
    ROW_NOISE: "red",
    ROW_NAK: "bold bright_red",
    ROW_NIC: "magenta",
    ROW_UNANSWERED: "bold yellow",
    ROW_RETRANSMISSION: "dark_orange",
    ROW_SLOW: "yellow",
    ROW_PROBLEM: "yellow",
    ROW_COMMAND: "cyan",
    ROW_WAITING: "dim cyan",
    ROW_ACK: "green",
    ROW_RESULT: "bright_green",
    ROW_RATE: "bold blue",
    ROW_PLAIN: "",
}

# The timeline: the rows' styles, its axis and links, and the selected transaction.
TIMELINE_STYLE = {
    **ROW_STYLE,
    "axis": "dim",
    "link": "grey50",
    "gap": "dim italic",
    "selected": "bold reverse",
}

# The help screen's "Row colours": a label and its row class, in priority order.
LEGEND = (
    ("bad checksum", ROW_CHECKSUM),
    ("noise", ROW_NOISE),
    ("NAK", ROW_NAK),
    ("NIC", ROW_NIC),
    ("no answer", ROW_UNANSWERED),
    ("retransmission", ROW_RETRANSMISSION),
    ("slow answer", ROW_SLOW),
    ("other problem", ROW_PROBLEM),
    ("command", ROW_COMMAND),
    ("waiting", ROW_WAITING),
    ("rate change", ROW_RATE),
)


def row_class(ev: Event, slow: float | None = None) -> str:
    """Why ``ev``'s row stands out (ROW_*), the first rule that applies.

    The text output and the TUI share these rules. ``slow`` (seconds) is the
    TUI's: answers slower than it are ROW_SLOW; the text output passes none.
    A command whose status is not final yet is ROW_WAITING: only the TUI shows
    such commands (the text output prints settled events). A ``pending``
    command (the capture ended first) is an ordinary command, not unanswered.
    """
    if ev.checksum_ok is False:
        return ROW_CHECKSUM
    kind = ev.kind
    if kind == NOISE:
        return ROW_NOISE
    if kind == RATE:
        return ROW_RATE
    status = ev.status
    if kind == NAK or status == ST_NAK:
        return ROW_NAK
    if kind == NIC or status == ST_NIC:
        return ROW_NIC
    if status == NO_ACK or status == NO_RESULT:
        return ROW_UNANSWERED
    if ev.retransmission:
        return ROW_RETRANSMISSION
    if slow is not None and ev.latency is not None and ev.latency > slow:
        return ROW_SLOW
    if ev.problems:
        return ROW_PROBLEM
    if kind == COMMAND:
        return ROW_COMMAND if status is not None else ROW_WAITING
    return ROW_PLAIN
