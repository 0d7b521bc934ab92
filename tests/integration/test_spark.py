"""The fleet on Spark (docs/spark.md), on a real local Spark (``local[2]``, Java 17):
``export --spark`` writes the dataset the local export writes, file for file and
row for row; ``report --spark`` gives DuckDB's report; the Spark SQL queries of
the docs give the answers of the README's DuckDB queries; a local master's
workers run the command's own Python, whatever PATH and PYSPARK_PYTHON say; and
what cannot work, or fails on Spark, is said in one line.

Spark starts a JVM, about ten seconds: most tests share one session of the
module and call the jobs in this process, and a few run the command line whole."""

from __future__ import annotations

import os
import re
import socket
import struct
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from analyzer.capture import Options
from analyzer.dataset.export import Job
from analyzer.dataset.export import export as local_export
from analyzer.dataset.inputs import captures_of
from analyzer.dataset.query import connect
from analyzer.dataset.report import build, to_dict
from analyzer.dataset.spark.export import run_on_spark
from analyzer.dataset.spark.report import SparkRows, build_on_spark, views
from analyzer.dataset.spark.session import SparkFailed
from tests.conftest import BUS, CTL, DEV, ROOT, SOCAT_LOG, run_cli
from tests.integration import test_query, test_report
from tests.integration.test_mcap_parts import record

SPARK_DOC = os.path.join(ROOT, "docs", "spark.md")


@pytest.fixture(scope="module")
def spark():
    from analyzer.dataset.spark.session import start
    session = start("local[2]", "gimbalscope tests")
    yield session
    session.stop()


def dataset(root) -> dict[str, object]:
    """Every Parquet file of a dataset, by its path in it, as a table."""
    out = {}
    for folder, _, files in os.walk(root):
        for name in files:
            path = os.path.join(folder, name)
            out[os.path.relpath(path, root)] = pq.read_table(path)
    return out


def assert_same_dataset(a, b) -> None:
    left, right = dataset(a), dataset(b)
    assert sorted(left) == sorted(right)
    assert {p.split(os.sep)[0] for p in left} == {"events", "transactions", "findings"}
    for path, table in left.items():
        assert table.schema == right[path].schema, path
        assert table.equals(right[path]), path


def jobs_of(inputs: list[str], root, **kw) -> list[Job]:
    return [Job(i, paths, str(root), Options(), **kw) for i, paths in enumerate(captures_of(inputs))]


@pytest.fixture(scope="module")
def in_parts(tmp_path_factory):
    """A folder with a recording in parts (rec-0001.mcap, …) and a socat log."""
    folder = tmp_path_factory.mktemp("recordings")
    parts, _ = record(folder / "rec.mcap", [SOCAT_LOG], rotate_bytes=20_000)
    assert len(parts) >= 3
    log = folder / "site.log"
    log.write_bytes(Path(SOCAT_LOG).read_bytes())
    return folder, parts


# ------------------------------------------------------------------ export

def test_the_folder_lists_a_recording_in_parts_as_one_capture(in_parts):
    folder, parts = in_parts
    assert captures_of([str(folder)]) == [tuple(str(folder / os.path.basename(p)) for p in parts),
                                          (str(folder / "site.log"),)]


def test_spark_export_is_the_local_export(spark, in_parts, tmp_path):
    # the sample captures, a recording in parts (a folder) and two raw dumps joined with +
    folder, _ = in_parts
    inputs = [SOCAT_LOG, f"{CTL}+{DEV}", BUS, str(folder)]
    local, on_spark = tmp_path / "local", tmp_path / "spark"
    outcomes = local_export(jobs_of(inputs, local), 2)
    assert [o.error for o in outcomes] == [None] * 5
    said = []
    got = run_on_spark("local[2]", jobs_of(inputs, on_spark), spark=spark, on_done=said.append)
    assert [o.error for o in got] == [None] * 5
    assert [o.rows for o in got] == [o.rows for o in outcomes]
    assert [o.capture for o in said] == [o.capture for o in outcomes]   # every outcome said, in the inputs' order
    assert_same_dataset(local, on_spark)
    # the parts are one capture: numbered on across them, as the whole socat log is
    events = pq.read_table(on_spark / "events").to_pylist()
    parts = "+".join(captures_of([str(folder)])[0])
    rec = [e for e in events if e["capture"] == parts]
    whole = [e for e in events if e["capture"] == SOCAT_LOG]
    assert [e["number"] for e in rec] == [e["number"] for e in whole] == list(range(1, len(whole) + 1))


