"""Serving a tap live to the Foxglove app over its WebSocket protocol (``--foxglove``
of ``live``, ``demo`` and ``replay``).

The app connects (Open connection → Foxglove WebSocket, ``ws://HOST:PORT``) and
sees the topics a recording has, with the same messages and log times: both are
built by ``Messages`` (analyzer/formats/mcap_messages.py) from the runner's callbacks,
mapped as the MCAP recording maps them (``message_clock``, ``log_level`` in
analyzer/writers/mcap.py).

The server is foxglove-sdk's: it runs in threads of its own and sends to each
client what it subscribed to. It listens on 127.0.0.1 only, behind a front on the
address given (analyzer/listeners/foxglove_front.py), which takes clients offering
the protocol's former name as well as the SDK's, and relays them. This listener
builds the messages and logs them, serialised, on the server's channels; a
message no client subscribed to is not serialised, except the first message of a
topic made mid-run (a gimbal's positions): it is kept until a client, told of the
topic, has subscribed. Each server has a context of its own, so two servers in
one process (tests) never share channels.

Messages are logged in bursts, at most every ``FLUSH_SECONDS``: the SDK wakes its
threads for every log call, and one wake-up per burst instead of per message cut
its threads' share of a core from about 10% to about 1% at two saturated
115200-baud lines (bench/foxglove_bench.py). Log times are the messages' own, so
a burst changes only when they arrive.

The server starts when the listener is made, before the tap reads anything: an
address that cannot be served is an error before the tap starts (``ServeError``).
It stops when the run ends, or when ``close()`` is called from another thread.

With ``lean`` (``live --lean``: the tap records lean recordings) it serves the lean
profile's topics, those of the recording (``fixed_topics``), with its batches of
reads: a batch goes out when full, or at the latest as a live recording would
flush it (``FLUSH_INTERVAL``).

A replay in the TUI reads its file flat out (the screen paces itself): there the
listener paces the events itself (``speed``), or a client would get the whole
recording at once, before it could subscribe.
"""

from __future__ import annotations

import logging
import os
import re
import socket
import threading
import time

import foxglove
from foxglove.websocket import WebSocketServer

from dissectors.event import Event

from ..errors import ServeError
from ..formats import mcap_schemas as S
from ..formats.mcap_messages import Messages, fixed_topics
from ..info import CaptureInfo
from ..netaddress import LOCAL_HOST, show_address
from ..output import dumps
from ..runner import INFO, RECORDING, WARNING, Listener, Note, TapRunner
from ..sources import Chunk
from ..writers.mcap import FLUSH_INTERVAL, log_level, message_clock
from . import foxglove_front

DEFAULT_PORT = 8765
NAME = "gimbalscope"

# Messages a client may fall behind by before the server drops its oldest (the
# SDK's default is 1024): a saturated pair of lines makes several thousand a second,
# and a client that stalls for a moment should not lose them.
BACKLOG = 16384

FLUSH_SECONDS = 0.03   # a burst's span: well under what a person sees as lag

# The SDK and the front log through Python's logging; with no handler configured
# their lines would land raw on standard error, over the TUI. They are told as
# notes instead.
LOGGERS = ("foxglove", foxglove_front.LOGGER.name)


