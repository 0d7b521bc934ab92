"""DuckDB, embedded, over an exported dataset (docs/dataset.md): one connection
with the views ``events``, ``transactions`` and ``findings``, each over its
table's Hive-partitioned Parquet files (``date`` read from the path as a DATE).
A table with no file yet is an empty view of its schema, so every query runs on
any export. A query is exactly one statement, counted by DuckDB's own parser, and
DuckDB's messages are said whole, on one line."""

from __future__ import annotations

import os
import re
from typing import TYPE_CHECKING

from ..errors import DatasetError
from ..formats.parquet_schema import PARTITION, TABLES

if TYPE_CHECKING:
    from duckdb import DuckDBPyConnection


def table_glob(root: str, table: str) -> str:
    return os.path.join(root, table, f"{PARTITION}=*", "*.parquet")


def _has_files(root: str, table: str) -> bool:
    folder = os.path.join(root, table)
    try:
        parts = os.scandir(folder)
    except OSError:
        return False
    with parts:
        for part in parts:
            if part.is_dir() and part.name.startswith(PARTITION + "="):
                try:
                    if any(f.endswith(".parquet") for f in os.listdir(part.path)):
                        return True
                except OSError:
                    continue
    return False


def check_dataset(root: str) -> None:
    """Refuse, in one line, a path that is no exported dataset."""
    if not os.path.exists(root):
        raise DatasetError(f"{root}: no such dataset (make one with: gimbalscope export CAPTURE... -o {root})")
    if not os.path.isdir(root):
        raise DatasetError(f"{root}: not a dataset folder (gimbalscope export writes one)")
    if not any(os.path.isdir(os.path.join(root, t)) for t in TABLES):
        raise DatasetError(f"{root}: no dataset here: none of the folders {', '.join(TABLES)}")


def connect(root: str) -> DuckDBPyConnection:
    """A DuckDB connection (in memory) with the dataset's views."""
    import duckdb
    import pyarrow as pa

    check_dataset(root)
    con = duckdb.connect()
    for table, schema in TABLES.items():
        if _has_files(root, table):
            glob = table_glob(root, table).replace("'", "''")
            # union_by_name: files written by an older release may lack a newer field column
            con.execute(f"CREATE VIEW {table} AS SELECT * FROM read_parquet('{glob}', hive_partitioning = true, "
                        f"union_by_name = true, hive_types = {{'{PARTITION}': DATE}})")
        else:
            empty = pa.table({f.name: pa.array([], f.type) for f in schema}
                             | {PARTITION: pa.array([], pa.date32())})
            con.register(f"_{table}_empty", empty)
            con.execute(f"CREATE VIEW {table} AS SELECT * FROM _{table}_empty")
    return con


def one_statement(sql: str) -> str:
    """``sql`` when it is exactly one statement (a trailing ``;`` is fine), as DuckDB
    parses it: a ``;`` inside a string or a comment separates nothing. Refuses, in
    one line, none, several, or SQL DuckDB cannot parse."""
    import duckdb

    try:
        statements = duckdb.extract_statements(sql)
    except duckdb.Error as e:
        raise DatasetError(f"query: {duckdb_message(e)}") from None
    if not statements:
        raise DatasetError("query: no SQL statement given")
    if len(statements) > 1:
        raise DatasetError(f"query: {len(statements)} SQL statements given; a query runs exactly one "
                           "(run each on its own)")
    return sql


_WHERE = re.compile(r"LINE (\d+): ")


def duckdb_message(e: Exception) -> str:
    """DuckDB's message for people, whole, on one line: its lines joined (``Did you
    mean "events"?`` included), and the place it points at with ``LINE n:`` and carets
    under an excerpt of the statement said as ``(at line n: "text")``."""
    text = str(e).strip()
    if not text:
        return type(e).__name__
    lines = text.splitlines()
    said, where = [], ""
    for i, line in enumerate(lines):
        m = _WHERE.match(line)
        if m is None:
            if line.strip():
                said.append(line.strip())
            continue
        carets = lines[i + 1] if i + 1 < len(lines) else ""
        start, end = carets.find("^"), carets.rfind("^") + 1
        pointed = line[start:end].strip() if 0 <= start < len(line) else ""
        where = f' (at line {m.group(1)}: "{pointed}")' if pointed else f" (at line {m.group(1)})"
        break   # the carets' line and nothing after it is for a terminal, not for one line
    return " ".join(said) + where
