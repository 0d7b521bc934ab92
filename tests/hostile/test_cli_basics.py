"""The command line's basics: every subcommand's --help works, every numeric option
refuses nan, infinity and negative numbers with one line naming it, a keymap with
an unknown binding id is one line with a suggestion, ``sim`` says what it
simulates, and the package declares its licence and its real lower bounds.

Subcommands and options are discovered from the parser, so a new one is covered
without touching this file. Options are checked by parsing only: a bad value must
be refused before anything starts (a port opened, a file written, a demo run).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import tomllib
import tty

import pytest

from analyzer.cli.main import COMMANDS, build_parser, commands_of
from tests.conftest import ROOT, run_cli

BAD_NUMBERS = ("nan", "inf", "-inf", "-1")
HANG_GUARD = 60.0   # seconds before a silent child counts as hung (a guard, not a timing check)


def subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(sub.choices)


def parse(parser: argparse.ArgumentParser, argv: list[str]) -> tuple[int, str, str]:
    """Parse only (nothing runs): (exit code, stdout, stderr); 0 when it parsed."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            parser.parse_args(argv)
            code = 0
        except SystemExit as e:
            code = e.code if isinstance(e.code, int) else 2
    return code, out.getvalue(), err.getvalue()


def is_numeric(action: argparse.Action) -> bool:
    """An option taking one number: its type turns "1" into an int or a float."""
    if not action.option_strings or action.choices or action.nargs not in (None, 1) or action.type is None:
        return False
    try:
        return isinstance(action.type("1"), (int, float))
    except (argparse.ArgumentTypeError, TypeError, ValueError):
        return False


def positionals(parser: argparse.ArgumentParser) -> list[str]:
    """Placeholder positionals, so only the option under test can be wrong."""
    return ["x" for a in parser._actions if not a.option_strings and a.nargs != argparse.SUPPRESS
            and not isinstance(a, argparse._SubParsersAction)]


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gimbalscope: error: "), err
    assert "Traceback" not in err
    return lines[0]


def test_every_subcommand_help_exits_0_and_prints_usage():
    broken = {}
    for name, parser in subcommands().items():
        try:
            code, out, err = parse(parser, ["--help"])
        except Exception as e:  # noqa: BLE001 - argparse formats help lazily: a bad %-code raises anything here
            broken[name] = repr(e)
            continue
        if code != 0 or not out.startswith(f"usage: gimbalscope {name}") or err:
            broken[name] = (code, out[:80], err)
    assert len(subcommands()) >= 10
    assert broken == {}


def test_a_command_parsed_alone_is_parsed_as_among_all():
    """``main`` builds the parser of the command it runs only (the others' modules
    are not imported): what a command line says, and its help, do not change."""
    every = subcommands()
    assert sorted(COMMANDS) == sorted(every)
    for name in COMMANDS:
        (alone,) = [a for a in build_parser((name,))._actions if isinstance(a, argparse._SubParsersAction)]
        assert list(alone.choices) == [name]
        assert alone.choices[name].format_help() == every[name].format_help()
    assert commands_of(["view", "x.mcap", "--keymap", "k.toml"]) == ["view"]
    for not_one in ([], ["--help"], ["--version"], ["vew", "x.mcap"]):
        assert commands_of(not_one) == COMMANDS


def test_every_numeric_option_refuses_nan_inf_and_negatives():
    accepted, unclear = [], []
    checked = 0
    for name, parser in subcommands().items():
        for action in filter(is_numeric, parser._actions):
            option = action.option_strings[-1]
            for value in BAD_NUMBERS:
                checked += 1
                # --option=value: a value starting with "-" reaches the type, not the option parser
                code, _, err = parse(parser, [f"{option}={value}", *positionals(parser)])
                if code == 0:
                    accepted.append(f"{name} {option} {value}")
                elif code != 2 or len(err.strip().splitlines()) != 1 or option not in err:
                    unclear.append((name, option, value, err))
    assert checked >= 150   # every subcommand's options were found
    assert accepted == []
    assert unclear == []


def test_per_command_timeouts_refuse_nan_inf_and_negatives():
    for name, parser in subcommands().items():
        if not any("--timeout" in a.option_strings for a in parser._actions):
            continue
        for value in BAD_NUMBERS + ("0",):
            code, _, err = parse(parser, [f"--timeout=IX={value}", *positionals(parser)])
            assert code == 2 and "--timeout" in one_error_line(err), (name, value, err)


def test_zero_is_refused_where_it_means_nothing():
    parser = subcommands()["decode"]
    for option in ("--baud", "--ack-timeout", "--result-timeout", "--frame-gap"):
        code, _, err = parse(parser, [option, "0", "x"])
        assert code == 2 and option in one_error_line(err)
    # and where 0 means something (until stopped, never) it is taken
    assert parse(subcommands()["sim"], ["--drop-acks", "0", "--init-seconds", "0", "x"])[0] == 0
    assert parse(subcommands()["demo"], ["--seconds", "0"])[0] == 0


def test_a_probability_above_one_is_refused():
    code, _, err = parse(subcommands()["sim"], ["--late", "1.5", "x"])
    assert code == 2 and "--late" in one_error_line(err) and "probability" in err


def test_bad_pairing_options_end_to_end():
    sample = os.path.join("captures", "demo-bus.bin")
    for option, value in (("--ack-timeout", "nan"), ("--frame-gap", "-1"), ("--result-timeout", "inf")):
        r = run_cli("decode", sample, option, value)
        assert r.returncode == 2 and r.stdout == "", (option, r.stderr)
        line = one_error_line(r.stderr)
        assert option in line and repr(value) in line


