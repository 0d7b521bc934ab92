"""The fleet dataset's tables as Arrow schemas (docs/dataset.md): ``events``,
``transactions`` and ``findings``, written as Hive-partitioned Parquet by
``gimbalscope export`` and read by ``query``, ``report``, DuckDB, Polars or Spark.

The event columns are the JSON Lines contract (docs/json-lines.md)
flattened: ``fields`` becomes one typed column per field name of the command
table (``dissectors.commands.field_types``, the same names as JSON Lines,
filters, the TUI and MCAP), null where the event has no such value. A field
whose name is also an event key (the ``status`` of an ``AW`` result, Table 15)
is the column ``field_<name>``: the event's own key keeps its name. Every row
also says which capture it comes from (``capture``), the site (``site``) and its
absolute time (``ts``, UTC); the partition column ``date`` is in the path.
"""

from __future__ import annotations

from collections.abc import Iterable

import pyarrow as pa

from .field_columns import field_columns

# each table's columns before the field columns; order is the files' column order
TIME = pa.timestamp("us", tz="UTC")   # microseconds: what Spark reads (it refuses nanoseconds)
_ARROW = {"integer": pa.int64(), "number": pa.float64(), "string": pa.string(), "boolean": pa.bool_()}

EVENT_COLUMNS: list[tuple[str, pa.DataType]] = [
    ("capture", pa.string()),
    ("site", pa.string()),
    ("number", pa.int64()),
    ("ts", TIME),
    ("t", pa.float64()),
    ("t_end", pa.float64()),
    ("line", pa.string()),
    ("offset", pa.int64()),
    ("kind", pa.string()),
    ("command", pa.string()),
    ("device", pa.string()),
    ("dst", pa.list_(pa.int64())),
    ("src", pa.int64()),
    ("payload", pa.string()),
    ("checksum_ok", pa.bool_()),
    ("problems", pa.list_(pa.string())),
    ("txn", pa.int64()),
    ("status", pa.string()),
    ("latency", pa.float64()),
    ("retransmission", pa.bool_()),
    ("request", pa.int64()),
    ("raw", pa.binary()),
]

TRANSACTION_COLUMNS: list[tuple[str, pa.DataType]] = [
    ("capture", pa.string()),
    ("site", pa.string()),
    ("txn", pa.int64()),
    ("number", pa.int64()),          # the command's event number (the answers' ``request``)
    ("ts", TIME),                   # the command's time
    ("t", pa.float64()),
    ("device", pa.string()),
    ("command", pa.string()),
    ("status", pa.string()),
    ("retransmission", pa.bool_()),
    ("ack_latency", pa.float64()),
    ("result_latency", pa.float64()),
    ("ack", pa.int64()),             # the answers' event numbers (null: none seen)
    ("nic", pa.int64()),
    ("result", pa.int64()),
    ("problems", pa.list_(pa.string())),
]

FINDING_COLUMNS: list[tuple[str, pa.DataType]] = [
    ("capture", pa.string()),
    ("site", pa.string()),
    ("start", TIME),                # the capture's first byte
    ("end", TIME),                  # its last byte
    ("code", pa.string()),
    ("severity", pa.string()),
    ("subject", pa.string()),
    ("title", pa.string()),
    ("detail", pa.string()),
    ("fix", pa.string()),
    ("evidence", pa.list_(pa.int64())),
    ("first_seen", pa.float64()),
    ("first_seen_ts", TIME),
    ("first_seen_event", pa.int64()),
]


# the events marked while the capture was watched (analyzer/formats/marks.py)
MARK_COLUMNS: list[tuple[str, pa.DataType]] = [
    ("capture", pa.string()),
    ("site", pa.string()),
    ("number", pa.int64()),         # the event's
    ("t", pa.float64()),            # the event's time (null: untimed, or not known)
    ("ts", TIME),
    ("note", pa.string()),          # "" for a mark without one
]


def _field_columns(taken: set[str]) -> list[tuple[str, str, pa.DataType]]:
    """(field name, column name, Arrow type) for every field of the command table."""
    return [(name, column, pa.list_(_ARROW[ft.items]) if ft.items is not None else _ARROW[ft.type])
            for name, column, ft in field_columns(taken)]


EVENT_FIELDS = _field_columns({n for n, _ in EVENT_COLUMNS})
TRANSACTION_FIELDS = _field_columns({n for n, _ in TRANSACTION_COLUMNS})


def _schema(columns: Iterable[tuple[str, pa.DataType]], fields: Iterable[tuple[str, str, pa.DataType]]) -> pa.Schema:
    return pa.schema([pa.field(n, t) for n, t in columns] + [pa.field(c, t) for _, c, t in fields])


EVENTS = _schema(EVENT_COLUMNS, EVENT_FIELDS)
TRANSACTIONS = _schema(TRANSACTION_COLUMNS, TRANSACTION_FIELDS)
FINDINGS = _schema(FINDING_COLUMNS, [])
MARKS = _schema(MARK_COLUMNS, [])

# the dataset's tables: folder name -> schema
TABLES: dict[str, pa.Schema] = {"events": EVENTS, "transactions": TRANSACTIONS, "findings": FINDINGS,
                                "marks": MARKS}
PARTITION = "date"   # Hive style: <table>/date=YYYY-MM-DD/<capture key>.parquet
UNDATED = "__HIVE_DEFAULT_PARTITION__"   # a capture without time: Hive's, Spark's and Arrow's null partition
