"""The fleet dataset: captures exported as Hive-partitioned Parquet tables
(``events``, ``transactions``, ``findings``), queried with DuckDB (docs/dataset.md)."""