def test_file_uris_in_and_out(spark, tmp_path):
    local, on_spark = tmp_path / "local", tmp_path / "spark"
    local_export(jobs_of([SOCAT_LOG], local), 1)
    got = run_on_spark("local[2]", jobs_of([f"file://{SOCAT_LOG}"], f"file://{on_spark}"), spark=spark)
    assert got[0].error is None
    # the capture column names it as given; the files (their key: the real path) are the local export's
    assert sorted(dataset(local)) == sorted(dataset(on_spark))
    a = pq.read_table(local / "events").drop(["capture"])
    b = pq.read_table(on_spark / "events")
    assert set(b.column("capture").to_pylist()) == {f"file://{SOCAT_LOG}"}
    assert a.equals(b.drop(["capture"]))


def test_exporting_again_on_spark_replaces_its_own_files_only(spark, tmp_path):
    out = tmp_path / "ds"
    local_export(jobs_of([SOCAT_LOG, f"{CTL}+{DEV}"], out), 1)
    before = {p: os.stat(out / p).st_ino for p in dataset(out)}
    got = run_on_spark("local[2]", jobs_of([SOCAT_LOG], out), spark=spark)
    assert got[0].error is None
    after = {p: os.stat(out / p).st_ino for p in dataset(out)}
    assert set(after) == set(before)
    for path, inode in before.items():
        replaced = "demo-socat.log" in path
        assert (after[path] != inode) == replaced, path


def test_a_capture_that_fails_is_skipped_and_the_others_written(spark, tmp_path):
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"\x89MCAP0\r\n" + os.urandom(300))   # an MCAP header and nothing whole after it
    missing = str(tmp_path / "gone.log")
    out = tmp_path / "ds"
    got = run_on_spark("local[2]", jobs_of([SOCAT_LOG, str(garbage), missing], out), spark=spark)
    assert got[0].error is None and got[0].rows["events"] > 0
    assert "garbage.mcap" in got[1].error and "cut short" in got[1].error
    assert "gone.log" in got[2].error
    assert {p.split(os.sep)[-1].split("-")[0] for p in dataset(out)} == {"demo"}


def test_the_command_line_export_and_its_skips(tmp_path, in_parts):
    folder, _ = in_parts
    local, on_spark = tmp_path / "local", tmp_path / "spark"
    r = run_cli("export", SOCAT_LOG, f"{CTL}+{DEV}", str(folder), "-o", local, timeout=300)
    assert r.returncode == 0, r.stderr
    r = run_cli("export", SOCAT_LOG, f"{CTL}+{DEV}", str(folder), str(tmp_path / "nope.log"),
                "-o", on_spark, "--spark", "local[2]", timeout=600)
    assert r.returncode == 1, r.stderr
    lines = [line for line in r.stderr.splitlines() if line.startswith("gimbalscope:")]
    assert lines[-2].startswith("gimbalscope: exported 4 of 5 captures to")
    assert lines[-1] == f"gimbalscope: skipped 1: {tmp_path / 'nope.log'}"
    assert "Traceback" not in r.stderr and " WARN " not in r.stderr and " INFO " not in r.stderr
    assert_same_dataset(local, on_spark)


# ------------------------------------------------------------------ which Python the workers run

@pytest.fixture(scope="module")
def python_without_pyarrow(tmp_path_factory):
    """A python3 that cannot import pyarrow, as the system's is beside a virtual
    environment that is not activated: a bare virtual environment's (no packages)."""
    bare = tmp_path_factory.mktemp("bare-python")
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(bare)], check=True)
    python = bare / "bin" / "python3"
    r = subprocess.run([python, "-c", "import pyarrow"], capture_output=True, text=True, cwd=bare, check=False)
    assert r.returncode != 0 and "No module named 'pyarrow'" in r.stderr, r.stderr
    return python


def outside_the_venv(args, python3, **env):
    """The command run as ``.venv/bin/gimbalscope …`` from a shell where the
    virtual environment is not activated: its bin not on PATH, and the folder of
    ``python3`` first on it; no Spark configuration of the user's (its log would
    speak)."""
    venv_bin = os.path.dirname(sys.executable)
    script = os.path.join(venv_bin, "gimbalscope")
    cmd = [script] if os.path.exists(script) else [sys.executable, "-m", "analyzer"]
    path = [str(python3.parent)] + [p for p in os.environ.get("PATH", "").split(os.pathsep)
                                    if p and os.path.realpath(p) != os.path.realpath(venv_bin)]
    gone = ("VIRTUAL_ENV", "PYSPARK_PYTHON", "PYSPARK_DRIVER_PYTHON", "SPARK_CONF_DIR", "PYTHONPATH")
    env = {**{k: v for k, v in os.environ.items() if k not in gone}, "PATH": os.pathsep.join(path), **env}
    return subprocess.run(cmd + [str(a) for a in args], capture_output=True, text=True, timeout=600, cwd=ROOT,
                          env=env, check=False)


