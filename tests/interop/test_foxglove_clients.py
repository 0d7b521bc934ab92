"""Foxglove clients of every age (docs/foxglove.md, "Clients of every age"): ``live
--foxglove`` and ``replay --foxglove`` take clients offering the protocol's former
name, ``foxglove.websocket.v1``, as well as the SDK's, ``foxglove.sdk.v1``.

The old client is ``@foxglove/ws-protocol``'s own ``FoxgloveClient`` over the ``ws``
package (``js/live.mjs``; the packages pinned in ``js/package-lock.json``, installed
by ``.ci/run``), offering one name; the current one is the Python client of
tests/integration/test_foxglove_live.py, offering the SDK's. Connected to the same
tap, they get the same topics, schemas, messages and log times, those of its
recording. Every wait is on a condition, with a generous deadline.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import subprocess
import threading
from collections import defaultdict

from mcap.reader import make_reader

from analyzer.simulation.traffic import generate
from tests.child import PATIENCE, wait_for
from tests.conftest import SOCAT_LOG, run_cli
from tests.integration.test_foxglove_live import (
    DEVICES,
    Client,
    Tap,
    client,
    free_port,
    position_query,
    recorded,
    two_lines,
    write_exchanges,
    write_paced,
)
from tests.interop.node import JS_DIR, node_with

LIVE = os.path.join(JS_DIR, "live.mjs")
PACKAGES = ("@foxglove/ws-protocol", "ws")
OLD, NEW = "foxglove.websocket.v1", "foxglove.sdk.v1"
FIXED = {"/serial/A/raw", "/serial/B/raw", "/events", "/transactions", "/log"}
LAST = "7FFF0123"   # the last report's position, in no other result


class JsClient:
    """``node live.mjs ws://127.0.0.1:PORT SUBPROTOCOL``, what it prints read as it comes."""

    def __init__(self, port: int, subprotocol: str) -> None:
        node = node_with(*PACKAGES)
        self.proc = subprocess.Popen([node, LIVE, f"ws://127.0.0.1:{port}", subprotocol], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        self.subprotocol: str | None = None
        self.channels: dict[str, dict] = {}                              # topic -> channel as advertised
        self.synced: set[str] = set()                                    # topics the server has taken
        self.messages: dict[str, list[tuple[int, bytes]]] = defaultdict(list)   # topic -> (log time, bytes)
        self.close_code: int | None = None
        self.err = ""
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            msg = json.loads(line)
            op = msg["op"]
            if op == "message":
                self.messages[msg["topic"]].append((int(msg["logTime"]), base64.b64decode(msg["data"])))
            elif op == "open":
                self.subprotocol = msg["subprotocol"]
            elif op == "advertise":
                self.channels[msg["channel"]["topic"]] = msg["channel"]
            elif op == "synced":
                self.synced = set(msg["topics"])
            elif op == "close":
                self.close_code = msg["code"]

    def wait_synced(self, topics: set[str]) -> None:
        wait_for(lambda: topics <= self.synced or self.proc.poll() is not None, f"node subscribed to {topics}")
        assert topics <= self.synced, self.proc.stderr.read() if self.proc.stderr else ""

    def events(self) -> list[dict]:
        return [json.loads(m) for _t, m in self.messages["/events"]]

    def wait(self) -> int:
        """Until it ends (the server closed the connection): its exit code."""
        code = self.proc.wait(PATIENCE)
        self._reader.join(PATIENCE)
        assert self.proc.stderr is not None
        self.err += self.proc.stderr.read()
        return code


@contextlib.contextmanager
def js_client(port: int, subprotocol: str):
    c = JsClient(port, subprotocol)
    try:
        yield c
    finally:
        if c.proc.poll() is None:
            c.proc.kill()
        c.wait()


def has_last_report(events: list[dict]) -> bool:
    return any(e["kind"] == "result" and e["payload"].endswith(LAST) for e in events)


def counts(c: JsClient | Client) -> dict[str, int]:
    return {topic: len(messages) for topic, messages in list(c.messages.items()) if messages}


def recorded_schemas(path) -> dict[str, tuple[str, str]]:
    """A recording's (schema name, schema text) per topic."""
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return {ch.topic: (summary.schemas[ch.schema_id].name, summary.schemas[ch.schema_id].data.decode())
            for ch in summary.channels.values() if ch.schema_id}


def test_an_old_client_gets_what_a_current_one_gets(tmp_path):
    """``live --record --foxglove`` with both clients subscribed to every topic
    before the traffic: the same messages, a run of the recording's."""
    port = free_port()
    rec = tmp_path / "rec.mcap"
    positions = {f"/gimbal/{d}/position" for d in DEVICES}
    with two_lines() as (fds, pa, pb):
        tap = Tap("live", pa, pb, "--no-tui", "--record", rec, "--foxglove", f"127.0.0.1:{port}")
        try:
            tap.wait_serving(port)
            make_position_topics(port, fds, positions)
            with js_client(port, OLD) as old, client(port) as new:
                old.wait_synced(FIXED | positions)
                assert old.subprotocol == OLD
                assert positions <= set(new.subscribed.values())
                write_paced(fds, generate(120, seed=7, bit_error_rate=0.02, drop_ack_rate=0.02,
                                          noise_rate=0.02).writes)
                write_exchanges(fds, position_query((1, 1, 1), LAST))
                wait_for(lambda: has_last_report(new.events()) and has_last_report(old.events()),
                         "the last report")
                # everything sent so far, to both, before the tap stops (what it says
                # as it stops may reach one client and not the other)
                wait_for(lambda: counts(old) == counts(new), "both clients to have it all")
                assert {t: m for t, m in old.messages.items() if m} == {t: m for t, m in new.messages.items() if m}
                assert tap.stop()[0] == 0, "".join(tap.err)
                assert old.wait() == 0, old.err
        finally:
            tap.stop()
    assert not any("Traceback" in line for line in tap.err), "".join(tap.err)
    want = recorded(rec)
    assert len(want["/events"]) > 250
    # the same topics, with the recording's schemas, as each client saw them advertised
    schemas = recorded_schemas(rec)
    assert set(old.channels) == set(new.schemas) == set(schemas) - {"/gimbalscope/columns"}
    for topic, channel in old.channels.items():
        assert (channel["schemaName"], channel["schema"]) == schemas[topic], topic
        assert new.schemas[topic] == channel["schemaName"]
        assert channel["encoding"] == "json" and channel["schemaEncoding"] == "jsonschema"
    # the recording's messages and log times, from the clients' start on: to its end
    # for the events and positions, and for the other topics as far as they came
    # before the tap stopped
    for c in (old, new):
        for topic in ("/events", *positions):
            assert is_run(c.messages[topic], want[topic], to_the_end=True), topic
        for topic in ("/serial/A/raw", "/serial/B/raw", "/transactions", "/log"):
            assert is_run(c.messages[topic], want[topic]), topic


def make_position_topics(port: int, fds: dict[str, int], topics: set[str]) -> None:
    """Each gimbal reports once, to a client of its own: the server keeps a new
    topic's first message until a client subscribes, and the one that subscribes
    first gets it. Made beforehand, the topics are advertised to later clients
    at once, and every message after their subscriptions goes to each."""
    with client(port) as primer:
        devices = [tuple(map(int, d.split("."))) for d in DEVICES]
        write_exchanges(fds, [x for dev in devices for x in position_query(dev, "0FA0FC18")])
        wait_for(lambda: all(primer.messages[t] for t in topics), "the position topics' first messages")


def is_run(got: list, want: list, to_the_end: bool = False) -> bool:
    """``got`` is some of ``want`` in a row (to its end)."""
    if not got or got[0] not in want:
        return False
    first = want.index(got[0])
    return got == want[first:first + len(got)] and (not to_the_end or first + len(got) == len(want))


def test_replay_serves_old_and_new_names(tmp_path):
    """``replay --foxglove``: the library's client offering either name alone gets
    a run of the recording's events, as they were recorded."""
    rec = tmp_path / "demo.mcap"
    assert run_cli("convert", SOCAT_LOG, "-o", rec).returncode == 0
    want = [m for _t, m in recorded(rec)["/events"]]
    port = free_port()
    # at a quarter of its pace: half a minute for the clients to start, and the
    # tap stopped once they have enough
    tap = Tap("replay", rec, "--speed", "0.25", "--no-tui", "--foxglove", f"127.0.0.1:{port}")
    try:
        tap.wait_serving(port)
        with js_client(port, OLD) as old, js_client(port, NEW) as new:
            wait_for(lambda: len(old.messages["/events"]) >= 20 and len(new.messages["/events"]) >= 20,
                     "events at both clients")
            # interrupted, as by Ctrl-C (130), or, on a very slow machine, ended by itself (0)
            assert tap.stop()[0] in (0, 130), "".join(tap.err)
            assert old.wait() == 0 and new.wait() == 0, old.err + new.err
    finally:
        tap.stop()
    assert (old.subprotocol, new.subprotocol) == (OLD, NEW)
    for c in (old, new):
        got = [m for _t, m in c.messages["/events"]]
        first = want.index(got[0])
        assert got == want[first:first + len(got)]


def test_a_client_offering_neither_name_is_refused(tmp_path):
    """As the SDK's server refuses it: HTTP 400 in the handshake, and the tap goes on."""
    port = free_port()
    tap = Tap("demo", "--seconds", "0", "--no-tui", "--foxglove", f"127.0.0.1:{port}")
    try:
        tap.wait_serving(port)
        with js_client(port, "foxglove.websocket.v2") as refused:
            assert refused.wait() == 1
        assert "Unexpected server response: 400" in refused.err
        with js_client(port, OLD) as old:   # still serving
            wait_for(lambda: len(old.messages["/events"]) >= 5, "events")
    finally:
        assert tap.stop()[0] == 0, "".join(tap.err)
