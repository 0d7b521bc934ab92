"""The dataset commands' one error: a path that is no dataset, or a query DuckDB
refused. Its own module so that the command line handles it without importing
DuckDB or pyarrow."""


class DatasetError(Exception):
    """One line for people (cli/main.py prints it, exit 2)."""
