"""The README's quick start, as written, in a fresh copy of the repository: one line
that makes a virtual environment, installs into it and runs the demo, on the
machine's own Python where it has one (Debian's and Ubuntu's are externally
managed: pip refuses to install there, PEP 668). The base install it makes has no
fleet stack: the fleet commands say in one line what to install.

pip reads its cache, which the test environment's own install filled, so this
takes seconds; it downloads what is missing."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys

from tests.conftest import ROOT

QUICK_START = re.compile(r"## Quick start\n.*?```\n(.*?)\n```", re.DOTALL)
STOCK = "/usr/bin/python3"


def quick_start_line() -> str:
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        block = QUICK_START.search(f.read()).group(1)
    lines = block.strip().splitlines()
    assert len(lines) == 1, "the quick start is one line"
    return lines[0]


def stock_python_dir() -> str:
    """A folder whose python3 is the machine's own (with its venv module), else this one's."""
    if os.path.exists(STOCK) and subprocess.run([STOCK, "-c", "import ensurepip, venv"],
                                                capture_output=True, check=False).returncode == 0:
        return os.path.dirname(STOCK)
    return os.path.dirname(os.path.realpath(sys.executable))


def fresh_copy(dest) -> str:
    """The repository's tracked files, as a fresh clone has them."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in filter(None, files.decode().split("\0")):
        src = os.path.join(ROOT, name)
        if os.path.isfile(src):
            os.makedirs(os.path.dirname(os.path.join(dest, name)), exist_ok=True)
            shutil.copy2(src, os.path.join(dest, name))
    return str(dest)


def test_the_quick_start_line_works_as_written_and_installs_no_fleet_stack(tmp_path):
    line = quick_start_line()
    assert line.startswith("python3 -m venv .venv && .venv/bin/pip install -e . && ")
    assert line.endswith(".venv/bin/gimbalscope demo")
    clone = fresh_copy(tmp_path / "clone")
    # the demo as the line runs it, but piped it prints for 12 s: 2 are enough here
    run = line + " --seconds 2"
    env = {"PATH": f"{stock_python_dir()}:/usr/bin:/bin", "HOME": os.environ.get("HOME", str(tmp_path)),
           "PIP_DISABLE_PIP_VERSION_CHECK": "1"}
    r = subprocess.run(["bash", "-c", run], cwd=clone, capture_output=True, text=True, env=env, timeout=600,
                       check=False)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert "command P?" in r.stdout and "ack" in r.stdout     # the demo's decoded traffic
    venv_python = os.path.join(clone, ".venv", "bin", "python")
    for name in ("pyarrow", "duckdb", "matplotlib"):
        missing = subprocess.run([venv_python, "-c", f"import {name}"], capture_output=True, check=False)
        assert missing.returncode != 0, f"the base install pulled in {name}"
    export = subprocess.run([os.path.join(clone, ".venv", "bin", "gimbalscope"), "export",
                             "captures/demo-socat.log", "-o", "fleet"], cwd=clone, capture_output=True, text=True,
                            env=env, timeout=120, check=False)
    assert export.returncode == 2
    assert export.stderr.strip().splitlines() == [
        ("gimbalscope: error: export needs pyarrow, which is not installed: it comes with the fleet extra: "
         f"{clone}/.venv/bin/pip install -e '{clone}[fleet]'")]
    # the base install writes Wireshark's pcapng with the same command, as the README says
    pcapng = subprocess.run([os.path.join(clone, ".venv", "bin", "gimbalscope"), "export",
                             "captures/demo-socat.log", "-o", "demo.pcapng"], cwd=clone, capture_output=True,
                            text=True, env=env, timeout=120, check=False)
    assert pcapng.returncode == 0, pcapng.stderr
    with open(os.path.join(clone, "demo.pcapng"), "rb") as f:
        assert f.read(4) == b"\x0a\x0d\x0d\x0a"   # a pcapng section header block


def test_ci_installs_into_a_virtual_environment_only():
    with open(os.path.join(ROOT, ".ci", "run"), encoding="utf-8") as f:
        script = f.read()
    installs = [m.start() for m in re.finditer(r"pip install", script)]
    venv = script.index('export PATH="$VIRTUAL_ENV/bin:$PATH"')
    assert installs and all(at > venv for at in installs), "every pip install comes after .venv is on PATH"
    assert "--break-system-packages" not in script and "--user" not in script
