"""Where the documentation pages are, for the words that point a user to one:
the clone's own ``docs/`` folder when the package runs from a clone (``pip
install -e``), else the page's path in the source repository."""

from __future__ import annotations

import os


def clone_folder() -> str | None:
    """The folder of the clone the package runs from, or None when it is installed
    (a wheel in site-packages)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    try:
        with open(os.path.join(root, "pyproject.toml"), encoding="utf-8") as f:
            named = 'name = "gimbalscope"' in f.read()
    except OSError:
        return None
    return root if named else None


def page(name: str) -> str:
    """``page("instruments.md")``: the page as a user can open it."""
    clone = clone_folder()
    if clone is not None and os.path.isfile(os.path.join(clone, "docs", name)):
        return os.path.join(clone, "docs", name)
    return f"docs/{name} in gimbalscope's source repository"
