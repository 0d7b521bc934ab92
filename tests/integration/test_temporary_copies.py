"""A capture read through a pipe or compressed, where its reader needs random
access (a sigrok session's zip, an MCAP recording), is copied to a temporary
file, and that copy is gone when the command ends: read whole, refused as
damaged, or not what it claims to be."""

from __future__ import annotations

import gzip
import io
import os
import zipfile

import pytest

from tests.conftest import run_cli

SESSION = os.path.join(os.path.dirname(__file__), "..", "data", "sigrok-dumps", "hello_world_8n1_57600.sr")


def gzipped(tmp_path, data: bytes, name: str) -> str:
    path = tmp_path / name
    path.write_bytes(gzip.compress(data))
    return str(path)


@pytest.mark.parametrize("what", ["whole", "cut short", "no session"])
def test_no_copy_is_left_behind(tmp_path, what):
    with open(SESSION, "rb") as f:
        data = f.read()
    if what == "cut short":
        data = data[: len(data) // 3]
    elif what == "no session":   # sigrok's version member, and no metadata
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w") as z:
            z.writestr("version", "2")
            z.writestr("logic-1-1", bytes(64))
        data = buffer.getvalue()
    capture = gzipped(tmp_path, data, "session.sr.gz")
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    done = run_cli("decode", capture, "--baud", "57600", env={**os.environ, "TMPDIR": str(scratch)})
    assert "Traceback" not in done.stderr
    assert (done.returncode == 0) == (what == "whole"), done.stderr
    assert os.listdir(scratch) == []
