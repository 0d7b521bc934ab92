"""Filters over the TUI store's columns (analyzer/formats/store_filter.py) select
exactly the rows the filter's closure selects, on every sample capture and on a
hostile line, for hand-picked filters and for random ones; and the columns
decide the filters they hold without the closure."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import analyzer
from analyzer.analysis.filter import compile_filter
from analyzer.analysis.filter_plan import AllOf, AnyOf, Const, Leaf, Name, Not
from analyzer.errors import FilterError
from analyzer.formats.store import EventStore
from analyzer.formats.store_filter import Columns, evaluate, matching
from analyzer.simulation.traffic import generate

SAMPLES = [("captures/demo-ctl.bin", "captures/demo-dev.bin"), ("captures/demo-socat.log",),
           ("captures/demo-bus.bin",)]


def stored(*paths) -> EventStore:
    store = EventStore()
    events = list(analyzer.open(*paths))
    for k in range(0, len(events), 97):   # in batches, as the screen appends them
        store.append(events[k:k + 97])
    return store


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    out = {p[0].split("/")[-1]: stored(*p) for p in SAMPLES}
    folder = tmp_path_factory.mktemp("hostile")
    tr = generate(500, baud=9600, seed=11, bit_error_rate=0.03, drop_ack_rate=0.05, noise_rate=0.05)
    (folder / "bus.bin").write_bytes(tr.single_line())
    out["hostile"] = stored(str(folder / "bus.bin"))
    return out


def by_closure(pred, store: EventStore, start: int = 0, stop: int | None = None) -> list[int]:
    stop = len(store) if stop is None else stop
    return [i for i in range(start, stop) if pred(store.event(i))]


HAND = [
    'status == "nak"', 'status != "ok"', 'not status == "ok"', "status == null", "status != null",
    'kind == "result" and azimuth_deg < -10', 'kind in ["ack", "nak"]', 'kind not in ["ack", "nak"]',
    "problems", "not problems", '"bad checksum" in problems', '"framing" in problems',
    'command in ["P?", "HO"]', 'command == "P?" or latency > 0.005', "latency > 0.005", "latency <= 0.005",
    "latency == null", "latency != null", "latency", "not latency", "retransmission", "retransmission == false",
    "checksum_ok == false", "checksum_ok == null", "not checksum_ok", 'device == "1.1.2"', 'device != "1.1.2"',
    'line == "A"', "number > 100 and number <= 200", "t > 1.0 and t < 2.5", "t == null", "t_end >= 3",
    "offset < 50", "txn == 3", "txn in [1, 2, 3, true]", "request != null", "request == 7", "dst[2] == 3",
    "src == 1", 'payload == "P?"', 'fields.azimuth_deg > 0', "revision != null", "number == true",
    'latency == "x"', 'latency in "abc"', '"P" in command', 'status in ["nak", null]', "not not problems",
    '(status == "ok" or status == "nak") and not retransmission', 'status == command',
    'raw == "0610"', "azimuth_deg == null", "not azimuth_deg == null", 'kind == "noise" or problems',
]


@pytest.mark.parametrize("text", HAND)
def test_hand_picked_filters_select_the_closures_rows(stores, text):
    pred = compile_filter(text)
    for name, store in stores.items():
        assert list(matching(pred, store, 0, len(store))) == by_closure(pred, store), (name, text)
        # a part of the store, as the catch-up after a filter's sweep takes it
        a, b = len(store) // 3, 2 * len(store) // 3
        assert list(matching(pred, store, a, b)) == by_closure(pred, store, a, b), (name, text)


def test_what_the_columns_hold_is_decided_without_the_closure(stores):
    store = stores["demo-socat.log"]
    cols = Columns(store, 0, len(store))
    for text in ('status == "nak" or problems', 'command in ["P?", "HO"] and latency > 0.005',
                 'not (device == "1.1.2") and t > 1', '"bad checksum" in problems', "number > 10"):
        _, maybe = evaluate(compile_filter(text).plan, cols)
        assert not maybe.any(), text
    # a decoded field: the closure runs on commands and results only
    _, maybe = evaluate(compile_filter('kind == "result" and azimuth_deg < -10').plan, cols)
    kinds = [store.event(i).kind for i in range(len(store))]
    assert maybe.any() and all(kinds[i] == "result" for i in maybe.nonzero()[0])


def test_a_plan_says_what_the_filter_tests():
    plan = compile_filter('status == "nak" or not problems or dst[2] == 3 or latency > azimuth_deg').plan
    assert isinstance(plan, AnyOf) and len(plan.plans) == 4
    status, no_problems, dst, names = plan.plans
    assert isinstance(status, Leaf) and (status.name, status.op, status.value, status.negate) == \
        (Name("status"), "==", "nak", False)
    assert isinstance(no_problems, Not) and isinstance(no_problems.plan, Leaf)
    assert (no_problems.plan.name, no_problems.plan.op) == (Name("problems"), "truth")
    assert isinstance(dst, Leaf) and (dst.name, dst.value) == (Name("dst", (2,)), 3)
    assert names is None   # two names compared: left to the closure
    has = compile_filter('"bad checksum" not in problems').plan
    assert isinstance(has, Leaf) and (has.op, has.value, has.negate) == ("has", "bad checksum", True)
    assert compile_filter("true and 1").plan == AllOf((Const(True), Const(True)))


# ------------------------------------------------------------------ random filters
NAMES = {
    "kind": st.sampled_from(['"command"', '"result"', '"ack"', '"nak"', '"nic"', '"noise"']),
    "status": st.sampled_from(['"ok"', '"nak"', '"nic"', '"no_ack"', '"no_result"', '"pending"']),
    "command": st.sampled_from(['"P?"', '"HO"', '"D?"', '"QZ"', '"P"']),
    "device": st.sampled_from(['"1.1.1"', '"1.1.2"', '"0.1.2"']),
    "line": st.sampled_from(['"A"', '"B"', '"AB"']),
    "latency": st.sampled_from(["0", "0.004", "0.01", "1"]),
    "t": st.sampled_from(["0", "0.5", "1", "2.25", "100"]),
    "t_end": st.sampled_from(["0", "1", "3"]),
    "number": st.integers(0, 600).map(str),
    "offset": st.integers(0, 3000).map(str),
    "txn": st.integers(0, 200).map(str),
    "request": st.integers(0, 400).map(str),
    "checksum_ok": st.sampled_from(["true", "false"]),
    "retransmission": st.sampled_from(["true", "false"]),
    "azimuth_deg": st.sampled_from(["-10", "0", "40.5"]),
    "revision": st.sampled_from(['"19"', '"20"']),
    "src": st.integers(0, 3).map(str),
}
ANY_VALUE = st.sampled_from(["null", "true", "false", '"x"', "3", "0.5", '"ok"', "[]"])


@st.composite
def leaf(draw) -> str:
    name = draw(st.sampled_from(sorted(NAMES)))
    value = draw(st.one_of(NAMES[name], ANY_VALUE))
    shape = draw(st.integers(0, 6))
    if shape == 0:
        return name
    if shape == 1:
        other = draw(NAMES[name])
        return f"{name} {'not in' if draw(st.booleans()) else 'in'} [{value}, {other}]"
    if shape == 2:
        return f'"{draw(st.sampled_from(["bad checksum", "framing", "timeout", "x"]))}" in problems'
    op = draw(st.sampled_from(["==", "!=", "<", ">", "<=", ">="]))
    return f"{name} {op} {value}"


def combined(children):
    return st.one_of(
        st.tuples(children, children).map(lambda p: f"({p[0]} and {p[1]})"),
        st.tuples(children, children).map(lambda p: f"({p[0]} or {p[1]})"),
        children.map(lambda c: f"not {c}"),
    )


FILTERS = st.recursive(leaf(), combined, max_leaves=5)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=FILTERS)
def test_random_filters_select_the_closures_rows(stores, text):
    try:
        pred = compile_filter(text)
    except FilterError:   # a value no such name has (kind == "x"): refused when typed
        assume(False)
    for name, store in stores.items():
        assert list(matching(pred, store, 0, len(store))) == by_closure(pred, store), (name, text)


def test_a_filtered_views_errors_come_from_the_flags(stores):
    from analyzer.formats.store import is_error
    from analyzer.tui.model.capture import CaptureModel

    events = list(analyzer.open("captures/demo-socat.log"))
    model = CaptureModel(follow=False)
    model.extend(events[:200])
    model.set_filter('device == "1.1.2" or kind == "noise"')
    model.extend(events[200:])   # learned as they come, after the filter's sweep
    wanted = [e for e in events if e.device == "1.1.2" or e.kind == "noise"]
    assert model.row_count == len(wanted)
    assert model.totals.shown_errors == sum(1 for e in wanted if is_error(e)) > 0
    model.set_filter("")
    assert model.totals.shown_errors == model.totals.errors == sum(1 for e in events if is_error(e))