class FoxgloveServer(Listener):
    """Serves the run ``info`` describes on ``host:port`` (port 0: any free port);
    with ``speed``, events go out at their recorded pace, ``speed`` times faster;
    with ``lean``, the lean profile's topics (module doc)."""

    def __init__(self, info: CaptureInfo, host: str = LOCAL_HOST, port: int = DEFAULT_PORT, *,
                 speed: float | None = None, lean: bool = False) -> None:
        self.info = info
        self._closing = threading.Lock()
        self._closed = threading.Event()   # ends a paced wait
        self._speed = speed or None
        self._started = time.monotonic()
        self._context = foxglove.Context()
        server = _start(self._context, host, port)
        try:
            front = _front(host, port, server.port)
        except BaseException:
            server.stop()
            raise
        self._server: WebSocketServer | None = server   # None once closed
        self._front: foxglove_front.Front | None = front
        self.address = show_address(host, front.port)
        self._channels: dict[str, foxglove.Channel] = {}
        for topic, key, metadata in fixed_topics(info.lines, lean):
            self._channel(topic, key, metadata)
        self._messages = Messages(self._emit, **message_clock(info), lean=lean)
        self._reads_due = time.monotonic() + FLUSH_INTERVAL if lean else None
        self._burst: list[tuple[foxglove.Channel, bytes, int]] = []
        # the first message of a topic made mid-run (a gimbal's positions), kept until a
        # client has subscribed: clients hear of the topic with it, and subscribe after
        self._first: dict[str, tuple[bytes, int]] = {}
        self._due = time.monotonic() + FLUSH_SECONDS
        self._runner: TapRunner | None = None
        self._notes: _ServerNotes | None = None

    @property
    def url(self) -> str:
        return f"ws://{self.address}"

    @property
    def announcement(self) -> str:
        """What the tap says once when it starts serving."""
        return f"serving Foxglove on {self.url} (open it in Foxglove: Open connection → Foxglove WebSocket)"

    def close(self) -> None:
        """Stop serving (again: nothing); from any thread (the TUI quitting ends a
        paced wait with it)."""
        self._closed.set()
        with self._closing:
            server, self._server = self._server, None
            front, self._front = self._front, None
            notes, self._notes = self._notes, None
        # the server first: it says goodbye to its clients (going away, 1001), which
        # the front passes on as it passes everything; then the front's relays end
        if server is not None:
            server.stop()
        if front is not None:
            front.stop()
        if notes is not None:
            for name in LOGGERS:
                logging.getLogger(name).removeHandler(notes)

    # ------------------------------------------------------------ listener
    def on_start(self, runner: TapRunner) -> None:
        self._runner = runner
        self._started = time.monotonic()
        self._notes = _ServerNotes(runner)
        for name in LOGGERS:
            logging.getLogger(name).addHandler(self._notes)
        # an output's word about itself: not a message of the topics (writers/mcap.py, log_level)
        runner.post(self.announcement, INFO, origin=RECORDING)

    def on_chunk(self, chunk: Chunk, offset: int) -> None:
        self._messages.raw(chunk, offset)

    def on_events(self, events: list[Event]) -> None:
        event, speed = self._messages.event, self._speed
        for ev in events:
            if speed is not None:
                self._wait_for(ev, speed)
            event(ev)
        # a live tap's idle ticks come here too; a paced replay's last events must not
        # wait for a next step that may not come until the screen closes, nor a new
        # topic's first message for a next message once a client has subscribed
        now = time.monotonic()
        if self._reads_due is not None and now >= self._reads_due:   # lean: as a live recording flushes
            self._messages.flush_reads()
            self._reads_due = now + FLUSH_INTERVAL
        if (self._burst or self._first) and (speed is not None or now >= self._due):
            self._flush()

    def on_note(self, note: Note) -> None:
        level = log_level(note)
        if level is not None:
            self._messages.note(note.text, note.t, level)

    def on_stop(self) -> None:
        try:
            runner = self._runner
            if runner is not None and runner.live:   # as a live recording ends (McapWriter.on_stop)
                self._messages.end_marker(runner.latest, self.info.lines[0])
            self._messages.finish()
            self._flush()
        finally:
            self.close()

    def _wait_for(self, ev: Event, speed: float) -> None:
        """Until ``ev``'s recorded time, ``speed`` times faster; what is due goes out first."""
        if ev.t is None:
            return
        delay = self._started + ev.t / speed - time.monotonic()
        if delay > 0:
            self._flush()
            self._closed.wait(delay)

    # ------------------------------------------------------------ channels
    def _channel(self, topic: str, key: str, metadata: dict[str, str] | None = None) -> foxglove.Channel:
        schema = S.ALL_SCHEMAS[key]
        channel = self._channels[topic] = foxglove.Channel(
            topic, schema=foxglove.Schema(name=schema["title"], encoding="jsonschema", data=S.encoded_by_key(key)),
            message_encoding="json", context=self._context, metadata=metadata or None)
        return channel

    def _emit(self, topic: str, key: str, ts: int, msg: dict) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            self._channel(topic, key)
            self._first[topic] = (dumps(msg), ts)
            return
        if channel.has_sinks():   # no client subscribed: not worth serialising
            if self._first:
                self._send_first()
            self._burst.append((channel, dumps(msg), ts))

    def _send_first(self) -> None:
        """The kept first messages of the topics a client now subscribes to."""
        for topic in list(self._first):
            channel = self._channels[topic]
            if channel.has_sinks():
                data, ts = self._first.pop(topic)
                self._burst.append((channel, data, ts))

    def _flush(self) -> None:
        if self._first:
            self._send_first()
        burst, self._burst = self._burst, []
        for channel, data, ts in burst:
            channel.log(data, log_time=ts)
        self._due = time.monotonic() + FLUSH_SECONDS


def _start(context: foxglove.Context, host: str, port: int) -> WebSocketServer:
    """The SDK's server, on 127.0.0.1 at a port of the system's choosing: only the
    front (``_front``) connects to it. ``host:port``, the address served, names the
    failure."""
    try:
        return foxglove.start_server(name=NAME, host="127.0.0.1", port=0, context=context,
                                     message_backlog_size=BACKLOG)
    except (RuntimeError, ValueError, OSError) as e:
        raise ServeError(f"{show_address(host, port)}: cannot serve: the server did not start: {_reason(e)}") \
            from None


def _front(host: str, port: int, sdk_port: int) -> foxglove_front.Front:
    """The front on the address served, for the SDK's server on ``sdk_port``."""
    try:
        return foxglove_front.Front(host, port, sdk_port)
    except (OSError, ValueError) as e:
        raise ServeError(f"{show_address(host, port)}: cannot serve: {_reason(e)}") from None


def _reason(e: BaseException) -> str:
    """A few words from binding's error or the SDK's: 'FoxgloveError: Failed to bind
    port: Address already in use (os error 98)' is 'address already in use'."""
    if isinstance(e, socket.gaierror):
        return "unknown host"
    if isinstance(e, OSError) and e.errno:
        return os.strerror(e.errno).lower()
    text = str(e)
    code = re.search(r"\(os error (\d+)\)", text)
    if code:
        return os.strerror(int(code.group(1))).lower()
    if "lookup address" in text:
        return "unknown host"
    for prefix in ("FoxgloveError: ", "Failed to bind port: "):
        text = text.removeprefix(prefix)
    return text[:1].lower() + text[1:]


class _ServerNotes(logging.Handler):
    """The SDK's and the front's warnings and errors (a client gone without
    closing) as the tap's notes: one line each."""

    def __init__(self, runner: TapRunner) -> None:
        super().__init__(logging.WARNING)
        self.runner = runner

    def emit(self, record: logging.LogRecord) -> None:
        # from the server's threads: post queues it for the runner's
        self.runner.post(f"Foxglove: {record.getMessage()}", WARNING, origin=RECORDING)
