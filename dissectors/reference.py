"""Render the command table as Markdown (docs/fields.md), so the documentation
of every command, field and unit comes from the same table that decodes them.

    python -m dissectors.reference > docs/fields.md
"""

from __future__ import annotations

from .commands import COMMANDS, DERIVED_FIELDS, DUE, OPTIONAL, field_types
from .fields import Layout


def _fields(layout: Layout) -> str:
    out = []
    for f in layout.fields:
        unit = f" [{f.unit}]" if f.unit else ""
        out.append(f"`{f.name}`{unit}")
    return ", ".join(out) or "—"


def render() -> str:
    lines = [
        "# Command and field reference",
        "",
        "Generated from `dissectors/commands.py` by `python -m dissectors.reference`; do not edit by hand.",
        "Every field name here is the one used in JSON Lines, `--filter`, statistics, MCAP recordings and the TUI,",
        "and by `gimbalscope send` (`send PORT P --to 1.1.3 azimuth_deg=10 elevation_deg=-5`). The effect says",
        "what sending it does: `query` only asks, `stop` stops a motion, `motion` moves the mount or the lens",
        "(sent with `--allow-motion`), `config` changes the address, rate, settings or outputs (`--allow-config`).",
        "",
        "| id | name | effect | payload | fields | result | result fields | spec |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in COMMANDS:
        due = {DUE: "due", OPTIONAL: "optional"}.get(c.result_due, "—")
        res_layouts = " or ".join(f"`{r.describe()}`" for r in c.result) or "—"
        res_fields = "; ".join(_fields(r) for r in c.result) or "—"
        name = c.name + (" (reserved)" if c.reserved else "") + (f"; {c.notes}" if c.notes else "")
        lines.append(f"| `{c.id}` | {name} | {c.effect} | `{c.layout.describe()}` | {_fields(c.layout)} | {due}: {res_layouts} "
                     f"| {res_fields} | {c.ref} |")
    lines += ["", "Derived fields (computed from the decoded ones): "
              + ", ".join(f"`{n}`" for n in DERIVED_FIELDS) + ".", ""]
    lines += ["## Field types", "",
              ("One name, one type, wherever it appears (the JSON types of the MCAP and Foxglove schemas, "
               "docs/foxglove.md). A value that cannot be given (a reserved rate code's `baud`, an unknown "
               "choice) is `null` in JSON Lines and left out of MCAP messages."), "",
              "| field | type | unit | meaning |", "|---|---|---|---|"]
    for name, ft in sorted(field_types().items()):
        what = ft.type if ft.items is None else f"array of {ft.items}"
        lines.append(f"| `{name}` | {what} | {ft.unit or '—'} | {ft.desc or '—'} |")
    lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(render(), end="")
