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

On a local master the executors are this machine's, and their Python workers
run this interpreter (``sys.executable``), whatever ``python3`` is on PATH and
whatever ``PYSPARK_PYTHON`` says: this one has the package and pyarrow, which a
worker needs. A cluster's workers run the Python its configuration names.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import socket
import sys
import warnings
from collections.abc import Iterator
from importlib import resources
from typing import TYPE_CHECKING
from urllib.parse import urlsplit

from ...errors import OutputError, UsageError

if TYPE_CHECKING:
    from pyspark.sql import SparkSession

CONNECT_TIMEOUT = 5.0   # seconds to reach a master's port
_LOCAL = re.compile(r"^local(\[(\*|\d+)(,\d+)?\])?$")
# Where pyspark and Spark look for the Python of the workers they start: pyspark's
# SparkContext takes PYSPARK_PYTHON for the Python functions it ships to the
# executors; Spark's JVM takes PYSPARK_DRIVER_PYTHON, else PYSPARK_PYTHON, for
# the Python processes it starts itself; the config spark.pyspark.python is read
# only by spark-submit, which turns it into PYSPARK_PYTHON before Python starts.
_PYTHON_VARIABLES = ("PYSPARK_PYTHON", "PYSPARK_DRIVER_PYTHON")


class SparkFailed(OutputError):
    """Spark failed a job for a reason no capture's outcome holds (a Python worker
    that crashed, an executor lost, executors whose Python cannot load the
    package): one line, and exit 1 as for any output not written whole."""

    exit_code = 1


def is_local(master: str) -> bool:
    """A master whose executors run on this machine: ``local``, ``local[N]``,
    ``local[N,F]``, ``local[*]``, ``local-cluster[…]``."""
    return master == "local" or master.startswith(("local[", "local-cluster["))


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
            elif isinstance(e, TimeoutError):   # socket.timeout is TimeoutError
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
    import pyspark  # noqa: F401 - imported for its ImportError only

    check_master(master)
    check_java()


def start(master: str, app: str, *, checked: bool = False) -> SparkSession:
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
    local = is_local(master)
    if local:
        # the executors are this machine's: they run this Python, with this package installed (the config for
        # what reads it; pyspark and the JVM read the environment: _workers_run_this_python)
        builder = builder.config("spark.pyspark.python", sys.executable).config("spark.ui.enabled", "false")
    if not os.environ.get("SPARK_CONF_DIR"):
        log4j = resources.files(__package__).joinpath("log4j2.properties")
        builder = builder.config("spark.driver.extraJavaOptions", f"-Dlog4j2.configurationFile=file:{log4j}")
    try:
        with _workers_run_this_python(local):
            return builder.getOrCreate()
    except Exception as e:   # noqa: BLE001 - the JVM did not start, or the master refused the application
        raise UsageError(f"--spark {master}: Spark did not start: {one_line(e)}") from None


@contextlib.contextmanager
def _workers_run_this_python(local: bool) -> Iterator[None]:
    """For a local master, ``_PYTHON_VARIABLES`` set to this interpreter while the
    session starts: the SparkContext and the JVM launched for it read them then,
    and keep what they read. Without this, workers run PATH's ``python3`` (the
    system's, without pyarrow, when the command runs from a virtual environment
    that is not activated) or whatever an inherited PYSPARK_PYTHON names. This
    process's own environment is given back after, for what it runs next."""
    if not local or not sys.executable:
        yield
        return
    saved = {name: os.environ.get(name) for name in _PYTHON_VARIABLES}
    os.environ.update(dict.fromkeys(_PYTHON_VARIABLES, sys.executable))
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


_PYTHON_TRACEBACK = "Traceback (most recent call last):"
# "org.apache.spark.SparkException: " before a Java exception's message
_JAVA_EXCEPTION = re.compile(r"^(?:[A-Za-z_$][\w$]*\.)+[A-Z][\w$]*(?:Exception|Error)(?::\s*|$)")
# " SQLSTATE: KD001" after a message: a code for programs
_SQLSTATE = re.compile(r"\s*SQLSTATE: \w+$")
# "Job aborted due to stage failure: Task 3 in stage 0.0 failed 1 times, most recent failure: Lost task 3.0 in
# stage 0.0 (TID 3) (host executor driver): " before the task's own failure
_ABORTED = re.compile(r"^Job aborted due to stage failure: .*?most recent failure: Lost task [^:]*\): ")


def one_line(e: BaseException) -> str:
    """An exception from Spark as the line that says what went wrong: the last
    line of a Python worker's traceback (``ModuleNotFoundError: …``), else the
    first line of substance of a Java stack trace, without the Java class names
    and job-abort preamble before the cause."""
    text = str(e)
    if _PYTHON_TRACEBACK in text:
        for line in text.rsplit(_PYTHON_TRACEBACK, 1)[1].splitlines():
            if line.strip() and not line[0].isspace():
                return line.strip()
    for line in text.splitlines():
        line = line.strip().lstrip(": ")
        if not line or line.startswith(("at ", "Traceback", "File ", "JVM stacktrace", "An error occurred while")):
            continue
        while True:   # the cause within the causes
            shorter = _JAVA_EXCEPTION.sub("", _ABORTED.sub("", line), count=1)
            if shorter == line or not shorter:   # a class name alone is the message
                break
            line = shorter
        # Spark's advice after a crashed Python worker is about its own debugging settings
        return _SQLSTATE.sub("", line.split(" Consider setting ", 1)[0])
    return type(e).__name__
