"""The Python examples of the README and of every docs/*.md page run as written,
as from the repository root (in a scratch folder that sees its captures, so what an
example writes stays out of the checkout). A fragment that cannot run as written is preceded by the
line ``<!-- not run -->`` (keep them rare)."""

import glob
import os
import re

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
NOT_RUN = "<!-- not run -->"
PAGES = ["README.md"] + sorted(os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(ROOT, "docs", "*.md")))


def blocks(page: str, *, skipped: bool = False) -> list[str]:
    """The ```python blocks of a page: those that run, or (skipped=True) those marked not run."""
    with open(os.path.join(ROOT, page), encoding="utf-8") as f:
        text = f.read()
    found = []
    for m in re.finditer(r"^(?:(<!-- not run -->)[ \t]*\n)?```python[^\n]*\n(.*?)^```", text, re.DOTALL | re.MULTILINE):
        if bool(m.group(1)) == skipped:
            found.append(m.group(2))
    return found


def examples():
    for page in PAGES:
        for i, code in enumerate(blocks(page), 1):
            yield pytest.param(page, code, id=f"{page}-{i}")


@pytest.mark.parametrize(("page", "code"), list(examples()))
def test_python_example_runs(page, code, tmp_path, monkeypatch, capsys):
    (tmp_path / "captures").symlink_to(os.path.join(ROOT, "captures"))
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(code, page, "exec"), namespace)   # noqa: S102 - our own documentation's examples
    assert capsys.readouterr().out.strip(), "each example prints something"


def test_readme_has_examples():
    assert len(blocks("README.md")) >= 2


def test_docs_pages_are_read():
    assert "docs/python-api.md" in PAGES and len(list(examples())) > len(blocks("README.md"))


def test_fragments_not_run_are_rare():
    """Every python block is either run or marked; marked ones stay few."""
    marked = sum(len(blocks(page, skipped=True)) for page in PAGES)
    for page in PAGES:
        with open(os.path.join(ROOT, page), encoding="utf-8") as f:
            total = len(re.findall(r"^```python", f.read(), re.MULTILINE))
        assert total == len(blocks(page)) + len(blocks(page, skipped=True)), page
    assert marked <= 3
