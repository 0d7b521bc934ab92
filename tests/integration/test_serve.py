"""``gimbalscope serve``: the TUI in a real headless Chromium, one session a tab,
through the real server bound on 127.0.0.1 (tests/browser.py reads what the page
drew).

The captures are built by hand (tests.conftest.frame, Table 1), and the rows
expected of them read from the spec's tables: ``P25`` to 1.1.3 is "go to preset"
(Table 11) with the preset in hex, 0x25 = 37; ``TP`` answered by a NAK is a
command whose status is nak.
"""

import os
import re
import signal
import socket
import tty
import urllib.request

import pytest

from tests.browser import browser_page
from tests.child import PATIENCE, Child, wait_for
from tests.conftest import frame, run_cli

SERVING = re.compile(r"serving `(.*?)` on http://127\.0\.0\.1:(\d+) ")


def capture(tmp_path):
    """Line A: P25 to 1.1.3, then TP to 1.1.4; line B: an ACK, then a NAK."""
    a, b = tmp_path / "a.bin", tmp_path / "b.bin"
    a.write_bytes(frame((1, 1, 3), 0, "P25") + frame((1, 1, 4), 0, "TP"))
    b.write_bytes(b"\x06\x15")
    return a, b


class Served(Child):
    """``gimbalscope serve --port 0 ARGS``; ``url`` once it says where."""

    def __init__(self, *args) -> None:
        super().__init__("serve", "--port", "0", *args)
        self.wait_said("(open it in a browser", "the serving line")
        found = SERVING.search("".join(self.err))
        assert found, self.err
        self.url = f"http://127.0.0.1:{found.group(2)}/"

    def sessions(self) -> list[int]:
        """The processes running a session (each tab's ``python -m analyzer``, not the shell
        that starts it nor its decoding process), among the server's descendants."""
        return [pid for pid in descendants(self.proc.pid) if b"\0-m\0analyzer\0" in cmdline(pid)]


def descendants(pid: int) -> list[int]:
    found, todo = [], [pid]
    while todo:
        parent = todo.pop()
        try:
            with open(f"/proc/{parent}/task/{parent}/children") as f:
                children = [int(c) for c in f.read().split()]
        except OSError:
            continue
        found += children
        todo += children
    return found


def cmdline(pid: int) -> bytes:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read()
    except OSError:
        return b""


def test_a_tab_shows_the_first_rows_of_a_capture(tmp_path):
    a, b = capture(tmp_path)
    server = Served("view", a, b)
    try:
        with browser_page(server.url) as page:
            text = page.wait_for_text("go to preset 37", "nak")
            assert "go to preset 37" in text and "1.1.3" in text, text[-2000:]
            assert re.search(r"1\.1\.4\s+command\s+TP", text), text[-2000:]
            assert page.evaluate("document.body.classList.contains('-first-byte')")   # the screen replaced the intro
            assert len(page.screenshot()) > 10_000   # the canvas was drawn
        code, _out, err = server.stop()
    finally:
        server.kill()
    assert code == 0, err


def test_each_tab_is_a_session_of_its_own_and_ctrl_c_ends_them(tmp_path):
    a, b = capture(tmp_path)
    server = Served("view", a, b)
    try:
        with browser_page(server.url) as first, browser_page(server.url) as second:
            for page in (first, second):
                assert "go to preset 37" in page.wait_for_text("go to preset 37")
            wait_for(lambda: len(server.sessions()) == 2, "two sessions")
            sessions = server.sessions()
            code, _out, err = server.stop(signal.SIGINT)
        assert code == 0, err
        wait_for(lambda: not any(os.path.exists(f"/proc/{pid}/cmdline") and cmdline(pid) for pid in sessions),
                 "the sessions to end with the server")
    finally:
        server.kill()


def test_a_live_tap_is_one_tab_at_a_time():
    master, slave = os.openpty()
    tty.setraw(slave)
    server = Served("live", os.ttyname(slave))
    try:
        with browser_page(server.url) as first:
            first.wait_for_text("0 events")
            os.write(master, frame((1, 1, 3), 0, "P25"))
            assert "go to preset 37" in first.wait_for_text("go to preset 37")
            with browser_page(server.url) as second:
                text = second.wait_for_text("open in another tab")
                assert "the live tap is open in another tab" in text, text
            assert server.said("a second tab asked for the live tap: refused")
        code, _out, err = server.stop()
        assert code == 0, err
    finally:
        server.kill()
        os.close(master)
        os.close(slave)


def test_the_page_links_to_the_address_the_browser_used(tmp_path):
    """Behind an SSH tunnel (ssh -L 9000:127.0.0.1:8000) the browser asks for 127.0.0.1:9000."""
    a, b = capture(tmp_path)
    server = Served("view", a, b)
    try:
        request = urllib.request.Request(server.url, headers={"Host": "127.0.0.1:9000"})
        with urllib.request.urlopen(request, timeout=PATIENCE) as answer:
            page = answer.read().decode()
        assert 'data-session-websocket-url="ws://127.0.0.1:9000/ws"' in page
        assert "http://127.0.0.1:9000/static/js/textual.js" in page
    finally:
        server.kill()


def test_every_network_is_said(tmp_path):
    a, b = capture(tmp_path)
    server = Child("serve", "--host", "0.0.0.0", "--port", "0", "view", a, b)
    try:
        server.wait_said("reachable by")
        assert server.said("reachable by anyone who can reach this machine on any of its networks, with no password")
        assert server.said(f"from elsewhere http://{socket.gethostname()}:")
    finally:
        server.kill()


@pytest.mark.parametrize(("args", "message"), [
    (["view", "missing.bin"], "missing.bin"),
    (["view", "captures/demo-bus.bin", "--filter", "kind =="], "filter"),
    (["live", "/dev/null", "--no-tui"], "serve shows live's TUI: --no-tui and --format print events instead"),
    (["decode", "captures/demo-bus.bin"], "argument COMMAND: invalid choice: 'decode'"),
    (["live"], "give one or two ports"),              # live's own checks, before every tab would fail them
    (["live", "/dev/null", "--allow-motion"], "--allow-motion and --allow-config go with --talk"),
    (["--port", "70000", "view", "captures/demo-bus.bin"], "argument --port: '70000': a TCP port is 0 to 65535"),
    (["--host", "no-such-host.invalid", "view", "captures/demo-bus.bin"],
     "no-such-host.invalid:8000: cannot serve: unknown host"),
])
def test_mistakes_are_one_line_before_serving(args, message):
    out = run_cli("serve", *args)
    assert out.returncode == 2, out
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gimbalscope: error:") and message in lines[0], out.stderr


def test_a_busy_port_is_one_line():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        out = run_cli("serve", "--port", port, "view", "captures/demo-bus.bin")
    assert out.returncode == 2
    assert out.stderr.strip() == f"gimbalscope: error: 127.0.0.1:{port}: cannot serve: address already in use"
