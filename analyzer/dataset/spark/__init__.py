"""The fleet dataset's jobs on Spark (docs/spark.md): ``export --spark`` decodes
captures on the executors, each capture one task, into the dataset the local
export writes (``export.py``); ``report --spark`` computes the report with Spark
SQL over the same tables (``report.py``); ``session.py`` starts Spark for a
MASTER and says in one line why it cannot."""
