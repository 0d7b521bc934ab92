"""``report DIR --spark MASTER``: the fleet report's figures computed by Spark SQL
over the dataset (docs/spark.md), for datasets too big for one machine. The
report itself (periods, trends, findings, its text, JSON and page) is
analyzer/dataset/report.py's, fed by Spark's rows instead of DuckDB's: the same
SQL but for the quantile's name (``report.SPARK``).

``views(spark, root)`` makes the temporary views ``events``, ``transactions``
and ``findings`` with the partition column ``date``, as ``query.connect`` does
for DuckDB: scripts and notebooks on a cluster can use it too.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ... import uris
from ...errors import DatasetError
from ...formats.parquet_schema import PARTITION, TABLES
from ..report import SPARK, Report, build
from .session import SparkFailed, one_line

if TYPE_CHECKING:
    from pyspark.sql import SparkSession


def views(spark: SparkSession, root: str) -> None:
    """The dataset at ``root`` (a path or a URI) as Spark's temporary views. Only
    ``*.parquet`` files are read: an export under way writes ``*.parquet.tmp``
    beside them, which Spark would otherwise take for a table's file. A table
    with no file yet is an empty view of its schema."""
    from pyspark.sql.pandas.types import from_arrow_schema
    from pyspark.sql.types import DateType, StructField

    local = uris.local_path(root)
    if local is not None:
        from ..query import check_dataset
        check_dataset(local)
        root = local
    for table, schema in TABLES.items():
        where = uris.join(root, table)
        try:
            frame = (spark.read.option("mergeSchema", "true").option("pathGlobFilter", "*.parquet")
                     .option("basePath", where).parquet(where))
        except Exception as e:   # noqa: BLE001 - Py4JJavaError or pyspark's own: no files, or one line
            if not _no_files(e):
                raise DatasetError(f"{where}: Spark cannot read it: {one_line(e)}") from None
            empty = from_arrow_schema(schema).add(StructField(PARTITION, DateType()))
            frame = spark.createDataFrame([], empty)
        frame.createOrReplaceTempView(table)


def _no_files(e: Exception) -> bool:
    text = str(e)
    return any(s in text for s in ("PATH_NOT_FOUND", "UNABLE_TO_INFER_SCHEMA", "Path does not exist",
                                   "Unable to infer schema"))


class SparkRows:
    """Spark SQL behind the ``execute(sql).fetchall()`` that ``report.build`` asks of
    an engine. A query Spark fails (a Parquet file it cannot decode, an executor
    lost) is ``SparkFailed``: one line, not Spark's stack trace."""

    def __init__(self, spark: SparkSession, root: str = "") -> None:
        self.spark = spark
        self.root = root
        self._rows: list[tuple[Any, ...]] = []

    def execute(self, sql: str) -> SparkRows:
        try:
            self._rows = [tuple(row) for row in self.spark.sql(sql).collect()]
        except Exception as e:   # noqa: BLE001 - Py4JJavaError, or pyspark's own exceptions for what it converts
            raise SparkFailed(f"{self.root or 'the dataset'}: Spark failed the report's query: {one_line(e)}") from None
        return self

    def fetchall(self) -> list[tuple[Any, ...]]:
        return self._rows


def build_on_spark(spark: SparkSession, root: str, period: str = "day", **kw: Any) -> Report:
    """The report of the dataset at ``root``, its figures computed by ``spark``."""
    views(spark, root)
    return build(SparkRows(spark, root), period, dialect=SPARK, **kw)
