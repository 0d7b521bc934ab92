"""The ``--foxglove`` server's front door: Foxglove clients of every age
(docs/foxglove.md, "Clients of every age").

foxglove-sdk's WebSocket server accepts only the subprotocol ``foxglove.sdk.v1``
and answers HTTP 400 to a client offering only ``foxglove.websocket.v1``: the same
protocol under its former name, which older Lichtblick releases, PlotJuggler and
everything built on ``@foxglove/ws-protocol`` offer. The SDK has no setting for
it, so the front listens on the user's address instead, and the SDK's server on
127.0.0.1 only, on a port of the system's choosing.

The front is a TCP relay that renames the subprotocol in the opening handshake
and then passes bytes unchanged, both ways, until either side closes:

- a client's upgrade request offering the former name (and not the new one) is
  passed on offering ``foxglove.sdk.v1``, and the SDK's answer is passed back
  naming the former name again. ``Sec-WebSocket-Accept`` depends only on the
  client's key, which is untouched, so the client's check of it holds; any other
  request (the new name, or neither: the SDK's 400) passes unchanged;
- after the handshake, WebSocket frames are the same bytes whichever name was
  agreed (a client's frames are masked by the client, and the SDK unmasks them;
  compression and pings are whatever the two ends agreed), so they are relayed as
  bytes, not decoded and encoded again: a relay of messages cost a third of a
  core's share more at two saturated lines (bench/foxglove_bench.py).

Memory stays bounded with a slow client: each direction reads at most
``CHUNK`` bytes and waits until the other side has taken them (``drain``), so the
SDK's server sees a slow client as it would without the front, and drops its
oldest messages beyond its backlog (analyzer/listeners/foxglove.py, ``BACKLOG``).

One thread runs the front's event loop; ``stop`` waits for every relay to end
(each passes the server's goodbye on, then is cut after ``GOODBYE_SECONDS``) and
for the thread. A client that leaves, even in the middle of a message, only ends its relay.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import re
import threading

SDK_SUBPROTOCOL = "foxglove.sdk.v1"         # what foxglove-sdk's server accepts
OLD_SUBPROTOCOL = "foxglove.websocket.v1"   # the same protocol's former name

# what it says (a client the SDK's server did not take): the listener tells these
# as the tap's notes
LOGGER = logging.getLogger(__name__)

CHUNK = 1 << 16          # bytes read from one side before they are sent on to the other
HEAD_LIMIT = 1 << 14     # an HTTP head longer than this is not a WebSocket handshake
HEAD_END = b"\r\n\r\n"
GOODBYE_SECONDS = 1.0    # on stop: what the relays are given to pass the server's goodbye on and end
_PROTOCOL_HEADER = re.compile(rb"^(sec-websocket-protocol[ \t]*:[ \t]*)([^\r\n]*)", re.IGNORECASE | re.MULTILINE)


def renamed_request(head: bytes) -> tuple[bytes, bool]:
    """A client's upgrade request with the former name offered as the new one
    (the request, and whether it was renamed)."""
    m = _PROTOCOL_HEADER.search(head)
    if m is None:
        return head, False
    offered = [p.strip() for p in m.group(2).split(b",")]
    if SDK_SUBPROTOCOL.encode() in offered or OLD_SUBPROTOCOL.encode() not in offered:
        return head, False
    return head[:m.start(2)] + SDK_SUBPROTOCOL.encode() + head[m.end(2):], True


def renamed_answer(head: bytes) -> bytes:
    """The SDK's answer, naming the former subprotocol the client asked for."""
    m = _PROTOCOL_HEADER.search(head)
    if m is None or m.group(2).strip() != SDK_SUBPROTOCOL.encode():
        return head
    return head[:m.start(2)] + OLD_SUBPROTOCOL.encode() + head[m.end(2):]


