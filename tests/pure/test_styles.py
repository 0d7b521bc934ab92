"""One style table (analyzer.styles): the row classes the text output and the TUI
share, and a style for every severity findings and problems have."""

import pytest

from analyzer.analysis import doctor
from analyzer.output import style_of
from analyzer.styles import (
    LEGEND,
    ROW_CHECKSUM,
    ROW_COMMAND,
    ROW_NAK,
    ROW_NIC,
    ROW_NOISE,
    ROW_PLAIN,
    ROW_PROBLEM,
    ROW_RETRANSMISSION,
    ROW_SLOW,
    ROW_STYLE,
    ROW_UNANSWERED,
    ROW_WAITING,
    SEVERITY_STYLE,
    TIMELINE_STYLE,
    row_class,
)
from dissectors import problems
from dissectors.event import ACK, COMMAND, NAK, NIC, NOISE, RESULT, Event


def ev(kind=COMMAND, **kw) -> Event:
    e = Event("A" if kind == COMMAND else "B", 0, kind, b"\xf8")
    for name, value in kw.items():
        setattr(e, name, value)
    return e


@pytest.mark.parametrize("event,row", [
    (ev(checksum_ok=False, status="nak"), ROW_CHECKSUM),        # the first rule wins
    (ev(NOISE), ROW_NOISE),
    (ev(NAK), ROW_NAK),
    (ev(status="nak"), ROW_NAK),
    (ev(NIC), ROW_NIC),
    (ev(status="nic"), ROW_NIC),
    (ev(status="no_ack"), ROW_UNANSWERED),
    (ev(status="no_result"), ROW_UNANSWERED),
    (ev(status="ok", retransmission=True), ROW_RETRANSMISSION),
    (ev(status="ok", problems=["reserved code: C8"]), ROW_PROBLEM),
    (ev(status="ok"), ROW_COMMAND),
    (ev(status="pending"), ROW_COMMAND),                        # the capture ended first: no failure
    (ev(), ROW_WAITING),                                        # not settled yet (the TUI shows it)
    (ev(ACK, latency=0.5), ROW_PLAIN),                          # slow only where a threshold is given
    (ev(RESULT), ROW_PLAIN),
])
def test_row_classes(event, row):
    assert row_class(event) == row
    assert style_of(event) == ROW_STYLE[row]                    # the text output's colour is the row's


def test_slow_answers_are_the_tuis_extra():
    ack = ev(ACK, latency=0.5)
    assert row_class(ack, slow=0.1) == ROW_SLOW and row_class(ack, slow=1.0) == ROW_PLAIN
    assert row_class(ev(NAK, latency=0.5), slow=0.1) == ROW_NAK  # a NAK is a NAK first


def test_every_severity_and_row_class_has_a_style():
    severities = {info.severity for info in problems.TABLE} | {doctor.ERROR, doctor.WARNING, doctor.INFO}
    assert severities <= set(SEVERITY_STYLE)
    assert {row for _label, row in LEGEND} <= set(ROW_STYLE)
    assert set(ROW_STYLE) <= set(TIMELINE_STYLE)
    # the timeline draws an ACK or a result in the colour of its kind
    assert TIMELINE_STYLE[ACK] and TIMELINE_STYLE[RESULT]
