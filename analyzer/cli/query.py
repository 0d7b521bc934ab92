"""``gimbalscope query DIR "SQL"``: SQL over an exported dataset (docs/dataset.md),
run by DuckDB embedded, with the views ``events``, ``transactions`` and
``findings`` (the tables ``export`` writes; statuses and kinds per spec
§1.4.2-1.4.3 and docs/decoding.md).

The result streams in batches (memory stays flat whatever its size): a table
on a terminal, CSV when standard output is a file or a pipe (what spreadsheets
and ``cut`` read), or JSON Lines (``--format jsonl``: dates and times as ISO
8601 text, lists as arrays, the same shape ``decode --format jsonl`` gives).
"""

from __future__ import annotations

import argparse
import csv
import datetime as dt
import decimal
import math
import sys

from ..errors import DatasetError
from ..output import dumps

BATCH = 10_000       # rows fetched at a time
TABLE_ROWS = 10_000  # a terminal table shows at most this many rows (the rest is counted)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("query", help="run SQL (DuckDB) over an exported dataset",
                       description="Run SQL over a dataset made by 'gimbalscope export', with the views events, "
                                   "transactions and findings (docs/dataset.md).")
    p.add_argument("dataset", metavar="DIR", help="the dataset folder")
    p.add_argument("sql", metavar="SQL", help="one SQL statement, e.g. \"SELECT device, count(*) FROM events "
                                              "GROUP BY device\"")
    p.add_argument("--format", choices=("table", "csv", "jsonl"), default=None,
                   help="table on a terminal; csv when standard output is not one (default)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    fmt = args.format or ("table" if sys.stdout.isatty() else "csv")
    # imported here: pyarrow and DuckDB take a tenth of a second to load, which
    # every other command would pay for at start (the parser registers them all)
    from ..dataset.query import connect

    con = connect(args.dataset)
    try:
        cur = con.execute(args.sql)
    except Exception as e:   # duckdb.Error and its kinds: the SQL's fault, said in DuckDB's words
        raise DatasetError(f"query: {_first_line(e)}") from None
    if cur.description is None:   # a statement with no result (CREATE VIEW ...)
        return 0
    names = [d[0] for d in cur.description]
    batches = _batches(cur)
    if fmt == "csv":
        _csv(names, batches)
    elif fmt == "jsonl":
        _jsonl(names, batches)
    else:
        _table(names, batches)
    return 0


def _first_line(e: Exception) -> str:
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__


def _batches(cur):
    while True:
        try:
            rows = cur.fetchmany(BATCH)
        except Exception as e:   # an error found while running (a cast that fails on a row)
            raise DatasetError(f"query: {_first_line(e)}") from None
        if not rows:
            return
        yield rows


def _plain(value):
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


def _jsonl(names, batches) -> None:
    out = sys.stdout.buffer
    for rows in batches:
        out.write(b"".join(dumps({n: _plain(v) for n, v in zip(names, row)}) + b"\n" for row in rows))


def _csv_cell(value):
    value = _plain(value)
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"   # as DuckDB and Spark write them
    if isinstance(value, (list, dict)):
        return dumps(value).decode()
    return value


def _csv(names, batches) -> None:
    w = csv.writer(sys.stdout, lineterminator="\n")
    w.writerow(names)
    for rows in batches:
        w.writerows([_csv_cell(v) for v in row] for row in rows)


def _table(names, batches) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(*names, show_lines=False)
    shown = more = 0
    for rows in batches:
        for row in rows:
            if shown < TABLE_ROWS:
                table.add_row(*("" if v is None else str(_csv_cell(v)) for v in row))
                shown += 1
            else:
                more += 1
    console = Console(highlight=False)
    console.print(table)
    console.print(f"{shown + more:,} row{'' if shown + more == 1 else 's'}"
                  + (f" ({more:,} not shown: --format csv or jsonl gives them all)" if more else ""))
