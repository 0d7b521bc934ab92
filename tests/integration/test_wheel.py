"""The package as others install it (docs/install.md, "From a wheel"): `python -m
build` makes an sdist and, from that sdist, a wheel; the wheel installs into a
fresh virtual environment with no compiler at hand (every dependency a wheel
too) and runs the demo; `pipx install` installs it as an application."""

from __future__ import annotations

import glob
import json
import os
import subprocess
import sys
import zipfile

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
NO_COMPILER = {"CC": "/bin/false", "CXX": "/bin/false"}   # a build step that compiles anything fails


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> str:
    out = str(tmp_path_factory.mktemp("dist"))
    done = subprocess.run([sys.executable, "-m", "build", "--outdir", out, ROOT], capture_output=True, text=True,
                          timeout=900, check=False)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return out


def only(pattern: str) -> str:
    found = glob.glob(pattern)
    assert len(found) == 1, found
    return found[0]


def test_the_sdist_and_the_wheel_hold_the_package(dist):
    sdist = only(os.path.join(dist, "gimbalscope-*.tar.gz"))
    wheel = only(os.path.join(dist, "gimbalscope-*.whl"))
    assert os.path.getsize(sdist) > 0
    names = zipfile.ZipFile(wheel).namelist()
    for wanted in ("analyzer/cli/main.py", "dissectors/commands.py", "analyzer/py.typed", "dissectors/_deframe.pyi"):
        assert wanted in names, wanted
    assert any(n.startswith("dissectors/_deframe") and n.endswith(".so") for n in names)   # compiled: no compiler needed
    assert any(n.startswith("analyzer/tui/") and n.endswith(".tcss") for n in names)      # the TUI's styles
    assert not any(n.startswith(("tests/", "bench/")) for n in names)


def test_the_wheel_installs_without_a_compiler_and_runs_the_demo(dist, tmp_path):
    wheel = only(os.path.join(dist, "gimbalscope-*.whl"))
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    env = {**os.environ, **NO_COMPILER}
    env.pop("VIRTUAL_ENV", None)
    done = subprocess.run([str(venv / "bin" / "pip"), "install", "--only-binary", ":all:", wheel],
                          capture_output=True, text=True, env=env, timeout=900, check=False)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    demo = subprocess.run([str(venv / "bin" / "gimbalscope"), "demo", "--no-tui", "--seconds", "2", "--format",
                           "jsonl"], capture_output=True, text=True, cwd=tmp_path, timeout=120, check=False)
    assert demo.returncode == 0, demo.stderr
    kinds = {json.loads(line)["kind"] for line in demo.stdout.splitlines()}
    assert {"command", "ack"} <= kinds, demo.stdout[:500]
    # the installed package, not this checkout's
    where = subprocess.run([str(venv / "bin" / "python"), "-c", "import analyzer; print(analyzer.__file__)"],
                           capture_output=True, text=True, cwd=tmp_path, timeout=60, check=True)
    assert where.stdout.startswith(str(venv))


def test_pipx_installs_it_as_an_application(dist, tmp_path):
    wheel = only(os.path.join(dist, "gimbalscope-*.whl"))
    env = {**os.environ, **NO_COMPILER, "PIPX_HOME": str(tmp_path / "pipx"), "PIPX_BIN_DIR": str(tmp_path / "bin"),
           "PIPX_MAN_DIR": str(tmp_path / "man")}
    env.pop("VIRTUAL_ENV", None)
    done = subprocess.run([sys.executable, "-m", "pipx", "install", wheel], capture_output=True, text=True, env=env,
                          timeout=900, check=False)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    version = subprocess.run([str(tmp_path / "bin" / "gimbalscope"), "--version"], capture_output=True, text=True,
                             timeout=60, check=False)
    assert version.returncode == 0 and version.stdout.startswith("gimbalscope "), version.stdout + version.stderr
