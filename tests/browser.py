"""A real headless Chromium, driven over its DevTools protocol (a WebSocket on
127.0.0.1), for pages that draw as they run: the TUI served to a browser.

The served TUI draws on a canvas (xterm.js), which holds no text a test can read.
So the page is given, before its own scripts run, a wrapper around ``WebSocket``
that keeps every screen update the page receives and hands to the terminal: the
text the browser drew, escape sequences and all (``screen_text`` strips them).
A screenshot says the canvas was drawn at all.
"""

from __future__ import annotations

import base64
import itertools
import json
import re
import shutil
import subprocess
import tempfile
import threading
import time
from contextlib import contextmanager
from typing import Any

import pytest
from websockets.sync.client import connect

from tests.child import PATIENCE

# kept as the page's own scripts receive them: strings, and binary frames decoded as UTF-8
KEEP_SCREEN = """
(() => {
  const Original = window.WebSocket;
  window.__screen = [];
  window.__opened = 0;
  window.WebSocket = class extends Original {
    constructor(...args) {
      super(...args);
      window.__opened += 1;
      this.addEventListener("message", (e) => {
        const d = e.data;
        if (typeof d === "string") window.__screen.push(d);
        else if (d instanceof ArrayBuffer) window.__screen.push(new TextDecoder().decode(d));
        else if (d instanceof Blob) d.text().then((t) => window.__screen.push(t));
      });
    }
  };
})();
"""

ESCAPES = re.compile(r"\x1b\[[0-9;?<>=]*[ -/]*[@-~]|\x1b\][^\x07\x1b]*(?:\x07|\x1b\\)|\x1b[@-_]")


def screen_text(raw: str) -> str:
    """What a run of terminal output writes, without its escape sequences."""
    return ESCAPES.sub("", raw)


def chromium() -> str:
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("chromium is not installed (.ci/run installs Debian's chromium)")
    return browser


class Page:
    """One tab, driven over the DevTools protocol (flat sessions on the browser's socket)."""

    def __init__(self, socket: Any, session: str) -> None:
        self._socket = socket
        self._session = session
        self._ids = itertools.count(1)

    def call(self, method: str, **params: Any) -> dict:
        n = next(self._ids)
        self._socket.send(json.dumps({"id": n, "method": method, "params": params, "sessionId": self._session}))
        while True:
            answer = json.loads(self._socket.recv(timeout=PATIENCE))
            if answer.get("id") == n:
                if "error" in answer:
                    raise AssertionError(f"{method}: {answer['error']}")
                return answer.get("result", {})

    def evaluate(self, expression: str) -> Any:
        return self.call("Runtime.evaluate", expression=expression, returnByValue=True)["result"].get("value")

    def screen(self) -> str:
        """Every screen update the page received, as text."""
        return screen_text("".join(self.evaluate("window.__screen") or []))

    def wait_for_text(self, *wanted: str, deadline: float = PATIENCE) -> str:
        """The page's screen once it shows every one of ``wanted``."""
        end = time.monotonic() + deadline
        while True:
            text = self.screen()
            if all(w in text for w in wanted) or time.monotonic() > end:
                return text
            time.sleep(0.2)

    def screenshot(self) -> bytes:
        return base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])


@contextmanager
def browser_page(url: str, *, width: int = 1280, height: int = 800):
    """A headless Chromium tab showing ``url``, its screen updates kept (``KEEP_SCREEN``)."""
    with tempfile.TemporaryDirectory(prefix="gimbalscope-chromium-") as profile:
        proc = subprocess.Popen(
            [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", f"--user-data-dir={profile}",
             "--remote-debugging-address=127.0.0.1", "--remote-debugging-port=0", f"--window-size={width},{height}",
             "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        try:
            endpoint = _devtools_endpoint(proc)
            # the rest of its log is read and dropped: a full pipe would stop the browser
            threading.Thread(target=proc.stderr.read, daemon=True).start()   # type: ignore[union-attr]
            with connect(endpoint, max_size=None, open_timeout=PATIENCE) as socket:
                target = _browser_call(socket, "Target.createTarget", url="about:blank")["targetId"]
                session = _browser_call(socket, "Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
                page = Page(socket, session)
                page.call("Page.enable")
                page.call("Page.addScriptToEvaluateOnNewDocument", source=KEEP_SCREEN)
                page.call("Page.navigate", url=url)
                yield page
        finally:
            proc.kill()
            proc.wait()
            if proc.stderr is not None:
                proc.stderr.close()


def _browser_call(socket: Any, method: str, **params: Any) -> dict:
    n = int(time.monotonic_ns() % 1_000_000_000)
    socket.send(json.dumps({"id": n, "method": method, "params": params}))
    while True:
        answer = json.loads(socket.recv(timeout=PATIENCE))
        if answer.get("id") == n:
            if "error" in answer:
                raise AssertionError(f"{method}: {answer['error']}")
            return answer["result"]


def _devtools_endpoint(proc: subprocess.Popen) -> str:
    """The browser's DevTools WebSocket, as Chromium prints it on standard error."""
    assert proc.stderr is not None
    seen = []
    for line in proc.stderr:
        seen.append(line)
        m = re.search(r"DevTools listening on (ws://\S+)", line)
        if m:
            return m.group(1)
    raise AssertionError("chromium did not start its DevTools server: " + "".join(seen[-5:]))
