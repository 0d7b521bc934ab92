"""Opening a capture: ``open`` (files) and ``open_live`` (serial ports) give a
``Capture``, which deframes each line, puts the lines in wire order and pairs the
events (analyzer/capture/capture.py).

The package's parts: ``options`` (``Options``, the decoding options, and the line
settings made of them), ``recorded`` (the options a recording or a logic
capture brings of itself), ``capture`` (``Capture``), ``merge`` (wire order of two
timed lines, with skew correction), ``rates`` (following the link's rate),
``undecoded`` (bytes a live tap passed over), ``collector`` (the garbage
collector while decoding) and ``wireclock`` (how far the wire has been seen).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..analysis.pairing import Timeouts
from ..sources import Source, detect
from ..sources.files import display_name
from .capture import Capture
from .options import Options
from .recorded import recorded_options
from .undecoded import UNDECODED_EVERY


def open_live(ports: list[str], options: Options | None = None,
              on_warning: Callable[[str], None] | None = None) -> Capture:
    """A live capture from one or two serial ports (device names or pyserial URLs)."""
    from ..sources.serialport import SerialTap

    options = options or Options()
    tap = SerialTap(ports, baud=options.baud, data_bits=options.data_bits, parity=options.parity,
                    stop_bits=options.stop_bits)
    capture = Capture(tap, options, on_warning)
    capture.inputs = tuple(ports)
    return capture


def open(*paths: str, options: Options | None = None, on_warning: Callable[[str], None] | None = None,
         filter: str | None = None, **kw: Any) -> Capture:
    """Open a capture: one socat log, one raw single-line dump, two raw dumps
    (line A then line B), or MCAP recordings of one tap (one, or its parts).
    Keyword arguments set ``Options`` fields (``baud=19200``); those given, like
    the ``explicit`` fields of ``options``, win over what a recording says of its
    own settings, and each that differs from it is said once (a warning).
    ``filter`` (the language of ``decode --filter``, analyzer/analysis/filter.py) keeps
    only the events it matches when iterating, in ``to_arrow()`` and in
    ``transactions()`` (by their command); a bad one raises ``FilterError``.
    Raises ``CaptureError`` with a one-line message for anything unreadable."""
    keep = None
    if filter is not None:
        from ..analysis.filter import compile_filter
        keep = compile_filter(filter)   # first: a typo costs no file opened
    if options is None:
        timeouts = kw.pop("timeouts", None)
        given = frozenset(kw) | ({"ack_timeout", "result_timeout", "timeouts"} if timeouts else frozenset())
        options = Options(timeouts=timeouts or Timeouts(), explicit=given, **kw)
    source = detect(list(paths), options.read_settings)
    name = paths[0] if len(paths) == 1 else f"{paths[0]} (and {len(paths) - 1} more)"
    capture = _capture_of(source, options, display_name(name), tuple(paths), on_warning)
    capture.keep = keep
    return capture


def open_samples(path: str, samplerate: float, unitsize: int = 1, options: Options | None = None,
                 given: str | None = None) -> Capture:
    """A live capture from a logic analyser's bare sample stream at ``path`` (``-``:
    standard input; docs/instruments.md, "A live logic analyser"), decoded with the
    rate and format its software UART measures unless ``options`` give them.
    ``given``: the input as the user named it, when ``path`` is where it was moved
    (``/dev/fd/N``: standard input moved aside for the TUI)."""
    from ..sources.samplestream import open_sample_stream

    options = options or Options()
    given = given or path
    source = open_sample_stream(path, samplerate, unitsize, options.read_settings, display_name(given))
    return _capture_of(source, options, display_name(given), (given,), None)


def _capture_of(source: Source, options: Options, name: str, inputs: tuple[str, ...],
                on_warning: Callable[[str], None] | None) -> Capture:
    """The capture reading ``source``, with the settings it brings of itself (a
    recording's metadata, a logic capture's measure) where ``options`` do not give
    them; what differs from an option given is said once."""
    try:
        options, said = recorded_options(options, source, name)
    except BaseException:
        source.close()
        raise
    for message in said:
        source.warn_later(message)
    capture = Capture(source, options, on_warning)
    capture.inputs = tuple(inputs)
    return capture


__all__ = ["UNDECODED_EVERY", "Capture", "Options", "open", "open_live", "open_samples"]
