"""What the TUI shows, without Textual: ``CaptureModel`` (capture.py) and the
parts it is made of, each a class of its own module:

- ``FilterView`` (filter.py): the filter's text, history and matching rows
- ``Follow`` and ``Marks`` (follow.py): follow mode, "+N new", the marked rows
- ``Navigation`` (navigation.py): next error, pair, same device, marks, search
- ``RowText`` (row_text.py): a row's cells and the time mode
- ``Replay`` and ``Playback`` (replay.py): a replay's pace and position
- ``Totals`` (totals.py): the error and checksum-error counts, and the
  statistics (``Stats``, analyzer/analysis/stats.py) and the device map
  (``DeviceInfo``, analyzer/formats/store_stats.py), worked out from the store's columns when asked
  (analyzer/formats/store_stats.py)
- ``PositionPlots`` (plots.py), fed the events
- ``SampledInput`` (sampled.py): a logic capture's input and each line's
  channel and measured rate and format, as the feed's batches carry them

The widgets only read them; tests/pure checks them without a screen.
"""

from ...formats.store import is_error
from ...formats.store_stats import DeviceInfo
from ...formats.sweep import Cancelled
from ..detail import DetailNode, hex_lines
from .capture import CaptureModel
from .replay import Playback

__all__ = ["Cancelled", "CaptureModel", "DetailNode", "DeviceInfo", "Playback", "hex_lines", "is_error"]