def not_ours(stderr: str) -> list[str]:
    """Lines of standard error that gimbalscope did not write. The JVM's own note
    of the incubator module Spark asks for is printed before anything runs."""
    return [line for line in stderr.splitlines()
            if not line.startswith(("gimbalscope:", "WARNING: Using incubator modules"))]


def test_the_workers_run_the_commands_python_not_paths(python_without_pyarrow, tmp_path):
    # PYSPARK_PYTHON unset: pyspark's default is PATH's python3, which here has no pyarrow (nor the package)
    inputs = [SOCAT_LOG, f"{CTL}+{DEV}"]
    local, on_spark = tmp_path / "local", tmp_path / "spark"
    local_export(jobs_of(inputs, local), 1)
    r = outside_the_venv(["export", *inputs, "-o", on_spark, "--spark", "local[2]"], python_without_pyarrow)
    assert r.returncode == 0, r.stderr
    assert not_ours(r.stderr) == [], r.stderr
    assert_same_dataset(local, on_spark)


def test_pyspark_python_set_elsewhere_and_a_capture_its_task_finds_cut_short(python_without_pyarrow, in_parts,
                                                                             tmp_path):
    # an inherited PYSPARK_PYTHON and PYSPARK_DRIVER_PYTHON naming a Python without pyarrow: a local master's
    # workers still run the command's own. A recording killed while being written (half of a real one) passes
    # the driver's listing and only its task finds it cut short: one line, the other capture written, exit 1
    _, parts = in_parts
    killed = tmp_path / "killed.mcap"
    whole = Path(parts[0]).read_bytes()
    killed.write_bytes(whole[:len(whole) // 2])
    local, on_spark = tmp_path / "local", tmp_path / "spark"
    local_export(jobs_of([SOCAT_LOG], local), 1)
    python = str(python_without_pyarrow)
    r = outside_the_venv(["export", SOCAT_LOG, killed, "-o", on_spark, "--spark", "local[2]"],
                         python_without_pyarrow, PYSPARK_PYTHON=python, PYSPARK_DRIVER_PYTHON=python)
    assert r.returncode == 1, r.stderr
    assert not_ours(r.stderr) == [], r.stderr
    said = [line for line in r.stderr.splitlines() if "gimbalscope: error:" in line]
    assert len(said) == 1 and said[0].startswith(f"gimbalscope: error: skipped {killed}: cut short"), r.stderr
    lines = r.stderr.splitlines()
    assert lines[-2].startswith(f"gimbalscope: exported 1 of 2 captures to {on_spark}")
    assert lines[-1] == f"gimbalscope: skipped 1: {killed}"
    assert_same_dataset(local, on_spark)


# ------------------------------------------------------------------ report and queries

def test_the_spark_report_is_duckdbs(spark, tmp_path):
    logs = []
    for day, ms, naks in zip(test_report.DAYS, test_report.WORSE_MS, test_report.WORSE_NAKS):
        log = tmp_path / f"{day}.log"
        test_report.day_log(log, day, ms, naks)
        logs.append(str(log))
    out = tmp_path / "fleet"
    local_export(jobs_of(logs + [SOCAT_LOG, f"{CTL}+{DEV}"], out), 2)
    for period in ("day", "week"):
        duck = to_dict(build(connect(str(out)), period))
        assert to_dict(build_on_spark(spark, str(out), period)) == duck
    assert any(d["trending_worse"] for d in duck["devices"])   # the trends are compared too
    assert duck["captures"]


def test_a_file_spark_cannot_decode_fails_the_report_in_one_line(spark, tmp_path):
    out = tmp_path / "fleet"
    local_export(jobs_of([SOCAT_LOG], out), 1)
    [damaged] = [os.path.join(d, f) for d, _, files in os.walk(out / "transactions") for f in files]
    data = bytearray(Path(damaged).read_bytes())
    # the footer (the schema, read when the views are made) whole; the pages before it, garbage from the disk
    footer = struct.unpack("<I", data[-8:-4])[0]
    data[4:len(data) - 8 - footer] = b"\xff" * (len(data) - 12 - footer)
    Path(damaged).write_bytes(data)
    with pytest.raises(SparkFailed) as failed:
        build_on_spark(spark, str(out))
    said = str(failed.value)
    assert "\n" not in said and said.startswith(f"{out}: Spark failed the report's query: ")
    assert os.path.basename(damaged) in said and "SQLSTATE" not in said
    assert failed.value.exit_code == 1


def test_the_command_line_report_on_spark(tmp_path):
    out = tmp_path / "fleet"
    assert run_cli("export", SOCAT_LOG, f"{CTL}+{DEV}", "-o", out).returncode == 0
    duck = run_cli("report", out, "--format", "json")
    on_spark = run_cli("report", out, "--format", "json", "--spark", "local[1]", timeout=300)
    assert duck.returncode == on_spark.returncode == 0, on_spark.stderr
    assert on_spark.stdout == duck.stdout


def spark_queries() -> dict[str, str]:
    """docs/spark.md's queries ("### The fleet queries in Spark SQL")."""
    text = Path(SPARK_DOC).read_text(encoding="utf-8")
    part = text.split("### The fleet queries in Spark SQL\n", 1)[1]
    part = re.split(r"\n##?#? ", part, maxsplit=1)[0]
    return {m.group(1).strip(): m.group(2) for m in re.finditer(r"####\s*(.+?)\n.*?```sql\n(.*?)```", part, re.DOTALL)}


def test_the_spark_sql_queries_give_duckdbs_answers(spark, tmp_path):
    one, two = tmp_path / "mon.log", tmp_path / "tue.log"
    test_query.day_one(one)
    test_query.day_two(two)
    out = tmp_path / "fleet"
    # dated captures only (raw dumps are dated by their files' times): every query has rows
    local_export(jobs_of([str(one), str(two), SOCAT_LOG], out), 2)
    duck_sql, spark_sql = test_query.readme_queries(), spark_queries()
    assert set(spark_sql) == set(duck_sql)
    con = connect(str(out))
    views(spark, str(out))
    rows = SparkRows(spark)
    for title, sql in duck_sql.items():
        duck = con.execute(sql)
        names = [d[0] for d in duck.description]
        expected = duck.fetchall()
        assert expected, title
        got = spark.sql(spark_sql[title])
        assert got.columns == names, title
        assert rows.execute(spark_sql[title]).fetchall() == expected, title


# ------------------------------------------------------------------ what cannot work, in one line

def closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]   # closed again when the socket goes


@pytest.mark.parametrize("master, said", [
    ("spark://127.0.0.1:{closed}", "cannot reach the Spark master: Connection refused"),
    ("spark://no-such-host.invalid:7077", "cannot reach the Spark master: no such host"),
    ("local[0]", "a local master needs at least one core"),
    ("mesos://x:5050", "not a Spark master"),
    ("yarn", "set HADOOP_CONF_DIR"),
])
def test_a_master_that_cannot_be_used_is_one_line(tmp_path, master, said):
    master = master.format(closed=closed_port())   # picked when run: test ids stay the same in every process
    env = {k: v for k, v in os.environ.items() if k not in ("HADOOP_CONF_DIR", "YARN_CONF_DIR")}
    for args in (["export", SOCAT_LOG, "-o", tmp_path / "ds"], ["report", tmp_path / "ds"]):
        r = run_cli(*args, "--spark", master, env=env)
        assert r.returncode == 2, r.stderr
        assert r.stderr.count("\n") == 1 and r.stderr.startswith("gimbalscope: error: "), r.stderr
        assert said in r.stderr


@pytest.mark.parametrize("output, said", [
    ("hdfs://namenode.invalid:8020/fleet", "cannot write the dataset there"),
    ("ftp://example.invalid/fleet", "cannot write the dataset there"),
    ("file:///proc/fleet", "cannot make the dataset folder"),
    ("file://otherhost/fleet", "cannot write the dataset there"),   # another machine's file
])
def test_an_output_that_cannot_be_written_is_one_line(tmp_path, output, said):
    r = run_cli("export", SOCAT_LOG, "-o", output, "--spark", "local[1]")
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and said in r.stderr, r.stderr


def test_a_path_that_is_no_dataset_is_refused_before_spark_starts(tmp_path):
    r = run_cli("report", tmp_path / "nothing", "--spark", "local[1]")
    assert r.returncode == 2
    assert r.stderr == (f"gimbalscope: error: {tmp_path / 'nothing'}: no such dataset (make one with: "
                        f"gimbalscope export CAPTURE... -o {tmp_path / 'nothing'})\n")   # no JVM said a word


def test_uris_without_spark_are_refused(tmp_path):
    r = run_cli("export", "s3a://bucket/site.log", "-o", tmp_path / "ds")
    assert r.returncode == 2 and "URIs (hdfs://, s3a://) are for --spark" in r.stderr
    r = run_cli("report", "s3a://bucket/fleet")
    assert r.returncode == 2 and "with --spark MASTER" in r.stderr
    # file://HOST/ is another machine's file, not a local path
    for args in (["export", SOCAT_LOG, "-o", "file://otherhost/fleet"], ["export", "file://otherhost/a.log", "-o",
                                                                          tmp_path / "ds"]):
        r = run_cli(*args)
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and "are for --spark" in r.stderr, r.stderr
