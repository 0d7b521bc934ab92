"""``--foxglove``: a tap served live over the Foxglove WebSocket protocol, checked
with a real WebSocket client against the recording of the same run.

The client speaks the protocol as the Foxglove app does: it reads ``serverInfo``
and ``advertise``, subscribes to every channel as it is advertised, and reads
message data as binary frames (opcode 0x01, u32 LE subscription id, u64 LE log
time in ns, the message). Every wait is on a condition, with a generous
deadline: the machine may be busy.
"""

import asyncio
import contextlib
import json
import os
import re
import socket
import struct
import subprocess
import threading
import time
import tty
from collections import defaultdict

from mcap.reader import make_reader
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

import analyzer
from analyzer.formats import mcap_schemas as S
from analyzer.info import CaptureInfo
from analyzer.listeners.foxglove import FoxgloveServer
from analyzer.simulation.traffic import generate
from analyzer.tui.run import make_app, stop_feed
from tests.child import PATIENCE, Child, wait_for
from tests.conftest import SOCAT_LOG, frame, run_cli

SUBPROTOCOL = "foxglove.sdk.v1"   # what the SDK's server accepts; its front also takes foxglove.websocket.v1
REFUSED = re.compile(r"Unknown channel ID: (\d+)")
PARAMETERS = "does not support parameters"   # the answer to a request for parameters
DEVICES = ("1.1.1", "1.1.2", "1.2.1")   # analyzer.simulation.traffic's gimbals
SERVING = "gimbalscope: serving Foxglove on ws://127.0.0.1:{port} (open it in Foxglove: Open connection → " \
          "Foxglove WebSocket)"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def assert_listenable(port: int) -> None:
    """Nothing listens on ``port``: a new server can, binding as servers do (asyncio's,
    the SDK's) with SO_REUSEADDR, which a listening socket stops and a connection
    the old server closed (TIME_WAIT, on the side that closed first) does not."""
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind(("127.0.0.1", port))
        s.listen()


@contextlib.contextmanager
def two_lines():
    """Two pseudo-terminals: ({"A": master, "B": master}, slave path A, slave path B)."""
    fds = [os.openpty() for _ in "AB"]
    try:
        for _master, slave in fds:
            tty.setraw(slave)
        yield {"A": fds[0][0], "B": fds[1][0]}, os.ttyname(fds[0][1]), os.ttyname(fds[1][1])
    finally:
        for pair in fds:
            for fd in pair:
                os.close(fd)


class Tap(Child):
    """``gimbalscope ARGS`` in a child process, its standard error read as it comes."""

    def __init__(self, *args) -> None:
        super().__init__(*args, stdout=subprocess.DEVNULL)

    def wait_serving(self, port: int) -> None:
        self.wait_said(SERVING.format(port=port) + "\n", "the serving line")


class Client:
    """A Foxglove WebSocket client that subscribes to every channel the server
    advertises, as it advertises it, and keeps what arrives per topic as
    (log time, message bytes)."""

    def __init__(self, ws) -> None:
        self.ws = ws
        self.info = json.loads(ws.recv(timeout=PATIENCE))
        self.topics: dict[int, str] = {}             # channel id -> topic
        self.schemas: dict[str, str] = {}            # topic -> schema name
        self.subscribed: dict[int, str] = {}         # subscription id -> topic
        self.messages: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
        self.statuses: list[dict] = []
        self.bad: list[bytes] = []
        self.refused: list[int] = []                 # channel ids whose subscription was refused
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        try:
            for msg in self.ws:   # until the connection closes
                if isinstance(msg, str):
                    self._control(json.loads(msg))
                else:
                    self._data(msg)
        except ConnectionClosed:   # either end may close it first: the tests say which must
            pass

    def _control(self, msg: dict) -> None:
        if msg["op"] == "advertise":
            for ch in msg["channels"]:
                assert ch["encoding"] == "json" and ch["schemaEncoding"] == "jsonschema"
                self.topics[ch["id"]] = ch["topic"]
                self.schemas[ch["topic"]] = ch["schemaName"]
            self._subscribe([ch["id"] for ch in msg["channels"]])
        elif msg["op"] == "status":
            refused = REFUSED.fullmatch(msg["message"])
            if refused and int(refused[1]) in self.topics:
                # foxglove-sdk 0.30 sends a channel's advertisement before it records
                # the channel for the client (connected_client.rs, advertise_channels):
                # a subscription that comes back quickly enough is refused. Again.
                self.refused.append(int(refused[1]))
                self._subscribe([int(refused[1])])
            self.statuses.append(msg)

    def _subscribe(self, channels: list[int]) -> None:
        subs = [{"id": len(self.subscribed) + k + 1, "channelId": ch} for k, ch in enumerate(channels)]
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
        self.subscribed.update((s["id"], self.topics[s["channelId"]]) for s in subs)

    def _data(self, data: bytes) -> None:
        if data[0] != 0x01 or len(data) < 13:
            self.bad.append(data)
            return
        sub, log_time = struct.unpack_from("<IQ", data, 1)
        self.messages[self.subscribed[sub]].append((log_time, data[13:]))

    def sync(self) -> None:
        """Wait until the server has handled every subscription sent so far. It
        answers requests in turn, and this one (parameters, a capability it lacks)
        always gets an answer; a subscription refused meanwhile was sent again
        before that answer was read, so another round makes sure of it."""
        while True:
            refused, n = len(self.refused), len(self.statuses)
            self.ws.send(json.dumps({"op": "getParameters", "parameterNames": [], "id": "sync"}))
            wait_for(lambda n=n: any(PARAMETERS in m["message"] for m in self.statuses[n:]), "the server's answer")
            if len(self.refused) == refused:
                return

    def events(self) -> list[dict]:
        return [json.loads(m) for _t, m in self.messages["/events"]]


