"""docs/layout.md is the map of the source: it names every module of both
packages, and every path it names is there.

A name in backquotes that looks like a path (a file with a suffix below, or a
folder ending in ``/``) is read in the folder of the section it is in (the
first path in the section's heading: ``analyzer/tui/model/`` makes
``capture.py`` the model's), else from the repository's root.
"""

from __future__ import annotations

import os
import posixpath
import re

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LAYOUT = os.path.join(ROOT, "docs", "layout.md")

PACKAGES = ("analyzer", "dissectors")
MODULE_SUFFIXES = (".py", ".c")
NOT_NAMED = {"__init__.py", "__main__.py"}   # a package's own files: its folder names them

CODE = re.compile(r"`([^`\n]+)`")
PATH = re.compile(r"[\w.-]+(?:/[\w.-]+)*(?:\.(?:py|pyi|c|md|yml|toml|tcss|properties|svg|go)|/)")


def module_files() -> set[str]:
    """Every module file of both packages, as a path from the root."""
    found = set()
    for top in PACKAGES:
        for folder, dirs, files in os.walk(os.path.join(ROOT, top)):
            dirs[:] = [d for d in dirs if d != "__pycache__"]
            for name in files:
                if name.endswith(MODULE_SUFFIXES) and name not in NOT_NAMED:
                    found.add(os.path.relpath(os.path.join(folder, name), ROOT).replace(os.sep, "/"))
    return found


def _resolved(name: str, folder: str) -> str | None:
    """``name`` in ``folder`` or from the root, whichever is there (None: neither)."""
    for candidate in (posixpath.join(folder, name), name):
        if os.path.exists(os.path.join(ROOT, candidate)):
            return candidate.rstrip("/")
    return None


def named_paths() -> list[tuple[int, str, str | None]]:
    """(line, the name as written, the path it names or None) for every path
    docs/layout.md names."""
    with open(LAYOUT, encoding="utf-8") as f:
        lines = f.read().splitlines()
    out: list[tuple[int, str, str | None]] = []
    folder = ""
    for number, line in enumerate(lines, 1):
        names = [n for n in CODE.findall(line) if PATH.fullmatch(n)]
        if line.startswith("#"):
            first = names[0] if names else ""
            folder = first if first.endswith("/") else posixpath.dirname(first)
        out.extend((number, name, _resolved(name, folder)) for name in names)
    return out


def test_layout_names_every_module() -> None:
    named = {path for _, _, path in named_paths() if path is not None}
    missing = sorted(module_files() - named)
    assert not missing, f"docs/layout.md does not name {len(missing)} modules: {', '.join(missing)}"


def test_every_path_layout_names_is_there() -> None:
    absent = [f"line {number}: {name}" for number, name, path in named_paths() if path is None]
    assert not absent, f"docs/layout.md names paths that are not there: {'; '.join(absent)}"
