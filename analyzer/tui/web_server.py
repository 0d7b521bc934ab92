"""The TUI in a browser: Textual's web server (textual-serve) running one session
of a gimbalscope command a browser tab (``gimbalscope serve``, docs/tui.md,
"In a browser").

Three things differ from textual-serve's own server:

- **Links follow the address the browser used.** The page tells the browser where
  its WebSocket and static files are; textual-serve writes them from the address
  it was bound to, which breaks behind an SSH tunnel to another local port and for
  a server bound to every interface (``ws://0.0.0.0:…``). Here they are made from
  the request's own host, unless a public URL is given.
- **Its banner and log are replaced by one line** saying where to browse, as the
  Foxglove server says it (``show_address``), and a session that failed to start
  has its error line told on standard error, naming the session.
- **The socket is bound before serving**, so a busy port or a host that is not
  this machine's is one line and a non-zero exit (``ServeError``) rather than
  aiohttp's traceback.
"""

from __future__ import annotations

import asyncio
import socket
import sys
from typing import Any

from aiohttp import web
from textual_serve.server import Server

from ..errors import ServeError
from ..netaddress import show_address

SHUTDOWN_SECONDS = 1.0   # Ctrl-C: what an open tab's session is given to end before it is cancelled


def bind(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host``:``port``, or a ``ServeError`` saying why not."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror:
        raise ServeError(f"{show_address(host, port)}: cannot serve: unknown host") from None
    family, kind, proto, _name, address = infos[0]
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(64)
    except OSError as e:
        sock.close()
        raise ServeError(f"{show_address(host, port)}: cannot serve: {(e.strerror or str(e)).lower()}") from None
    return sock


class TuiWebServer(Server):
    """textual-serve's server, serving ``command`` (a shell command line) one
    session a browser tab, on a socket bound already (``bind``)."""

    def __init__(self, command: str, sock: socket.socket, *, title: str, public_url: str | None = None,
                 one_at_a_time: str | None = None) -> None:
        host, port = sock.getsockname()[:2]
        super().__init__(command, host=host, port=port, title=title, public_url=public_url)
        self.sock = sock
        self.fixed_url = public_url is not None
        # what a session holds that a second cannot share (a port, a file), or None
        self.one_at_a_time = one_at_a_time
        self.sessions = 0

    def initialize_logging(self) -> None:
        """None: what a user needs to know is said in our own lines."""

    async def on_startup(self, app: web.Application) -> None:
        """Nothing: the command said where it serves before serving."""

    async def handle_index(self, request: web.Request) -> Any:
        # The page's WebSocket and static addresses as the browser reached us: an
        # SSH tunnel's local port, or this machine's LAN address.
        if not self.fixed_url:
            self.public_url = f"{request.scheme}://{request.host}"
        return await super().handle_index(request)

    async def handle_websocket(self, request: web.Request) -> web.WebSocketResponse:
        if self.one_at_a_time and self.sessions:
            return await self._refuse(request)
        self.sessions += 1
        try:
            return await super().handle_websocket(request)
        finally:
            self.sessions -= 1

    async def _refuse(self, request: web.Request) -> web.WebSocketResponse:
        """A tab beyond the one session: told why on its screen, which stays until the tab goes."""
        websocket = web.WebSocketResponse(heartbeat=15)
        await websocket.prepare(request)
        text = (f"gimbalscope: {self.one_at_a_time} is open in another tab, and only one session at a "
                "time can hold it.\r\nClose that tab, then reload this page.\r\n")
        await websocket.send_bytes(b"\x1b[2J\x1b[H" + text.encode())
        print(f"gimbalscope: a second tab asked for {self.one_at_a_time}: refused (one session at a time)",
              file=sys.stderr, flush=True)
        async for _message in websocket:   # until the tab closes
            pass
        return websocket

    def serve(self, debug: bool = False) -> None:
        """Serve until SIGINT or SIGTERM (then every session's process is told to quit)."""
        self.debug = debug
        loop = asyncio.new_event_loop()
        asyncio.set_event_loop(loop)
        for stop in (2, 15):   # SIGINT, SIGTERM
            loop.add_signal_handler(stop, self.request_exit)
        # open tabs hold their handlers until they close: on a stop, each is given
        # SHUTDOWN_SECONDS, then cancelled, which quits its session (aiohttp waits a minute)
        web.run_app(self._make_app(), sock=self.sock, handle_signals=False, loop=loop,
                    shutdown_timeout=SHUTDOWN_SECONDS,
                    print=lambda *_args: None)
        sys.stdout.flush()
