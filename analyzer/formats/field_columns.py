"""The decoded fields as columns of a table (the Parquet dataset, CSV): one
column per field name of the command table (``dissectors.commands.field_types``,
the names JSON Lines, filters, the TUI and MCAP use), each keeping its name,
unless an event's own key has it (the ``status`` of an ``AW`` result, Table 15,
beside the event's ``status``): that column is ``field_<name>``.
"""

from __future__ import annotations

from collections.abc import Iterable

from dissectors.commands import FieldType, field_types


def field_columns(taken: Iterable[str]) -> list[tuple[str, str, FieldType]]:
    """(field name, column name, its type) for every field of the command table,
    in the table's order; ``taken``: the table's other column names."""
    taken = set(taken)
    return [(name, f"field_{name}" if name in taken else name, ft) for name, ft in field_types().items()]
