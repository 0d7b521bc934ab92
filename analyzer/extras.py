"""The optional parts of an install (pyproject.toml's extras), and the one line that
says which to install when a command needs a part that is not there.

The fleet stack (pyarrow, DuckDB, matplotlib) is most of an install's size and only
``export``, ``query``, ``report`` and ``Capture.to_arrow()`` use it, so it is the
``fleet`` extra; those import it when they run, and the import error becomes this
hint rather than a traceback."""

from __future__ import annotations

import importlib.util
import os
import shlex
import sys

from .docs import clone_folder

# top-level module → the extra that installs it
EXTRA_OF = {"pyarrow": "fleet", "duckdb": "fleet", "matplotlib": "fleet", "pandas": "pandas",
            "pyspark": "spark", "py4j": "spark"}


def missing_extra(error: ImportError, needed_by: str) -> str | None:
    """The one line for ``error`` when it is an extra's package that is not
    installed (``needed_by`` names what wanted it: a command, a method); None for
    any other import error, which is a bug to show whole."""
    top = (error.name or "").split(".")[0]
    extra = EXTRA_OF.get(top)
    # installed but broken inside is not "missing": that error stays as it is
    if extra is None or importlib.util.find_spec(top) is not None:
        return None
    return f"{needed_by} needs {top}, which is not installed: it comes with the {extra} extra: {install_command(extra)}"


def install_command(extra: str) -> str:
    """The command that adds ``extra`` to this very install, as a user can paste
    it: the pip of the virtual environment running us (the quick start never
    activates it, so the ``pip`` on PATH is another one), and the clone's own
    folder when the package is installed from one (``pip install -e``)."""
    if sys.prefix != sys.base_prefix:   # a virtual environment
        pip = shlex.quote(os.path.join(sys.prefix, "Scripts" if os.name == "nt" else "bin", "pip"))
    else:
        pip = f"{shlex.quote(sys.executable)} -m pip"
    clone = clone_folder()
    if clone is not None:
        return f"{pip} install -e {shlex.quote(f'{clone}[{extra}]')}"
    return f"{pip} install {shlex.quote(f'gimbalscope[{extra}]')}"
