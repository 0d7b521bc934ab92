import os

from dissectors.reference import render

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_docs_fields_md_is_generated_from_the_table():
    with open(os.path.join(ROOT, "docs", "fields.md"), encoding="utf-8") as f:
        assert f.read() == render(), "run: python -m dissectors.reference > docs/fields.md"
