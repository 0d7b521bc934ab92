"""The README's Python examples run as written, from the repository root."""

import os
import re

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def blocks():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        return re.findall(r"```python\n(.*?)```", f.read(), re.S)


@pytest.mark.parametrize("code", blocks())
def test_readme_python_example_runs(code, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)   # our own documentation
    assert capsys.readouterr().out.strip(), "each example prints something"


def test_readme_has_examples():
    assert len(blocks()) >= 2
