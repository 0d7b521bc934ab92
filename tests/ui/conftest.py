"""What every TUI test starts from."""

import pytest

from analyzer.sources.meter import READS


@pytest.fixture(autouse=True)
def fresh_read_meter():
    """The status bar's load progress reads ``READS``, the meter of every input
    this process opened (a command clears it when it starts, analyzer/cli/main.py):
    each test starts as a command does, so that the sizes are its own capture's."""
    READS.clear()
    yield
