"""The ``--foxglove`` server's front (analyzer/listeners/foxglove_front.py): it takes
either subprotocol name, serves on while clients leave in any state, and stops
with the server, its clients' connections closed and its thread ended.
(Clients of both ages getting the same messages: tests/interop/test_foxglove_clients.py.)
"""

from __future__ import annotations

import base64
import os
import socket
import struct
import threading

import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

import analyzer
from analyzer.info import CaptureInfo
from analyzer.listeners.foxglove import FoxgloveServer
from tests.child import PATIENCE, wait_for
from tests.conftest import SOCAT_LOG, run_cli
from tests.integration.test_foxglove_live import Tap, assert_listenable, client, free_port

OLD, NEW = "foxglove.websocket.v1", "foxglove.sdk.v1"


def handshake(port: int, subprotocol: str) -> socket.socket:
    """A WebSocket opened by hand, offering ``subprotocol``: the socket, past the
    server's answer (which must take that name)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=PATIENCE)
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall((f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
               f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
               f"Sec-WebSocket-Protocol: {subprotocol}\r\n\r\n").encode())
    answer = b""
    while b"\r\n\r\n" not in answer:
        data = s.recv(4096)
        assert data, answer
        answer += data
    head = answer.split(b"\r\n\r\n")[0].decode().lower()
    assert head.startswith("http/1.1 101") and f"sec-websocket-protocol: {subprotocol}" in head, head
    return s


def test_clients_leaving_mid_message_leave_the_tap_serving():
    """One client leaves in the middle of a frame it sends, another resets its
    connection while the server sends: the tap serves on, says nothing of it but
    in one-line notes, and stops cleanly."""
    port = free_port()
    tap = Tap("demo", "--seconds", "0", "--no-tui", "--foxglove", f"127.0.0.1:{port}")
    try:
        tap.wait_serving(port)
        with handshake(port, OLD) as s:
            # a masked text frame announcing 1000 bytes, and 10 of them
            s.sendall(bytes([0x81, 0x80 | 126]) + struct.pack(">H", 1000) + os.urandom(4) + b"x" * 10)
        with handshake(port, NEW) as s:
            assert s.recv(1)   # the server is sending (its serverInfo first)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))   # close: a reset
        with client(port, subprotocol=OLD) as c:
            wait_for(lambda: len(c.messages["/events"]) >= 5, "events")
    finally:
        code, _out, err = tap.stop()
    assert code == 0, err
    assert "Traceback" not in err
    assert all(line.startswith("gimbalscope") for line in err.splitlines()), err


def test_closing_ends_the_relays_and_the_thread():
    """``close()`` (the run ending, the TUI quitting) closes each client's
    connection (with the server's own closing handshake), ends the front's thread and frees the address."""
    info = CaptureInfo.of(analyzer.open(SOCAT_LOG), command="replay")
    server = FoxgloveServer(info, "127.0.0.1", 0)   # any free port
    try:
        port = int(server.address.rsplit(":", 1)[1])
        assert server.url == f"ws://127.0.0.1:{port}"
        fronts = [t for t in threading.enumerate() if t.name == "foxglove-front"]
        assert len(fronts) == 1
        with connect(server.url, subprotocols=[OLD], open_timeout=PATIENCE) as ws:
            assert ws.subprotocol == OLD
            assert '"serverInfo"' in ws.recv(timeout=PATIENCE)
            server.close()
            with pytest.raises(ConnectionClosed) as closed:
                while True:
                    ws.recv(timeout=PATIENCE)
            # the server's own goodbye, passed on: a closing handshake, not a dropped connection
            assert closed.value.rcvd is not None
    finally:
        server.close()
    assert not fronts[0].is_alive()
    server.close()   # again: nothing
    assert_listenable(port)


def test_an_unknown_host_is_one_line():
    out = run_cli("demo", "--no-tui", "--foxglove", "no-such-host.invalid:8765", timeout=PATIENCE)
    assert out.returncode == 2
    assert out.stderr.splitlines() == [("gimbalscope: error: --foxglove no-such-host.invalid:8765: cannot serve: "
                                        "unknown host")]
