"""Counts read as English: "1 device address", "3 device addresses", never
"address(es)" or "(s)" (analyzer/words.py words them)."""

import ast
import os
import re

from analyzer.analysis.findings import DEVICE_MAP
from tests.conftest import ROOT
from tests.pure.test_doctor import findings_of, polls

# Lua source held in a Python string, where f(s) is a call, not a plural
LUA = os.path.join(ROOT, "analyzer", "wireshark", "lua.py")


def test_the_device_map_counts_addresses_and_commands_in_english(tmp_path):
    one = tmp_path / "one.log"
    one.write_text(polls(rounds=1).socat_log())            # one P? to 1.1.1
    found = findings_of(one)[DEVICE_MAP]
    assert found.title == "1 device address addressed"
    assert found.detail == "1.1.1: 1 command, answers on B"
    three = tmp_path / "three.log"
    three.write_text(polls(rounds=3).socat_log())          # P? to 1.1.1, 1.1.2, 1.1.1
    found = findings_of(three)[DEVICE_MAP]
    assert found.title == "2 device addresses addressed"
    assert found.detail.splitlines() == ["1.1.1: 2 commands, answers on B", "1.1.2: 1 command, answers on B"]


def _strings(tree):
    """The string constants of a module but its docstrings (a bare string statement)."""
    bare = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in bare:
            yield node.lineno, node.value


def test_no_message_counts_with_an_optional_plural():
    hedged = re.compile(r"[a-z]\(e?s\)")
    found = []
    for folder, _, files in os.walk(os.path.join(ROOT, "analyzer")):
        for name in files:
            path = os.path.join(folder, name)
            if not name.endswith(".py") or path == LUA:
                continue
            with open(path, encoding="utf-8") as f:
                tree = ast.parse(f.read())
            found += [f"{os.path.relpath(path, ROOT)}:{line}: {text!r}" for line, text in _strings(tree)
                      if hedged.search(text)]
    assert found == []
