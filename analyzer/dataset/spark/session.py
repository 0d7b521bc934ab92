"""A Spark session for a MASTER (``local[N]``, ``spark://HOST:PORT``, ``yarn``,
``k8s://…``), or one line saying why there is none: no pyspark (the ``spark``
extra), no Java, a master that is no master URL or cannot be reached.

A master that cannot be reached is tried here, with a plain TCP connection,
before Spark starts: Spark's own client would retry for a minute and print a
Java stack trace a try. yarn needs Hadoop's configuration to find its resource
manager, and Spark's launcher refuses without it, so that is checked too.

The session's SQL time zone is UTC, the dataset's: a date is cut at UTC
midnight as the export cuts partitions. Spark's console progress bar is off
(the export shows its own) and its log says only errors unless the user has a
Spark configuration of their own (``SPARK_CONF_DIR``).
"""

from __future__ import annotations

import os
import re
import shutil
import socket
import sys
import warnings
from importlib import resources
from urllib.parse import urlsplit

from ...errors import UsageError

CONNECT_TIMEOUT = 5.0   # seconds to reach a master's port
_LOCAL = re.compile(r"^local(\[(\*|\d+)(,\d+)?\])?$")


def check_master(master: str) -> None:
    """Refuse, in one line, a MASTER that is no Spark master URL or that cannot be
    reached from here."""
    if _LOCAL.match(master):
        if master in ("local[0]",):
            raise UsageError(f"--spark {master}: a local master needs at least one core: local[N] with N >= 1")
        return
    if master == "yarn":
        if not (os.environ.get("HADOOP_CONF_DIR") or os.environ.get("YARN_CONF_DIR")):
            raise UsageError("--spark yarn: set HADOOP_CONF_DIR (or YARN_CONF_DIR) to the cluster's Hadoop "
                             "configuration, where Spark finds the resource manager")
        return
    if master.startswith("spark://"):
        hosts = master[len("spark://"):].split(",")   # several masters: standby ones (ZooKeeper)
        _reach(master, [_host_port(h, 7077, master) for h in hosts])
        return
    if master.startswith("k8s://"):
        api = master[len("k8s://"):]
        if "://" not in api:
            api = "https://" + api
        parts = urlsplit(api)
        default = 443 if parts.scheme == "https" else 80
        _reach(master, [_host_port(parts.netloc, default, master)])
        return
    raise UsageError(f"--spark {master}: not a Spark master (local[N], spark://HOST:PORT, yarn, "
                     "k8s://https://HOST:PORT)")


def _host_port(text: str, default: int, master: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":") if ":" in text else (text, "", "")
    if not host or (port and not port.isdigit()):
        raise UsageError(f"--spark {master}: not a Spark master URL (HOST:PORT)")
    return host.strip("[]"), int(port) if port else default


def _reach(master: str, hosts: list[tuple[str, int]]) -> None:
    why = ""
    for host, port in hosts:
        try:
            with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT):
                return
        except OSError as e:
            why = e.strerror or str(e) or type(e).__name__
            if isinstance(e, socket.gaierror):
                why = f"no such host ({why})"
            elif isinstance(e, TimeoutError) or isinstance(e, socket.timeout):
                why = f"no answer in {CONNECT_TIMEOUT:.0f} s"
    raise UsageError(f"--spark {master}: cannot reach the Spark master: {why}")


def check_java() -> None:
    """Spark runs on a JVM: Java 17 or later (Debian: openjdk-17-jre-headless)."""
    home = os.environ.get("JAVA_HOME")
    if home and os.access(os.path.join(home, "bin", "java"), os.X_OK):
        return
    if shutil.which("java") is None:
        raise UsageError("--spark needs Java 17 or later, and there is no java here (set JAVA_HOME, or on "
                         "Debian and Ubuntu: apt-get install openjdk-17-jre-headless)")


def check(master: str) -> None:
    """Everything Spark needs that can be told without starting it: pyspark (an
    ImportError: cli/main.py names the extra), a master that is one and can be
    reached, Java. Each a ``UsageError`` of one line."""
    import pyspark  # noqa: F401

    check_master(master)
    check_java()


def start(master: str, app: str, *, checked: bool = False):
    """A SparkSession for ``master`` (``check``-ed first, unless the caller has);
    raises ``UsageError`` with one line when Spark cannot start."""
    if not checked:
        check(master)
    from pyspark.sql import SparkSession

    # pyspark warns at import that it does not support pandas 3; nothing here uses pandas
    warnings.filterwarnings("ignore", message=".*PySpark does not yet fully support pandas.*")
    builder = (SparkSession.builder.master(master).appName(app)
               .config("spark.sql.session.timeZone", "UTC")
               .config("spark.ui.showConsoleProgress", "false"))
    if master.startswith("local"):
        # the executors are this machine's: they run this Python, with this package installed
        builder = builder.config("spark.pyspark.python", sys.executable).config("spark.ui.enabled", "false")
    if not os.environ.get("SPARK_CONF_DIR"):
        log4j = resources.files(__package__).joinpath("log4j2.properties")
        builder = builder.config("spark.driver.extraJavaOptions", f"-Dlog4j2.configurationFile=file:{log4j}")
    try:
        return builder.getOrCreate()
    except Exception as e:   # the JVM did not start, or the master refused the application
        raise UsageError(f"--spark {master}: Spark did not start: {one_line(e)}") from None


def one_line(e: BaseException) -> str:
    """An exception from Spark (often a Java stack trace) as its first line of
    substance."""
    for line in str(e).splitlines():
        line = line.strip()
        if line and not line.startswith(("at ", "Traceback", "File ", "JVM stacktrace")):
            return line
    return type(e).__name__
