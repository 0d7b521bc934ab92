"""The packages' layers (docs/architecture.md, "Layers"): every import in
analyzer/ and dissectors/ goes to the same layer or one below, and no modules
import each other in a circle. Every import counts: at the top of a module, in a
function (imported when needed), or for type hints only (``TYPE_CHECKING``).

The list below is the written picture of the house; a module that fits no entry
fails the test, so a new folder has to be placed on purpose.
"""

from __future__ import annotations

import ast
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Bottom first. A module belongs to the entry naming it or its nearest package.
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("the protocol: frames, fields, commands, events", ("dissectors",)),
    (("foundations: version, extras, docs, errors, lines, output files, capture info, styles, words, templates, URIs,"
      " screens, network addresses, work in another process"),
     ("analyzer.version", "analyzer.extras", "analyzer.docs", "analyzer.errors", "analyzer.lines", "analyzer.outfile",
      "analyzer.info", "analyzer.styles", "analyzer.words", "analyzer.templates", "analyzer.uris",
      "analyzer.screen", "analyzer.netaddress", "analyzer.worker_process")),
    ("analysis of events, the physical layer (the software UART), and the simulator",
     ("analyzer.analysis", "analyzer.physical", "analyzer.simulation")),
    ("formats that readers and writers share", ("analyzer.formats", "analyzer.output")),
    ("readers", ("analyzer.sources",)),
    ("the capture and its runner", ("analyzer.capture", "analyzer.runner")),
    ("writers", ("analyzer.writers",)),
    ("listeners", ("analyzer.listeners",)),
    ("jobs: the fleet dataset, Wireshark, sigrok, Saleae, the portable decoder the last two embed, talking to gimbals",
     ("analyzer.dataset", "analyzer.wireshark", "analyzer.sigrok", "analyzer.saleae", "analyzer.portable",
      "analyzer.talk")),
    ("the terminal UI", ("analyzer.tui",)),
    ("the command line", ("analyzer.cli",)),
    ("the package's face", ("analyzer", "analyzer.__main__")),
]


def _modules() -> dict[str, str]:
    """Module name → file, for every module of both packages."""
    found = {}
    for top in ("analyzer", "dissectors"):
        for folder, _, files in os.walk(os.path.join(ROOT, top)):
            for name in files:
                if name.endswith(".py"):
                    path = os.path.join(folder, name)
                    parts = os.path.relpath(path, ROOT)[:-3].split(os.sep)
                    if parts[-1] == "__init__":
                        parts.pop()
                    found[".".join(parts)] = path
    return found


MODULES = _modules()


def layer_of(module: str) -> int:
    best, where = -1, None
    for i, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best:
                best, where = len(p), i
    if where is None:
        raise AssertionError(f"{module} is in no layer: place it in LAYERS")
    return where


def _absolute(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _existing(name: str) -> str | None:
    """The module ``name`` is, or lives in (a name imported from a module)."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        candidate = ".".join(parts[:i])
        if candidate in MODULES:
            return candidate
    return None


def imports_of(module: str) -> dict[str, int]:
    """The package modules ``module`` imports → the line of the first import."""
    path = MODULES[module]
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read(), path)
    found: dict[str, int] = {}
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _absolute(module, path.endswith("__init__.py"), node)
            for a in node.names:
                # ``from pkg import mod`` imports the module; ``from mod import name`` the module
                targets.append(f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base)
        for t in targets:
            target = _existing(t)
            # a package's own parent is loaded by Python first: not an import of the code
            if target and target != module and not module.startswith(target + "."):
                found.setdefault(target, node.lineno)
    return found


GRAPH = {m: imports_of(m) for m in MODULES}


def test_every_module_has_a_layer():
    for module in MODULES:
        layer_of(module)


def test_imports_only_go_down():
    upward = []
    for module, targets in sorted(GRAPH.items()):
        for target, line in targets.items():
            if layer_of(target) > layer_of(module):
                upward.append(f"{os.path.relpath(MODULES[module], ROOT)}:{line} imports {target} "
                              f"({LAYERS[layer_of(module)][0]} → {LAYERS[layer_of(target)][0]})")
    assert not upward, "imports from a lower layer to a higher one:\n" + "\n".join(upward)


def _cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycles():
    assert _cycles(GRAPH) == []


# The checker itself, on graphs made by hand: it must see what it is there to see.
def test_the_cycle_finder_finds_a_type_only_circle():
    assert _cycles({"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 3}, "d": {"a": 1}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b": 1}, "b": {}}) == []


@pytest.mark.parametrize("module, layer", [
    ("dissectors.deframer", 0), ("analyzer.errors", 1), ("analyzer.analysis.pairing", 2),
    ("analyzer.formats.pdu", 3), ("analyzer.sources.rawdump", 4), ("analyzer.capture", 5),
    ("analyzer.cli.main", len(LAYERS) - 2), ("analyzer", len(LAYERS) - 1),
])
def test_modules_are_placed_by_their_nearest_package(module, layer):
    assert layer_of(module) == layer


def test_imports_are_read_from_functions_and_type_hints_too():
    # sources/base.py reads ``Input`` for type hints only, under TYPE_CHECKING
    assert "analyzer.sources.files" in GRAPH["analyzer.sources.base"]
    # capture/capture.py imports the Parquet rows inside a function (to_arrow)
    assert any(t.startswith("analyzer.formats") for t in GRAPH["analyzer.capture.capture"])
