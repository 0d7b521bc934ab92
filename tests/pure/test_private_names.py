"""A module's ``_private`` names stay in it (docs/architecture.md): no module of
analyzer/ or dissectors/ imports another module's private name, or reads a
private attribute of an object that is not its own (``self``, ``cls``, or a
name of its own module). What the standard library makes public with a leading
underscore (a named tuple's ``_replace``, ``sys._getframe``) is allowed by name.
"""

from __future__ import annotations

import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# the standard library's public names that start with an underscore
PUBLIC_UNDERSCORED = frozenset(("_replace", "_asdict", "_fields", "_make", "_field_defaults", "_getframe",
                                "_exit", "_current_frames", "_name_"))
OWN = frozenset(("self", "cls", "mcs"))
# the one adapter to the mcap library's internals, held by tests/pure/test_mcap_internals.py
ADAPTERS = frozenset((os.path.join("analyzer", "writers", "mcap_internals.py"),))


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _files() -> list[str]:
    out = []
    for top in ("analyzer", "dissectors"):
        for folder, _, files in os.walk(os.path.join(ROOT, top)):
            out += [os.path.join(folder, f) for f in files if f.endswith(".py")]
    return sorted(out)


def _own_names(tree: ast.Module) -> set[str]:
    """Names bound at the top of the module itself (its classes, functions, globals)."""
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
    return names


def reaches(path: str) -> list[str]:
    """Where the module at ``path`` uses another module's private name."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read(), path)
    own = _own_names(tree)
    where = os.path.relpath(path, ROOT)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            # a package's private compiled part, imported by its own package, is the package's
            own_package = node.level > 0 and os.path.basename(path) in ("deframer.py", "__init__.py")
            for alias in node.names:
                if _private(alias.name) and not own_package:
                    found.append(f"{where}:{node.lineno}: imports {alias.name} from {node.module or '.'}")
        elif isinstance(node, ast.Attribute) and _private(node.attr) and node.attr not in PUBLIC_UNDERSCORED:
            base = node.value
            if isinstance(base, ast.Name) and (base.id in OWN or base.id in own):
                continue
            if isinstance(base, ast.Call) and isinstance(base.func, ast.Name) and base.func.id == "super":
                continue
            found.append(f"{where}:{node.lineno}: reads .{node.attr} of {ast.unparse(base)}")
    return found


def test_no_module_uses_another_modules_private_names():
    found = [line for path in _files() if os.path.relpath(path, ROOT) not in ADAPTERS for line in reaches(path)]
    assert not found, "\n".join(found)


def test_the_check_sees_a_reach(tmp_path):
    # the rule itself: each kind of reach is caught, and a module's own private names are not
    module = tmp_path / "m.py"
    module.write_text("from .store import _lines\n"
                      "class Own:\n"
                      "    def f(self, store):\n"
                      "        return self._x, store._columns, Own._y, _helper()\n")
    assert [line.split(": ", 1)[1] for line in reaches(str(module))] == [
        "imports _lines from store", "reads ._columns of store"]
