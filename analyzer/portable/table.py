"""The command table (``dissectors.commands``) and the problem table
(``dissectors.problems``) as Python source text, for a decoder that runs where
gimbalscope cannot be imported (``frame_decoder``): each layout's regular
expression (the one ``dissectors.fields.Layout`` compiles) and its fields'
codecs as data. The table's derive functions and the summary filling are
copied in as their source, so a value the table derives is derived the same
way there; a derive function that uses a name the decoder does not define
fails the generators' tests, not a user's PulseView or Logic 2.
"""

from __future__ import annotations

import inspect
import pprint
import re

from dissectors import problems as P
from dissectors.commands import BAUD_CODES, COMMANDS, ERROR_BITS, STATUS_BITS, Command, bit_names, field_types
from dissectors.dissect import summarize, summary_value
from dissectors.fields import Field, Layout

from ..analysis.pairing import Timeouts

DEFAULTS = Timeouts()   # the pairing's timeouts a decoder without settings for them uses
# what the derive functions of the table call, copied in with them
_DERIVE_HELPERS = (bit_names,)


def _field(f: Field) -> dict:
    return {"name": f.name, "codec": f.codec, "divisor": f.divisor, "signed": f.signed, "strip": f.strip,
            "choices": dict(f.choices), "valid": f.valid, "hex": f.hexdigits}


def _lead(layout: Layout) -> bytes | None:
    """What the character after the layout's leading literal may be (``Layout.lead_ok``), as a regex."""
    for part in layout.parts[1:] if layout.prefix else layout.parts:
        return re.escape(part[:1]) if isinstance(part, bytes) else part.lead
    return None


def _layout(layout: Layout) -> dict:
    return {"regex": layout.regex.pattern, "prefix": layout.prefix, "lead": _lead(layout),
            "width": layout.width, "describe": layout.describe(),
            "fields": [_field(f) for f in layout.fields],
            "derive": layout.derive.__name__ if layout.derive is not None else None}


def _command(c: Command) -> dict:
    return {"id": c.id, "name": c.name, "ref": c.ref, "reserved": c.reserved, "due": c.result_due,
            "result_timeout": c.result_timeout,
            "summary": c.summary, "result_summary": c.result_summary,
            "layout": _layout(c.layout), "results": [_layout(r) for r in c.result]}


def _derives() -> list:
    seen: dict[str, object] = {}
    for c in COMMANDS:
        for layout in (c.layout, *c.result):
            if layout.derive is not None:
                seen.setdefault(layout.derive.__name__, layout.derive)
    return list(seen.values())


def _functions() -> str:
    return "\n\n".join(inspect.getsource(fn).strip()
                       for fn in [*_DERIVE_HELPERS, *_derives(), summary_value, summarize])


def table_values() -> dict[str, str]:
    """The tables' placeholders of ``frame_decoder.TEMPLATE``, as source text."""
    return {
        # problem id -> (category text, severity)
        "PROBLEMS": pprint.pformat({info.name: (info.text, info.severity) for info in P.TABLE}, width=110),
        "BAUD_CODES": repr(BAUD_CODES),
        "ERROR_BITS": repr(ERROR_BITS),
        "STATUS_BITS": repr(STATUS_BITS),
        "COMMANDS": pprint.pformat([_command(c) for c in COMMANDS], width=110, sort_dicts=False),
        "FUNCTIONS": _functions(),
        "DERIVE_NAMES": ", ".join(f"{fn.__name__!r}: {fn.__name__}" for fn in _derives()),
        "UNITS": repr({name: ft.unit for name, ft in field_types().items() if ft.unit}),
        "TIMEOUTS": repr((DEFAULTS.ack, DEFAULTS.result, DEFAULTS.untimed_window)),
    }
