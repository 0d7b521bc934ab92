"""``gimbalscope saleae install`` end to end: the extension folder Logic 2 loads
(extension.json naming the analyzer's module and class, the module, a README),
where it goes, one line when it cannot be written; and the installed module
checked for Python 3.8 by vermin, and imported by a Python 3.8 when the machine
has one (Logic 2 embeds 3.8). tests/pure/test_saleae_analyzer.py runs it."""

from __future__ import annotations

import ast
import glob
import json
import os
import re
import shutil
import subprocess
import sysconfig

import pytest

from analyzer.version import __version__
from tests.conftest import run_cli
from tests.saleae_logic import STANDIN

FILES = ["README.md", "extension.json", "gimbal_hla.py"]


def installed(args: list, env: dict | None = None) -> tuple[subprocess.CompletedProcess, str]:
    run = run_cli("saleae", "install", *args, env=env)
    assert run.returncode == 0, run.stderr
    said = run.stderr.strip().splitlines()
    assert len(said) == 1 and run.stdout == "", run.stderr
    return run, said[0]


def test_install_writes_the_extension_folder(tmp_path):
    _, said = installed(["--dir", tmp_path / "ext"])
    folder = tmp_path / "ext" / "Gimbal"
    assert sorted(os.listdir(folder)) == FILES
    assert said == (f"gimbalscope: wrote the Saleae Logic 2 extension Gimbal into {folder}; load it in Logic 2: "
                    f"Extensions panel → ⋮ → Load Existing Extension → {folder / 'extension.json'}, then add Gimbal "
                    "on each line's Async Serial analyzer")
    manifest = json.loads((folder / "extension.json").read_text(encoding="utf-8"))
    assert manifest["apiVersion"] == "1.0.0" and manifest["version"] == __version__
    assert {"name", "author", "description"} <= set(manifest)
    (extension,) = manifest["extensions"].values()
    assert extension["type"] == "HighLevelAnalyzer"
    module, cls = extension["entryPoint"].split(".")
    tree = ast.parse((folder / f"{module}.py").read_text(encoding="utf-8"), feature_version=(3, 8))
    (hla,) = [node for node in tree.body if isinstance(node, ast.ClassDef) and node.name == cls]
    assert [base.id for base in hla.bases if isinstance(base, ast.Name)] == ["HighLevelAnalyzer"]
    readme = (folder / "README.md").read_text(encoding="utf-8")
    assert f"gimbalscope {__version__}" in readme and "Async Serial" in readme
    # again: the same folder, brought up to date in place
    installed(["--dir", tmp_path / "ext"])
    assert sorted(os.listdir(folder)) == FILES


def test_default_folder_is_under_the_user_data_folder(tmp_path):
    env = {**os.environ, "XDG_DATA_HOME": str(tmp_path / "data")}
    _, said = installed([], env=env)
    folder = tmp_path / "data" / "gimbalscope" / "saleae" / "Gimbal"
    assert sorted(os.listdir(folder)) == FILES
    assert f"into {folder};" in said


def test_a_folder_it_cannot_write_is_one_line(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    targets = [blocker, blocker / "sub"]
    if os.geteuid() != 0:   # root writes anywhere
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        targets.append(locked)
    for target in targets:
        run = run_cli("saleae", "install", "--dir", target)
        assert run.returncode == 2, run.stderr
        lines = run.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("gimbalscope: error: ") and "Traceback" not in run.stderr


def test_vermin_finds_it_python_3_8(tmp_path):
    """vermin, over the installed module: nothing in it needs a Python newer than 3.8."""
    installed(["--dir", tmp_path])
    vermin = shutil.which("vermin", path=sysconfig.get_path("scripts")) or shutil.which("vermin")
    assert vermin is not None, "vermin is in the test extra"
    module = tmp_path / "Gimbal" / "gimbal_hla.py"
    run = subprocess.run([vermin, "--target=3.8-", "--no-tips", "--violations", str(module)],
                         capture_output=True, text=True, timeout=300, check=False)
    assert run.returncode == 0, run.stdout + run.stderr
    run = subprocess.run([vermin, "--no-tips", str(module)], capture_output=True, text=True, timeout=300, check=False)
    needed = re.search(r"Minimum required versions: 3\.(\d+)", run.stdout)
    assert needed is not None and int(needed.group(1)) <= 8, run.stdout


def python_3_8() -> str | None:
    """A Python 3.8 that runs (on PATH, or one pyenv installed), or None."""
    candidates = [shutil.which("python3.8"), *sorted(glob.glob(os.path.expanduser("~/.pyenv/versions/3.8*/bin/python3.8")))]
    for exe in filter(None, candidates):
        try:
            run = subprocess.run([exe, "-c", "import sys; assert sys.version_info[:2] == (3, 8)"],
                                 capture_output=True, timeout=60, check=False)
        except OSError:
            continue
        if run.returncode == 0:
            return exe
    return None


def test_a_python_3_8_runs_it(tmp_path):
    """The installed module imported by Python 3.8 over the stand-in ``saleae``,
    and a command, its ACK and its result through it."""
    exe = python_3_8()
    if exe is None:
        pytest.skip("no Python 3.8 on this machine")
    installed(["--dir", tmp_path])
    code = """
import sys
from datetime import datetime, timezone
sys.path[:0] = sys.argv[1:3]
from saleae.analyzers import AnalyzerFrame
from saleae.data import GraphTime, GraphTimeDelta
import gimbal_hla
hla = gimbal_hla.Gimbal.__new__(gimbal_hla.Gimbal)
hla.line, hla.frame_gap_ms = 'both: one wire, both directions (half-duplex)', 0
hla.__init__()
t0 = GraphTime(datetime(2024, 5, 1, tzinfo=timezone.utc))
wire = bytes.fromhex(sys.argv[3])
for k, b in enumerate(wire):
    at = t0 + GraphTimeDelta(millisecond=k)
    for f in hla.decode(AnalyzerFrame('data', at, at + GraphTimeDelta(millisecond=1), {'data': bytes([b])})) or []:
        print(f.type, f.data['command'], f.data['device'], f.data['summary'])
"""
    # P? to 1.1.2 (checksum 0x95), ACK, its result "0FA0FC18" (az +40.00°, el -10.00°: Table 15), then
    # the start of another frame, whose byte completes nothing
    result = bytes.fromhex("f80001020108") + b"0FA0FC18"
    wire = bytes.fromhex("f80101020002503f95") + b"\x06" + result + bytes([sum(result[1:]) & 0xFF]) + b"\xf8"
    run = subprocess.run([exe, "-c", code, STANDIN, str(tmp_path / "Gimbal"), wire.hex()],
                         capture_output=True, text=True, timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ["command P? 1.1.2 current position query", "ack P? 1.1.2 ACK",
                                       "result P? 1.1.2 at az +40.00° el -10.00°"]
