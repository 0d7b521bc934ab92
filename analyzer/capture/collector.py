"""The garbage collector's young threshold while captures are decoded.

Decoding allocates millions of short-lived, cycle-free events; with the default
young threshold (700) the collector scans each of them once or more before
reference counting frees it, which costs as much as decoding. While any capture
is being iterated (``Options.tune_gc``), the young generation is collected every
100 000 allocations instead; the old thresholds come back afterwards.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

YOUNG_THRESHOLD = 100_000

_depth = 0                              # captures being iterated now
_saved: tuple[int, ...] | None = None   # the thresholds before the first of them


@contextmanager
def fewer_collections(enabled: bool = True) -> Iterator[None]:
    """Raise the young threshold while the block runs (nested uses share it)."""
    if not enabled:
        yield
        return
    _busy(+1)
    try:
        yield
    finally:
        _busy(-1)


def _busy(step: int) -> None:
    global _depth, _saved
    if step > 0:
        if _depth == 0:
            _saved = gc.get_threshold()
            gc.set_threshold(YOUNG_THRESHOLD, *_saved[1:])
        _depth += 1
    else:
        _depth -= 1
        if _depth == 0 and _saved is not None:
            gc.set_threshold(*_saved)
