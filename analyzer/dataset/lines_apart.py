"""Two raw dumps given to ``export`` as two captures that are one capture's two lines.

``decode ctl.bin dev.bin`` reads two dumps as line A and line B; ``export`` reads
each input as a capture of its own and joins one capture's files with ``+``. Given
the ``decode`` form, it would export a controller's side with every command
unanswered and a device's side of answers to nothing, and exit 0. So before
exporting, neighbouring single raw dumps are tried together: when one of them
alone has (almost) no command answered, and read as line A beside the other as
line B most of its commands are, while the other carries no commands of its own (a
single-line dump of the whole bus does), they are one capture, and export refuses,
naming the ``+`` form. ``--separate`` says they really are two captures."""

from __future__ import annotations

from itertools import islice, pairwise

from dissectors.event import COMMAND, NO_RESULT, OK, ST_NIC

from ..analysis.signs import WiringSigns
from ..capture import Options
from ..capture import open as open_capture
from ..errors import CaptureError
from ..outfile import show
from ..sources.rawdump import RawDumpSource
from ..words import counted

SAMPLE = 2000          # events read of each try: enough to tell, cheap beside the export
MIN_COMMANDS = 5
ALONE_AT_MOST = 0.2    # commands answered in the controller's dump read alone
TOGETHER_AT_LEAST = 0.5


def _answered(paths: tuple[str, ...], options: Options) -> tuple[int, int, int] | None:
    """(commands, commands answered, command frames on line B) in the first events
    of ``paths`` read as one capture; None when they are not raw dumps or cannot be
    read (export says why)."""
    try:
        capture = open_capture(*paths, options=options)
    except CaptureError:
        return None
    try:
        if not isinstance(capture.source, RawDumpSource):
            return None
        commands = answered = 0
        signs = WiringSigns(capture.lines)
        for ev in islice(capture, SAMPLE):
            signs.add(ev)
            if ev.kind == COMMAND:
                commands += 1
                answered += ev.status in (OK, ST_NIC, NO_RESULT)
        return commands, answered, len(signs.commands_on_b)
    except CaptureError:
        return None
    finally:
        capture.source.close()


def one_capture(a: str, b: str, options: Options) -> str | None:
    """Why ``a`` (line A) and ``b`` (line B) look like one capture's two lines; None if not."""
    alone = _answered((a,), options)
    if alone is None or alone[0] < MIN_COMMANDS or alone[1] > ALONE_AT_MOST * alone[0]:
        return None
    together = _answered((a, b), options)
    if together is None or together[1] < TOGETHER_AT_LEAST * together[0] or together[2] > ALONE_AT_MOST * together[0]:
        return None
    return f"{together[1]:,} of the first {counted(together[0], 'command')} on {show(a)} are answered on {show(b)}"


def lines_of_one_capture(inputs: list[tuple[str, ...]], options: Options) -> str | None:
    """The refusal for neighbouring inputs that are one capture's lines, or None."""
    for first, second in pairwise(inputs):
        if len(first) != 1 or len(second) != 1:
            continue
        for a, b in ((first[0], second[0]), (second[0], first[0])):
            why = one_capture(a, b, options)
            if why is not None:
                return (f"{show(first[0])} and {show(second[0])} look like the two lines of one capture ({why}): "
                        f"export them as one input, {show(a)}+{show(b)}, or add --separate if they are two captures")
    return None