@contextlib.contextmanager
def client(port: int, last_fixed: str = "/events", subprotocol: str = SUBPROTOCOL):
    """A client subscribed to the fixed channels (``last_fixed`` advertised: all of
    them), offering ``subprotocol``."""
    with connect(f"ws://127.0.0.1:{port}", subprotocols=[subprotocol], open_timeout=PATIENCE,
                 max_size=None) as ws:
        assert ws.subprotocol == subprotocol
        c = Client(ws)
        wait_for(lambda: last_fixed in c.schemas, "the fixed channels")
        c.sync()   # subscribed before any traffic
        yield c


def recorded(path) -> dict[str, list[tuple[int, bytes]]]:
    """A recording's messages per topic, in the order written."""
    out: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
    with open(path, "rb") as f:
        for _schema, channel, m in make_reader(f).iter_messages(log_time_order=False):
            out[channel.topic].append((m.log_time, m.data))
    return out


# ------------------------------------------------------------------ traffic
def position_query(dev: tuple[int, int, int], value: str) -> list[tuple[str, bytes]]:
    """P? to ``dev``, its ACK and its report (Table 15), as (line, bytes)."""
    g, p, d = dev
    return [("A", frame(dev, 0, "P?")), ("B", b"\x06"), ("B", frame((0, p, d), g, value))]


def write_paced(fds: dict[str, int], writes, baud: int = 9600) -> None:
    """Each write when its wire time has come (two lines, one clock)."""
    bt = 10 / baud
    start = time.monotonic()
    for w in sorted(writes, key=lambda w: w.t):
        delay = start + w.t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        os.write(fds[w.line], w.data)
        time.sleep(len(w.data) * bt)


def write_exchanges(fds: dict[str, int], parts: list[tuple[str, bytes]]) -> None:
    for line, data in parts:
        os.write(fds[line], data)
        time.sleep(0.02)


# -------------------------------------------------------------------- tests
def test_live_serves_what_it_records(tmp_path):
    with two_lines() as (fds, pa, pb):
        c, tap, rec = serve_a_conversation(tmp_path, fds, pa, pb)
    assert not c.bad
    assert not any("Traceback" in line for line in tap.err), "".join(tap.err)
    got, want = c.messages, recorded(rec)
    # /events: the same messages, byte for byte, in order, at the same log times
    assert len(want["/events"]) > 250
    assert got["/events"] == want["/events"]
    # every gimbal's positions, the first too: the server keeps a new topic's first
    # message until the client, told of the topic by it, has subscribed
    for device in DEVICES:
        topic = f"/gimbal/{device}/position"
        assert c.schemas[topic] == "gimbalscope.Position"
        assert got[topic] == want[topic], (topic, len(got[topic]), len(want[topic]))
    # the other topics as far as they came before the tap stopped (what it says as it
    # stops, such as its last transaction, may not reach the client)
    for topic in ("/serial/A/raw", "/serial/B/raw", "/transactions", "/log"):
        assert got[topic] and got[topic] == want[topic][:len(got[topic])], topic
    assert c.schemas["/log"] == "foxglove.Log" and c.schemas["/events"] == "gimbalscope.Event"


