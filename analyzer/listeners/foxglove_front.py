"""The ``--foxglove`` server's front door: Foxglove clients of every age
(docs/foxglove.md, "Clients of every age").

foxglove-sdk's WebSocket server accepts only the subprotocol ``foxglove.sdk.v1``
and answers HTTP 400 to a client offering only ``foxglove.websocket.v1``: the same
protocol under its former name, which older Lichtblick releases, PlotJuggler and
everything built on ``@foxglove/ws-protocol`` offer. The SDK has no setting for
it, so the front listens on the user's address instead, accepts either name
(answering with the one the client offered; the new one when it offers both, and
HTTP 400 when it offers neither, as the SDK does), and relays each client over a
connection of its own to the SDK's server, which listens on 127.0.0.1 only, on a
port of the system's choosing. Every message goes on unchanged, text or binary,
both ways; either side closing closes the other, with its close code. The front
adds nothing else: no compression, no pings of its own.

Memory stays bounded with a slow client: the relay forwards one message at a
time and waits while more than ``WRITE_LIMIT`` bytes wait for the client; meanwhile
it holds at most ``MAX_QUEUE`` messages read from the SDK (and what one read of
the socket brings) before it stops reading there. The SDK's server then queues
for it as for any slow client, dropping the oldest beyond its backlog
(analyzer/listeners/foxglove.py, ``BACKLOG``).

One thread runs the front's event loop; ``stop`` ends it and waits for it. A
client that leaves, even in the middle of a message, only ends its relay.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import threading

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed, InvalidHandshake
from websockets.frames import EXTERNAL_CLOSE_CODES, CloseCode
from websockets.typing import Subprotocol

SDK_SUBPROTOCOL = Subprotocol("foxglove.sdk.v1")         # what foxglove-sdk's server accepts
OLD_SUBPROTOCOL = Subprotocol("foxglove.websocket.v1")   # the same protocol's former name
SUBPROTOCOLS = [SDK_SUBPROTOCOL, OLD_SUBPROTOCOL]       # the first one a client offers is chosen

# what it says (a client the SDK's server did not take, and websockets' own
# errors): the listener tells these as the tap's notes
LOGGER = logging.getLogger(__name__)

MAX_QUEUE = 16           # messages read from one side and not yet sent on to the other
WRITE_LIMIT = 1 << 16    # bytes waiting to be sent to one side before the relay waits
CLOSE_TIMEOUT = 2.0      # seconds for a peer to answer a close: a stop waits at most about that


class Front:
    """Serves ``host:port`` (port 0: any free port, then ``port`` says which) to
    clients offering either subprotocol name, relaying each to the SDK's server
    on 127.0.0.1:``sdk_port``. An address that cannot be served raises the
    ``OSError`` of binding it, with no thread left running."""

    def __init__(self, host: str, port: int, sdk_port: int) -> None:
        self._sdk_url = f"ws://127.0.0.1:{sdk_port}"
        self._listening: concurrent.futures.Future[int] = concurrent.futures.Future()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Event | None = None
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
            # no pings of its own on either leg: a client is served as the SDK serves
            # it (a ping would time out whenever a slow client is behind on its reading)
            server = await serve(self._relay, host, port, subprotocols=SUBPROTOCOLS, compression=None,
                                 ping_interval=None, max_queue=MAX_QUEUE, write_limit=WRITE_LIMIT,
                                 close_timeout=CLOSE_TIMEOUT, logger=LOGGER)
        except Exception as e:   # noqa: BLE001 - any of them: __init__ raises it, in the caller's thread
            self._listening.set_exception(e)
            return
        self._listening.set_result(server.sockets[0].getsockname()[1])
        async with server:   # on leaving: clients closed (going away), relays ended
            await stopping.wait()

    async def _relay(self, client: ServerConnection) -> None:
        """One client's connection, relayed to the SDK's server until either closes."""
        try:
            sdk = await connect(self._sdk_url, subprotocols=[SDK_SUBPROTOCOL], compression=None, proxy=None,
                                ping_interval=None, max_size=None, max_queue=MAX_QUEUE, write_limit=WRITE_LIMIT,
                                close_timeout=CLOSE_TIMEOUT, logger=LOGGER)
        except (OSError, InvalidHandshake, TimeoutError) as e:
            LOGGER.warning("a client was turned away: the server did not take its connection (%s)", e)
            await client.close(CloseCode.TRY_AGAIN_LATER, "server unavailable")
            return
        async with sdk:
            await _both_ways(client, sdk)


async def _both_ways(client: ServerConnection, sdk: ClientConnection) -> None:
    """Relay until one side closes, then close the other with its code."""
    pipes = {asyncio.create_task(_pipe(client, sdk)), asyncio.create_task(_pipe(sdk, client))}
    _done, pending = await asyncio.wait(pipes, return_when=asyncio.FIRST_COMPLETED)
    for pipe in pending:
        pipe.cancel()
    await asyncio.gather(*pending, return_exceptions=True)
    closed, other = (client, sdk) if client.close_code is not None else (sdk, client)
    code = closed.close_code
    if code in EXTERNAL_CLOSE_CODES or (code is not None and 3000 <= code < 5000):
        await other.close(code, closed.close_reason or "")
    else:   # none given (1005) or the connection broke (1006): the peer went away
        await other.close(CloseCode.GOING_AWAY)


async def _pipe(source: ServerConnection | ClientConnection, sink: ServerConnection | ClientConnection) -> None:
    """Each message of ``source`` to ``sink`` as it came (str: a text frame, bytes:
    binary), one at a time: ``send`` waits while ``sink`` is behind."""
    try:
        async for message in source:
            await sink.send(message)
    except ConnectionClosed:   # either side, normally or not: the caller closes the other
        pass
