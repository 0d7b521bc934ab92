"""The install's parts (pyproject.toml's extras, docs/install.md): the base install
taps, decodes, records and converts without the fleet stack; the fleet commands
without it stop with one line naming the extra.

"Not installed" is made real for the interpreter under test: ``sys.modules[name] =
None`` makes ``import name`` fail and ``importlib.util.find_spec(name)`` find
nothing, as when the package is absent."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib

import pytest

from tests.conftest import BUS, CTL, DEV, ROOT, SOCAT_LOG

FLEET = ("pyarrow", "duckdb", "matplotlib")


def hint(extra: str) -> str:
    """What a user pastes to add ``extra``: the pip of the venv the tests run in
    (not the one on PATH), installing this clone's folder with the extra."""
    return f"{sys.prefix}/bin/pip install -e '{ROOT}[{extra}]'"


HINT = hint("fleet")


def without(modules: tuple[str, ...], *args: str) -> subprocess.CompletedProcess:
    """``gimbalscope ARGS`` in an interpreter where ``modules`` are not installed."""
    code = ("import sys\n"
            f"for name in {modules!r}: sys.modules[name] = None\n"
            "from analyzer.cli.main import main\n"
            "sys.exit(main(sys.argv[1:]))\n")
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=ROOT,
                          timeout=120, check=False)


def project() -> dict:
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        return tomllib.load(f)["project"]


def test_the_fleet_stack_is_an_extra_and_the_tests_pull_in_every_extra():
    p = project()
    base = " ".join(p["dependencies"])
    extras = p["optional-dependencies"]
    for name in FLEET:
        assert name not in base
        assert any(spec.startswith(name + ">=") for spec in extras["fleet"])
    pulled = {e for spec in extras["test"] if spec.startswith("gimbalscope[")
              for e in spec[len("gimbalscope["):-1].split(",")}
    assert pulled == set(extras) - {"test"}


@pytest.mark.parametrize("args, status", [
    (("decode", BUS), 0),
    (("stats", SOCAT_LOG), 0),
    (("doctor", CTL, DEV), 1),      # the sample's line A is noisy: a warning
])
def test_the_base_install_decodes_without_the_fleet_stack(args, status):
    r = without(FLEET, *args)
    assert r.returncode == status, r.stderr
    assert r.stdout.strip()
    assert "fleet" not in r.stderr


def test_the_base_install_converts_to_every_file_format_without_the_fleet_stack(tmp_path):
    for suffix in (".mcap", ".jsonl", ".pcapng"):
        out = tmp_path / f"out{suffix}"
        r = without(FLEET, "convert", BUS, "-o", str(out))
        assert r.returncode == 0, r.stderr
        assert out.stat().st_size > 0


def test_the_base_install_exports_to_pcapng_without_the_fleet_stack(tmp_path):
    out = tmp_path / "both.pcapng"
    r = without(FLEET, "export", BUS, SOCAT_LOG, "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert "fleet" not in r.stderr
    with open(out, "rb") as f:
        assert f.read(4) == b"\x0a\x0d\x0d\x0a"   # pcapng's section header block


@pytest.mark.parametrize("missing, args, needed", [
    (("pyarrow",), ("export", SOCAT_LOG, "-o", "{tmp}/fleet"), "pyarrow"),
    (FLEET, ("query", "{tmp}/fleet", "SELECT 1"), "pyarrow"),
    (("duckdb",), ("query", "{tmp}/fleet", "SELECT 1"), "duckdb"),
    (("matplotlib",), ("report", "{tmp}/fleet", "--html", "{tmp}/r.html"), "matplotlib"),
])
def test_a_fleet_command_without_the_extra_says_what_to_install(tmp_path, missing, args, needed):
    # a real dataset first, so the command gets as far as needing the missing package
    made = without((), "export", SOCAT_LOG, "-o", str(tmp_path / "fleet"))
    assert made.returncode == 0, made.stderr
    r = without(missing, *(a.format(tmp=tmp_path) for a in args))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith(f"gimbalscope: error: {args[0]} needs {needed}, which is not installed")
    assert HINT in lines[0] and "Traceback" not in r.stderr
    assert not (tmp_path / "r.html").exists()


def test_to_arrow_without_the_extra_names_it():
    code = ("import sys\nsys.modules['pyarrow'] = None\nimport analyzer\n"
            f"analyzer.open({SOCAT_LOG!r}).to_arrow()\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=60, check=False)
    assert r.returncode == 1
    assert r.stderr.strip().splitlines()[-1].startswith("ImportError: to_arrow() needs pyarrow")
    assert HINT in r.stderr


def test_spark_without_the_spark_extra_says_what_to_install(tmp_path):
    for args in (["export", SOCAT_LOG, "-o", str(tmp_path / "ds")], ["report", str(tmp_path / "ds")]):
        r = without(("pyspark", "py4j"), *args, "--spark", "local[1]")
        assert r.returncode == 2, r.stderr
        assert r.stderr == ("gimbalscope: error: " + args[0] + " needs pyspark, which is not installed: it comes "
                            f"with the spark extra: {hint('spark')}\n")