def serve_a_conversation(tmp_path, fds, pa, pb):
    """``live --record --foxglove`` on the two lines, a client subscribed to
    everything before any traffic, a conversation, the tap stopped once the client
    has its last event: (client, tap, recording)."""
    port = free_port()
    rec = tmp_path / "rec.mcap"
    tap = Tap("live", pa, pb, "--no-tui", "--record", rec, "--foxglove", f"127.0.0.1:{port}")
    try:
        tap.wait_serving(port)
        with client(port) as c:
            assert c.info["op"] == "serverInfo" and c.info["name"] == "gimbalscope"
            assert {"/serial/A/raw", "/serial/B/raw", "/events", "/transactions", "/log"} <= set(c.schemas)
            # each gimbal reports once: its position topic appears, and the client subscribes to it
            devices = [tuple(map(int, d.split("."))) for d in DEVICES]
            write_exchanges(fds, [x for dev in devices for x in position_query(dev, "0FA0FC18")])
            topics = {f"/gimbal/{d}/position" for d in DEVICES}
            wait_for(lambda: topics <= set(c.subscribed.values()), "the position topics")
            c.sync()
            # a conversation of every kind of command, then a last report to know when it has all come
            write_paced(fds, generate(120, seed=7, bit_error_rate=0.02, drop_ack_rate=0.02, noise_rate=0.02).writes)
            last = position_query((1, 1, 1), "7FFF0123")
            write_exchanges(fds, last)
            # the last report's position (0x7FFF, 0x0123 in bits) is in no other result
            wait_for(lambda: any(e["kind"] == "result" and e["payload"].endswith("7FFF0123")
                                 for e in c.events()), "the last report")
            assert tap.stop()[0] == 0, "".join(tap.err)
    finally:
        tap.stop()
    return c, tap, rec


def test_a_busy_port_is_one_line_before_the_tap_starts(tmp_path):
    with two_lines() as (_fds, pa, pb), socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        out = run_cli("live", pa, pb, "--no-tui", "--record", tmp_path / "rec.mcap",
                      "--foxglove", f"127.0.0.1:{port}", timeout=PATIENCE)
    assert out.returncode == 2
    assert out.stderr.splitlines() == [(f"gimbalscope: error: --foxglove 127.0.0.1:{port}: cannot serve: "
                                        "address already in use")]
    assert out.stdout == "" and not (tmp_path / "rec.mcap").exists()


def test_a_bad_address_is_a_usage_error():
    for value in ("x:y", "host:", "99999"):
        out = run_cli("demo", "--no-tui", "--foxglove", value, timeout=PATIENCE)
        assert out.returncode == 2, value
        lines = out.stderr.splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"gimbalscope: error: argument --foxglove: '{value}': "), \
            out.stderr
    # a port's name is an input, said as such (test_an_input_taken_as_the_address_is_said_as_such)
    out = run_cli("demo", "--no-tui", "--foxglove", "/dev/ttyUSB0", timeout=PATIENCE)
    assert out.returncode == 2 and "'/dev/ttyUSB0' was taken as the server's address" in out.stderr


def test_an_input_taken_as_the_address_is_said_as_such(tmp_path):
    """`replay --foxglove demo.mcap`: the optional address takes the file; the error
    says so and how to write it, not only that FILE.mcap is missing."""
    rec = tmp_path / "demo.mcap"
    rec.write_bytes(b"")
    for value in (str(rec), "demo.mcap", "tap.log"):
        out = run_cli("replay", "--foxglove", value, timeout=PATIENCE)
        assert out.returncode == 2, value
        lines = out.stderr.splitlines()
        assert lines == [(f"gimbalscope: error: argument --foxglove: '{value}' was taken as the server's address, "
                          f"and looks like an input: give --foxglove after the inputs ({value} --foxglove), or its "
                          f"address as --foxglove=HOST:PORT (see: gimbalscope replay --help)")], out.stderr


def test_demo_serves():
    port = free_port()
    tap = Tap("demo", "--seconds", "0", "--no-tui", "--foxglove", str(port))   # PORT alone: this machine
    try:
        tap.wait_serving(port)
        with client(port) as c:
            wait_for(lambda: len(c.messages["/events"]) >= 20 and any(t.startswith("/gimbal/") and m
                                                                       for t, m in c.messages.items()),
                     "events and positions")
    finally:
        assert tap.stop()[0] == 0, "".join(tap.err)
    events = c.events()
    assert [e["number"] for e in events] == list(range(events[0]["number"], events[-1]["number"] + 1))
    assert c.messages["/serial/A/raw"] and c.messages["/serial/B/raw"]


