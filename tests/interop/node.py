"""Node.js and the packages of tests/interop/js (pinned in its package-lock.json),
which the interop tests run Foxglove's own code in."""

from __future__ import annotations

import os
import shutil

import pytest

from tests.conftest import ROOT

JS_DIR = os.path.join(ROOT, "tests", "interop", "js")
INSTALL = "npm ci --prefix tests/interop/js --no-audit --no-fund"


def node_with(*packages: str) -> str:
    """The node executable, once ``packages`` are installed in tests/interop/js; a
    missing one fails the test with the command that installs it."""
    node = shutil.which("node")
    if node is None:
        pytest.fail(f"node is not installed: install Node.js 20 or later with npm, then run `{INSTALL}`")
    missing = [p for p in packages if not os.path.isdir(os.path.join(JS_DIR, "node_modules", p))]
    if missing:
        pytest.fail(f"{', '.join(missing)} not installed in tests/interop/js: run `{INSTALL}` (.ci/run does)")
    return node
