"""``gimbalscope query DIR "SQL"``: SQL over an exported dataset (docs/dataset.md),
run by DuckDB embedded, with the views ``events``, ``transactions`` and
``findings`` (the tables ``export`` writes; statuses and kinds per spec
§1.4.2-1.4.3 and docs/decoding.md).

The result streams in batches (memory stays flat whatever its size): on a
terminal a table, or a record at a time (a column and its value a line, like
psql's ``\\x``) when the columns are wider than the terminal; CSV when standard
output is a file or a pipe (what spreadsheets and ``cut`` read), or JSON Lines
(``--format jsonl``: dates and times as ISO 8601 text, lists as arrays, the same
shape ``decode --format jsonl`` gives).

The SQL is exactly one statement (DuckDB's parser counts them), and DuckDB's
messages are said whole on one line (analyzer/dataset/query.py).
"""

from __future__ import annotations

import argparse
import csv
import datetime as dt
import decimal
import math
import sys
from collections.abc import Callable, Iterable, Iterator
from typing import TYPE_CHECKING, Any

from ..errors import DatasetError
from ..output import dumps
from ..words import counted
from .common import Subcommands

BATCH = 10_000       # rows fetched at a time
TABLE_ROWS = 10_000  # a terminal shows at most this many rows (the rest is counted)
TERMINAL = ("table", "vertical")

if TYPE_CHECKING:
    from duckdb import DuckDBPyConnection
    from rich.console import Console

Row = tuple[Any, ...]   # a result row, as DuckDB fetches it


def register(sub: Subcommands) -> None:
    p = sub.add_parser("query", help="run SQL (DuckDB) over an exported dataset",
                       description="Run SQL over a dataset made by 'gimbalscope export', with the views events, "
                                   "transactions and findings (docs/dataset.md).")
    p.add_argument("dataset", metavar="DIR", help="the dataset folder")
    p.add_argument("sql", metavar="SQL", help="one SQL statement, e.g. \"SELECT device, count(*) FROM events "
                                              "GROUP BY device\"")
    p.add_argument("--format", choices=("table", "vertical", "csv", "jsonl"), default=None,
                   help="on a terminal (default): a table, or a record at a time (vertical: a column and its "
                        "value a line) when the columns are wider than the terminal; csv when standard output "
                        "is not a terminal (default); jsonl: JSON Lines")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    # imported here: pyarrow and DuckDB take a tenth of a second to load, which
    # every other command would pay for at start (the parser registers them all)
    from ..dataset.query import connect, duckdb_message, one_statement

    sql = one_statement(args.sql)
    con = connect(args.dataset)
    try:
        cur = con.execute(sql)
    except Exception as e:  # noqa: BLE001 - duckdb.Error and its kinds: the SQL's fault, said in DuckDB's words
        raise DatasetError(f"query: {duckdb_message(e)}") from None
    if cur.description is None:   # a statement with no result (CREATE VIEW ...)
        return 0
    names = [d[0] for d in cur.description]
    batches = _batches(cur, duckdb_message)
    if args.format == "csv" or (args.format is None and not sys.stdout.isatty()):
        _csv(names, batches)
    elif args.format == "jsonl":
        _jsonl(names, batches)
    else:
        _terminal(names, batches, args.format)
    return 0


def _batches(cur: DuckDBPyConnection, message: Callable[[Exception], str]) -> Iterator[list[Row]]:
    while True:
        try:
            rows = cur.fetchmany(BATCH)
        except Exception as e:  # noqa: BLE001 - an error found while running (a cast that fails on a row), one line
            raise DatasetError(f"query: {message(e)}") from None
        if not rows:
            return
        yield rows


def _plain(value: object) -> object:
    """A value as JSON has it: times as ISO 8601, decimals as numbers, bytes as hex."""
    if isinstance(value, (dt.datetime, dt.date, dt.time)):
        return value.isoformat()
    if isinstance(value, dt.timedelta):
        return value.total_seconds()
    if isinstance(value, decimal.Decimal):
        return float(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value).hex()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    return value


def _jsonl(names: list[str], batches: Iterable[list[Row]]) -> None:
    out = sys.stdout.buffer
    for rows in batches:
        out.write(b"".join(dumps({n: _plain(v) for n, v in zip(names, row)}) + b"\n" for row in rows))


def _csv_cell(value: object) -> object:
    value = _plain(value)
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"   # as DuckDB and Spark write them
    if isinstance(value, (list, dict)):
        return dumps(value).decode()
    return value


def _csv(names: list[str], batches: Iterable[list[Row]]) -> None:
    w = csv.writer(sys.stdout, lineterminator="\n")
    w.writerow(names)
    for rows in batches:
        w.writerows([_csv_cell(v) for v in row] for row in rows)


def _shown(batches: Iterable[list[Row]]) -> tuple[list[list[str]], int]:
    """The first TABLE_ROWS rows as text, and how many more there are."""
    shown: list[list[str]] = []
    more = 0
    for rows in batches:
        for row in rows:
            if len(shown) < TABLE_ROWS:
                shown.append(["" if v is None else str(_csv_cell(v)) for v in row])
            else:
                more += 1
    return shown, more


def _terminal(names: list[str], batches: Iterable[list[Row]], fmt: str | None) -> None:
    """A table, or a record at a time: ``fmt`` says which, or (None) the table when
    its columns fit the terminal side by side, each as wide as its widest value."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from ..formats.fit_width import FitLines, table_width

    rows, more = _shown(batches)
    console = Console(highlight=False)
    vertical = fmt == "vertical" or (fmt is None and table_width(names, rows) > console.width)
    if vertical:
        _vertical(console, names, rows)
    else:
        table = Table()
        for name in names:
            table.add_column(Text(name))
        for row in rows:
            table.add_row(*map(Text, row))   # Text: a value is never markup
        console.print(table)
    said = counted(len(rows) + more, "row")
    if more:
        said += f" ({more:,} not shown: --format csv or jsonl gives them all)"
    if vertical and fmt is None:
        said += " (a record at a time: the columns are wider than the terminal; --format table or csv for a table)"
    console.print(FitLines(said))


def _vertical(console: Console, names: list[str], rows: list[list[str]]) -> None:
    """Each record as psql's \\x shows it: a rule naming it, then a column and its
    value a line, the names aligned; a long value wraps under itself."""
    from rich.rule import Rule

    from ..formats.fit_width import FitFields

    for n, row in enumerate(rows, 1):
        console.print(Rule(f"record {n:,}", align="left", style="dim"))
        console.print(FitFields(list(zip(names, row))))