def test_replay_serves_at_its_pace(tmp_path):
    rec = tmp_path / "demo.mcap"
    assert run_cli("convert", SOCAT_LOG, "-o", rec).returncode == 0
    port = free_port()
    tap = Tap("replay", rec, "--speed", "2", "--no-tui", "--foxglove", f"127.0.0.1:{port}")
    try:
        tap.wait_serving(port)
        with client(port) as c:
            wait_for(lambda: tap.proc.poll() is not None, "the end of the replay")
    finally:
        assert tap.stop()[0] == 0, "".join(tap.err)
    # what came is a run of what the recording holds (the replay started as the client connected)
    got, want = [m for _t, m in c.messages["/events"]], [m for _t, m in recorded(rec)["/events"]]
    assert len(got) > 100
    first = want.index(got[0])
    assert got == want[first:first + len(got)]


def test_the_tui_serves_a_replay_at_its_pace(tmp_path):
    """A replay in the TUI reads its file flat out; the server paces what it sends."""
    rec = tmp_path / "demo.mcap"
    assert run_cli("convert", SOCAT_LOG, "-o", rec).returncode == 0
    want = recorded(rec)["/events"]
    capture = analyzer.open(str(rec))
    info = CaptureInfo.of(capture, command="replay")
    port = free_port()
    server = FoxgloveServer(info, "127.0.0.1", port, speed=4)
    app = make_app(capture, mode="replay", speed=4, info=info, listeners=[server])

    async def drive(c):
        async with app.run_test(size=(120, 40)) as pilot:
            end = time.monotonic() + PATIENCE
            while len(c.messages["/events"]) < len(want):
                assert time.monotonic() < end, "gave up waiting for the replay"
                await pilot.pause(0.05)
            assert server.announcement in app.messages
        stop_feed(app, [server])

    with client(port) as c:   # subscribed before the replay starts: it gets every event
        asyncio.run(drive(c))
    assert c.messages["/events"] == want
    assert_listenable(port)   # stopped with the screen


def test_the_server_listens_only_while_it_serves():
    """The port is free again once the tap has stopped."""
    port = free_port()
    tap = Tap("demo", "--seconds", "0", "--no-tui", "--foxglove", f"127.0.0.1:{port}")
    tap.wait_serving(port)
    assert tap.stop()[0] == 0, "".join(tap.err)
    assert_listenable(port)



def test_a_lean_tap_serves_the_lean_topics(tmp_path):
    """``live --record --lean --foxglove``: the server advertises the lean profile's
    topics, those of the recording, with its schemas; the same positions and
    transactions, and the same reads, batched as the server's flushes fall."""
    port = free_port()
    rec = tmp_path / "rec.mcap"
    new_gimbal = (1, 2, 2)   # not in the generated traffic: its topic's arrival says the last report came
    with two_lines() as (fds, pa, pb):
        tap = Tap("live", pa, pb, "--no-tui", "--record", rec, "--lean", "--foxglove", f"127.0.0.1:{port}")
        try:
            tap.wait_serving(port)
            with client(port, last_fixed=S.LOG_TOPIC) as c:
                assert set(c.schemas) == {S.READS_TOPIC, S.TRANSACTIONS_TOPIC, S.LOG_TOPIC}
                write_paced(fds, generate(60, seed=3, bit_error_rate=0.02, noise_rate=0.02).writes)
                write_exchanges(fds, position_query(new_gimbal, "7FFF0123"))
                wait_for(lambda: c.messages["/gimbal/1.2.2/position"], "the last report")
                assert tap.stop()[0] == 0, "".join(tap.err)
        finally:
            tap.stop()
    assert not c.bad and not any("Traceback" in line for line in tap.err), "".join(tap.err)
    with open(rec, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    schemas = {ch.topic: summary.schemas[ch.schema_id].name for ch in summary.channels.values()}
    assert c.schemas == schemas and S.EVENTS_TOPIC not in schemas
    want = recorded(rec)
    for topic in (*(f"/gimbal/{d}/position" for d in DEVICES), "/gimbal/1.2.2/position"):
        assert c.messages[topic] == want[topic], topic
    # what the tap said as it stopped (its last transaction, reads and notes) may not
    # have come; every read did, but for those, in the recording's order
    for topic in (S.TRANSACTIONS_TOPIC, S.LOG_TOPIC):
        got = c.messages[topic]
        assert got and got == want[topic][:len(got)], topic
    got_reads, want_reads = reads(c.messages[S.READS_TOPIC]), reads(want[S.READS_TOPIC])
    assert len(got_reads) >= 10 and got_reads == want_reads[:len(got_reads)]   # (a busy tap reads more at once)


def reads(messages: list[tuple[int, bytes]]) -> list[dict]:
    """The reads of /serial/reads messages, in order."""
    return [read for _t, m in messages for read in json.loads(m)["reads"]]