class Front:
    """Serves ``host:port`` (port 0: any free port, then ``port`` says which) to
    clients offering either subprotocol name, relaying each to the SDK's server
    on 127.0.0.1:``sdk_port``. An address that cannot be served raises the
    ``OSError`` of binding it, with no thread left running."""

    def __init__(self, host: str, port: int, sdk_port: int) -> None:
        self._sdk_port = sdk_port
        self._listening: concurrent.futures.Future[int] = concurrent.futures.Future()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Event | None = None
        self._relays: set[asyncio.Task] = set()
        self._open: set[asyncio.StreamWriter] = set()   # both ends of every relay, closed on stop
        self._thread = threading.Thread(target=asyncio.run, args=(self._serve(host, port),),
                                        name="foxglove-front", daemon=True)
        self._thread.start()
        try:
            self.port = self._listening.result()
        except BaseException:
            self._thread.join()
            raise

    def stop(self) -> None:
        """Close every client's relay and stop listening; returns once the thread
        has ended (again: nothing)."""
        loop, stopping = self._loop, self._stopping
        if loop is not None and stopping is not None and self._thread.is_alive():
            try:
                loop.call_soon_threadsafe(stopping.set)
            except RuntimeError:   # the loop closed meanwhile: the thread is ending
                pass
        self._thread.join()

    async def _serve(self, host: str, port: int) -> None:
        self._loop = asyncio.get_running_loop()
        self._stopping = stopping = asyncio.Event()
        try:
            server = await asyncio.start_server(self._accept, host, port, limit=HEAD_LIMIT)
        except Exception as e:   # noqa: BLE001 - any of them: __init__ raises it, in the caller's thread
            self._listening.set_exception(e)
            return
        self._listening.set_result(server.sockets[0].getsockname()[1])
        async with server:
            await stopping.wait()
            server.close()
            # The SDK's server stops first and says goodbye to each relay, which
            # passes it on and ends by itself: give them that long. Then what is left
            # is cut (aborted: a client that stopped reading would hold a graceful
            # close forever, and the tap's exit with it). Cut sockets end each relay's
            # reads, so every relay still ends by itself (a cancelled connection
            # callback would be logged as an error).
            if self._relays:
                await asyncio.wait(set(self._relays), timeout=GOODBYE_SECONDS)
            for end in list(self._open):
                end.transport.abort()
            await asyncio.gather(*self._relays, return_exceptions=True)

    async def _accept(self, client_in: asyncio.StreamReader, client_out: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        self._relays.add(task)
        self._open.add(client_out)
        try:
            await self._relay(client_in, client_out)
        except (ConnectionError, asyncio.IncompleteReadError, asyncio.LimitOverrunError):
            pass   # a client gone mid-handshake, or no WebSocket client at all: its relay ends
        finally:
            self._relays.discard(task)
            self._open.discard(client_out)
            client_out.close()

    async def _relay(self, client_in: asyncio.StreamReader, client_out: asyncio.StreamWriter) -> None:
        """One client's connection: the handshake renamed if need be, then bytes both ways."""
        request, renamed = renamed_request(await client_in.readuntil(HEAD_END))
        try:
            sdk_in, sdk_out = await asyncio.open_connection("127.0.0.1", self._sdk_port, limit=HEAD_LIMIT)
        except OSError as e:
            LOGGER.warning("a client was turned away: the server did not take its connection (%s)", e)
            client_out.write(b"HTTP/1.1 503 Service Unavailable\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")
            return
        self._open.add(sdk_out)
        try:
            sdk_out.write(request)
            answer = await sdk_in.readuntil(HEAD_END)
            client_out.write(renamed_answer(answer) if renamed else answer)
            await asyncio.gather(_pipe(client_in, sdk_out), _pipe(sdk_in, client_out))
        finally:
            self._open.discard(sdk_out)
            sdk_out.close()


async def _pipe(source: asyncio.StreamReader, sink: asyncio.StreamWriter) -> None:
    """Bytes from ``source`` to ``sink`` as they come, ``sink`` taking each chunk
    before the next is read, until ``source`` ends; then ``sink`` is closed, which
    ends the other direction too."""
    try:
        while data := await source.read(CHUNK):
            sink.write(data)
            await sink.drain()
    except ConnectionError:
        pass
    finally:
        sink.close()
