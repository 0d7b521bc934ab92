"""Reading back the boxed tables that ``stats``, ``report`` and the TUI's
statistics screen draw (analyzer/formats/fit_width.py), so tests can compare
what is shown with the numbers, independently of how it was laid out."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from dataclasses import dataclass, field

from tests.conftest import ROOT


def run_piped(*args, columns: int | None) -> str:
    """The command's standard output piped, with COLUMNS set to ``columns`` (None:
    unset, as in a pipe from a script); it must succeed."""
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    if columns is not None:
        env["COLUMNS"] = str(columns)
    exe = shutil.which("gimbalscope")
    cmd = [exe] if exe else [sys.executable, "-m", "analyzer"]
    r = subprocess.run(cmd + [str(a) for a in args], capture_output=True, text=True, env=env, cwd=ROOT,
                       timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    return r.stdout


def assert_fits(text: str, width: int) -> None:
    """No line wider than ``width`` or ending in spaces, and nothing cut short."""
    for line in text.splitlines():
        assert len(line) <= width, line
        assert line == line.rstrip(), repr(line)
    assert "…" not in text


@dataclass
class Drawn:
    title: str                      # the line above the box ("" when none)
    headers: list[str]              # each column's name, a stacked header's words joined by spaces
    rows: list[list[str]] = field(default_factory=list)


def _cells(line: str, bar: str) -> list[str]:
    return [c.strip() for c in line.strip()[1:-1].split(bar)]


def read_tables(text: str) -> list[Drawn]:
    """Every boxed table in ``text``, in order."""
    lines = [line.rstrip() for line in text.splitlines()]
    tables: list[Drawn] = []
    i = 0
    while i < len(lines):
        if not lines[i].lstrip().startswith("┏"):
            i += 1
            continue
        title = lines[i - 1].strip() if i and lines[i - 1].strip()[:1] not in ("┃", "│", "└", "") else ""
        i += 1
        stacked: list[list[str]] = []
        while lines[i].lstrip().startswith("┃"):
            stacked.append(_cells(lines[i], "┃"))
            i += 1
        headers = [" ".join(word for word in words if word) for words in zip(*stacked)]
        assert lines[i].lstrip().startswith("┡"), lines[i]
        i += 1
        table = Drawn(title, headers)
        while lines[i].lstrip().startswith("│"):
            table.rows.append(_cells(lines[i], "│"))
            i += 1
        assert lines[i].lstrip().startswith("└"), lines[i]
        tables.append(table)
    return tables


def cells(tables: list[Drawn]) -> dict[tuple[str, str], str]:
    """What the tables show, as (the row's key cell, the column's name) → cell; a
    column shown twice (the key column aside) fails."""
    out: dict[tuple[str, str], str] = {}
    for table in tables:
        for row in table.rows:
            for name, cell in zip(table.headers[1:], row[1:]):
                assert (row[0], name) not in out, (row[0], name)
                out[row[0], name] = cell
    return out


def headers(tables: list[Drawn]) -> list[str]:
    """The columns' names in the order shown, the key column once."""
    out = tables[0].headers[:1] if tables else []
    for table in tables:
        out += table.headers[1:]
    return out
