"""The TUI's widgets, one a module, each with its own messages: the panes
(event list, detail tree, hex, timeline), the status bar, the filter bar, the
search, go-to, talk and note prompts, and two that draw nothing (the record control, the
background sweep). Each reads the ``CaptureModel`` or what it is handed; none
holds events of its own or reaches into the app."""

from .background_sweep import BackgroundSweep
from .detail_tree import DetailTree
from .event_list import EventList
from .filter_bar import FilterBar
from .goto import GotoBar
from .hex_view import HexView
from .note_bar import NoteBar
from .record import RecordControl
from .search import SearchBar
from .status_bar import StatusBar
from .talk_bar import TalkBar
from .timeline_view import TimelineView

__all__ = ["BackgroundSweep", "DetailTree", "EventList", "FilterBar", "GotoBar", "HexView", "NoteBar",
           "RecordControl", "SearchBar", "StatusBar", "TalkBar", "TimelineView"]
