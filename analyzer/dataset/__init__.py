"""The fleet dataset's jobs: captures exported as Hive-partitioned Parquet
tables (``events``, ``transactions``, ``findings``) by a process pool
(``export``), queried and reported with DuckDB (``query``, ``report``;
docs/dataset.md). The tables themselves are analyzer/formats/parquet_schema.py
and parquet_rows.py."""
