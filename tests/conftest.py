import os
import shutil
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# the sample captures (captures/README.md says how they were made)
CAPTURES = os.path.join(ROOT, "captures")
SOCAT_LOG = os.path.join(CAPTURES, "demo-socat.log")
BUS = os.path.join(CAPTURES, "demo-bus.bin")
CTL = os.path.join(CAPTURES, "demo-ctl.bin")
DEV = os.path.join(CAPTURES, "demo-dev.bin")


def frame(dst, src, payload) -> bytes:
    """A frame built by hand (Table 1), independent of the code under test."""
    if isinstance(payload, str):
        payload = payload.encode("latin-1")
    body = bytes([*dst, src, len(payload) & 0xFF]) + payload
    return b"\xf8" + body + bytes([sum(body) & 0xFF])


def run_cli(*args, input=None, timeout=60, env=None):
    """Run the installed console command (fall back to ``python -m analyzer``)."""
    exe = shutil.which("gimbalscope")
    cmd = [exe] if exe else [sys.executable, "-m", "analyzer"]
    return subprocess.run(cmd + [str(a) for a in args], capture_output=True, text=True, input=input,
                          timeout=timeout, cwd=ROOT, env=env, check=False)


def drain(master: int) -> bytes:
    """Everything a pseudo-terminal's other side writes, until every writer has closed it."""
    seen = b""
    while True:
        try:
            data = os.read(master, 1 << 16)
        except OSError:        # EIO: every writer has closed it
            break
        if not data:
            break
        seen += data
    return seen


@pytest.fixture
def socat_bin():
    path = shutil.which("socat")
    if path is None:
        pytest.skip("socat is not installed (.ci/run installs it)")
    return path


# Property tests: 300 examples each by default; HYPOTHESIS_PROFILE=deep for 5000.
from hypothesis import settings

settings.register_profile("default", max_examples=300, deadline=None)
settings.register_profile("deep", max_examples=5000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


@pytest.fixture(autouse=True)
def recordings_match_their_schemas(request):
    """After each test, every MCAP recording it left in its ``tmp_path`` must match
    the schemas it declares, message by message (tests/recordings.py). Tests that
    write messages off their schema on purpose say so with ``foreign_messages``."""
    if "tmp_path" not in request.fixturenames or request.node.get_closest_marker("foreign_messages"):
        yield
        return
    tmp_path = request.getfixturevalue("tmp_path")   # now: so it is torn down after this check
    yield
    from tests.recordings import check_recording

    for path in sorted(tmp_path.rglob("*.mcap")):
        check_recording(path)