def test_unknown_keymap_id_is_one_line_with_the_nearest_ids(tmp_path):
    keys = tmp_path / "keys.toml"
    keys.write_text('"app.filtr" = "ctrl+l"\n')
    r = run_cli("view", os.path.join("captures", "demo-socat.log"), "--keymap", keys)
    assert r.returncode == 2, r.stderr
    line = one_error_line(r.stderr)
    assert "'app.filtr'" in line and "app.filter" in line and str(keys) in line


def test_keymap_ids_come_from_the_app_and_its_widgets(tmp_path):
    from analyzer.tui.app import GimbalscopeApp
    from analyzer.tui.run import load_keymap
    from analyzer.tui.widgets import EventList

    ids = [b.id for cls in (GimbalscopeApp, EventList) for b in cls.BINDINGS]
    keys = tmp_path / "all.toml"
    keys.write_text("".join(f'"{i}" = "f12"\n' for i in ids))
    assert set(load_keymap(str(keys))) == set(ids)
    nothing_near = tmp_path / "odd.toml"
    nothing_near.write_text('"zzzz" = "x"\n')
    r = run_cli("view", os.path.join("captures", "demo-socat.log"), "--keymap", nothing_near)
    assert r.returncode == 2 and "'zzzz'" in one_error_line(r.stderr)


def read_line(stream, seconds: float) -> str:
    """One line from a child's pipe, or '' if none came before the hang guard."""
    ready, _, _ = select.select([stream], [], [], seconds)
    return stream.readline() if ready else ""


def test_sim_says_what_it_simulates_then_stops_on_sigterm():
    master, slave = os.openpty()
    tty.setraw(slave)
    port = os.ttyname(slave)
    exe = shutil.which("gimbalscope")
    cmd = [exe] if exe else [sys.executable, "-m", "analyzer"]
    proc = subprocess.Popen(cmd + ["sim", port, "--address", "1.1.1", "--address", "1.1.2"],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = read_line(proc.stderr, HANG_GUARD)
        assert line == f"gimbalscope: sim: gimbals 1.1.1, 1.1.2 answering on {port} at 9600 baud (Ctrl-C stops)\n"
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=HANG_GUARD)
        assert proc.returncode == 0 and out == "" and err == ""
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(master)
        os.close(slave)


def lower_bounds() -> dict[str, tuple[int, ...]]:
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        project = tomllib.load(f)["project"]
    specs = project["dependencies"] + [s for group in project["optional-dependencies"].values() for s in group]
    bounds = {}
    for spec in specs:
        if spec.startswith("gimbalscope["):   # an extra that pulls in others: no version of its own
            continue
        m = re.fullmatch(r"([A-Za-z0-9_.-]+)(?:\[[^]]*\])?\s*>=\s*([0-9][0-9.]*)\s*(?:,.*)?", spec)
        assert m, f"{spec!r}: every requirement has a >= lower bound"
        bounds[m.group(1).lower()] = tuple(int(x) for x in m.group(2).split("."))
    return bounds


def test_lower_bounds_carry_the_features_used():
    bounds = lower_bounds()
    # Binding(id=...) and App.set_keymap, which --keymap and every binding use, are 0.82's
    assert bounds["textual"] >= (0, 82)
    assert set(bounds) >= {"pyserial", "mcap", "rich", "orjson", "pytest", "hypothesis", "pymcap-cli",
                           "pytest-textual-snapshot"}


def test_license_is_present_and_declared():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        data = tomllib.load(f)
    project = data["project"]
    assert project["license"] == "MIT" and project["license-files"] == ["LICENSE"]
    with open(os.path.join(ROOT, "LICENSE"), encoding="utf-8") as f:
        assert f.readline().strip() == "MIT License"
    assert any(c.startswith("Programming Language :: Python :: 3") for c in project["classifiers"])
    # PEP 561: both packages say they are typed, and the wheel carries the marker
    for package in ("analyzer", "dissectors"):
        assert os.path.isfile(os.path.join(ROOT, package, "py.typed"))
        assert "py.typed" in data["tool"]["setuptools"]["package-data"][package]


def test_python_dash_m_analyzer_works_and_is_documented():
    r = subprocess.run([sys.executable, "-m", "analyzer", "--version"], capture_output=True, text=True, cwd=ROOT,
                       timeout=HANG_GUARD, check=False)
    assert r.returncode == 0 and r.stdout.startswith("gimbalscope ")
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        assert "python3 -m analyzer" in f.read()


def test_ci_run_without_go_is_one_clear_line(tmp_path):
    """.ci/run on a machine without Go: it stops with one line saying so. The Python
    and socat steps are stubbed (socat present, pip a no-op) so nothing is installed."""
    if shutil.which("go", path="/usr/bin:/bin"):
        pytest.skip("go is installed where every PATH finds it")
    stubs = tmp_path / "bin"
    stubs.mkdir()
    for name in ("python3", "socat"):
        (stubs / name).write_text("#!/bin/sh\nexit 0\n")
        (stubs / name).chmod(0o755)
    # a copy in a checkout of its own: the real one may hold the .venv .ci/run made,
    # whose python3 would come before the stub
    checkout = tmp_path / "checkout"
    (checkout / ".ci").mkdir(parents=True)
    shutil.copy(os.path.join(ROOT, ".ci", "run"), checkout / ".ci" / "run")
    env = {"PATH": f"{stubs}:/usr/bin:/bin", "HOME": str(tmp_path)}
    r = subprocess.run(["bash", str(checkout / ".ci" / "run")], capture_output=True, text=True, env=env,
                       timeout=HANG_GUARD, check=False)
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "go not found" in lines[0] and "1.21" in lines[0], r.stderr
