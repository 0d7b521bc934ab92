"""Search by a filter expression (``=EXPR`` at the search prompt, as Wireshark's
"find by display filter"): from any row, the next hit forward or back is the
next event the expression selects among the rows shown, wrapping round, found
through the store's columns. Held against the expression's own closure, event
by event, on the sample captures, with and without a filter view."""

from __future__ import annotations

import pytest

import analyzer
from analyzer.analysis.filter import FilterError, compile_filter
from analyzer.tui.model import CaptureModel
from tests.pure.test_store_filter import HAND, SAMPLES


@pytest.fixture(scope="module")
def models():
    out = {}
    for paths in SAMPLES:
        events = list(analyzer.open(*paths))
        m = CaptureModel(follow=False)
        m.extend(events)
        out[paths[0]] = (m, events)
    return out


def walk(m: CaptureModel, text: str, forward: bool) -> list[int]:
    """Hits in the order n (or N) visits them from the first row, once round."""
    seen: list[int] = []
    here = m.row(0).number
    while True:
        n = m.nav.search(text, here, forward)
        if n is None or n in seen:
            return seen
        seen.append(n)
        here = n


@pytest.mark.parametrize("expr", HAND[::3] + ['kind == "nak"', "number < 0"])
def test_the_hits_are_the_events_the_expression_selects(models, expr):
    pred = compile_filter(expr)
    for m, events in models.values():
        m.set_filter("")
        want = [e.number for e in events if pred(e)]
        first = m.row(0).number
        forward = walk(m, "=" + expr, True)
        # from the first row on, forward: after it, then round to it
        assert forward == [n for n in want if n > first] + [n for n in want if n <= first], expr
        assert sorted(walk(m, "=" + expr, False)) == want
        # a filter view: only the rows it shows are hits
        m.set_filter('kind in ["command", "nak"]')
        shown = [e.number for e in events if e.kind in ("command", "nak")]
        within = [n for n in want if n in set(shown)]
        assert sorted(walk(m, "= " + expr, True)) == within


def test_backwards_from_a_row_is_the_hit_before_it(models):
    m, events = models[SAMPLES[1][0]]
    m.set_filter("")
    acks = [e.number for e in events if e.kind == "ack"]
    assert len(acks) >= 3
    assert m.nav.search('=kind == "ack"', acks[1], forward=False) == acks[0]
    assert m.nav.search('=kind == "ack"', acks[0], forward=False) == acks[-1]   # round the start
    assert m.nav.search('=kind == "ack"', acks[-1]) == acks[0]                  # round the end


def test_a_bad_expression_is_a_filter_error(models):
    m, _ = models[SAMPLES[0][0]]
    with pytest.raises(FilterError):
        m.nav.search("=kind ==", 1)
