"""The fleet on Spark with its files behind URIs (docs/spark.md, "Where the files
are"): captures listed in an S3 bucket and the dataset written into it, through
pyarrow's S3 client, against a real S3 server on 127.0.0.1 (moto's, started
here); ``s3a://`` is Spark's name for what pyarrow calls ``s3://``.

The dataset written there holds the rows the local export writes of the same
captures; only the ``capture`` column (the URIs, as given) and the files' keys
(a hash of the URIs) differ."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time

import pyarrow.parquet as pq
import pytest
from pyarrow import fs

from tests.conftest import CTL, DEV, ROOT, SOCAT_LOG, run_cli

BUCKET = "fleet-bucket"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def s3():
    """An S3 server on 127.0.0.1, the environment that points pyarrow at it, and
    its filesystem."""
    port = free_port()
    # moto of this interpreter's environment (the test extra's), not whichever moto_server
    # is first on PATH: an older moto elsewhere (5.2.1) names CompleteMultipartUpload's
    # reply <CompleteMultipartUploadResponse>, which pyarrow takes for an error in a 200 OK
    server = subprocess.Popen([sys.executable, "-m", "moto.server", "-H", "127.0.0.1", "-p", str(port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    env = dict(os.environ, AWS_ENDPOINT_URL=f"http://127.0.0.1:{port}", AWS_ACCESS_KEY_ID="test",
               AWS_SECRET_ACCESS_KEY="test", AWS_DEFAULT_REGION="us-east-1", AWS_EC2_METADATA_DISABLED="true")
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                if time.monotonic() > deadline or server.poll() is not None:
                    raise RuntimeError("the S3 server did not start")
                time.sleep(0.2)
        s3fs = fs.S3FileSystem(endpoint_override=f"127.0.0.1:{port}", scheme="http", access_key="test",
                               secret_key="test", region="us-east-1", allow_bucket_creation=True)
        s3fs.create_dir(BUCKET)
        for name, path in (("site.log", SOCAT_LOG), ("ctl.bin", CTL), ("dev.bin", DEV)):
            fs.copy_files(path, f"{BUCKET}/captures/{name}", destination_filesystem=s3fs)
        yield env, s3fs
    finally:
        server.terminate()
        server.wait(timeout=10)


def gimbalscope(env, *args, timeout=600):
    cmd = [shutil.which("gimbalscope") or sys.executable, *([] if shutil.which("gimbalscope") else ["-m", "analyzer"])]
    return subprocess.run(cmd + [str(a) for a in args], capture_output=True, text=True, env=env, cwd=ROOT,
                          timeout=timeout, check=False)


def rows(table, *, filesystem=None) -> list[dict]:
    data = pq.read_table(table, filesystem=filesystem, partitioning="hive").drop(["capture"])
    return sorted(data.to_pylist(), key=lambda r: tuple(str(r.get(k)) for k in ("date", "site", "t", "number", "code")))


def test_export_from_and_into_a_bucket_is_the_local_export(s3, tmp_path):
    env, s3fs = s3
    local = tmp_path / "local"
    # raw dumps are dated by their files' times, which the copies in the bucket do not share: a start given
    start = ("--start-time", "2026-11-20T08:00:00Z")
    assert run_cli("export", SOCAT_LOG, f"{CTL}+{DEV}", "-o", local, *start).returncode == 0
    r = gimbalscope(env, "export", f"s3a://{BUCKET}/captures/site.log",
                    f"s3a://{BUCKET}/captures/ctl.bin+s3a://{BUCKET}/captures/dev.bin",
                    "-o", f"s3a://{BUCKET}/fleet", *start, "--spark", "local[2]")
    assert r.returncode == 0, r.stderr
    assert "exported 2 of 2 captures" in r.stderr
    written = s3fs.get_file_info(fs.FileSelector(f"{BUCKET}/fleet", recursive=True))
    files = sorted(f.path for f in written if f.type == fs.FileType.File)
    assert files and all(f.endswith(".parquet") for f in files)   # no .tmp left, no probe
    assert {f.split("/")[2] for f in files} == {"events", "transactions", "findings"}
    for table in ("events", "transactions", "findings"):
        got = rows(f"{BUCKET}/fleet/{table}", filesystem=s3fs)
        assert got == rows(str(local / table)), table
    events = pq.read_table(f"{BUCKET}/fleet/events", filesystem=s3fs)
    assert set(events.column("capture").to_pylist()) == {
        f"s3a://{BUCKET}/captures/site.log", f"s3a://{BUCKET}/captures/ctl.bin+s3a://{BUCKET}/captures/dev.bin"}


def test_a_bucket_folder_is_listed_and_a_missing_object_skipped(s3, tmp_path):
    env, _s3fs = s3
    r = gimbalscope(env, "export", f"s3a://{BUCKET}/captures/*.log", f"s3a://{BUCKET}/captures/gone.log",
                    "-o", f"s3a://{BUCKET}/fleet2", "--spark", "local[1]", "--separate")
    assert r.returncode == 1, r.stderr
    assert "exported 1 of 2 captures" in r.stderr
    assert f"s3a://{BUCKET}/captures/gone.log: cannot read it" in r.stderr
    assert r.stderr.rstrip().endswith(f"skipped 1: s3a://{BUCKET}/captures/gone.log")
    # the folder itself: each capture in it
    r = gimbalscope(env, "export", f"s3a://{BUCKET}/captures/", "-o", f"s3a://{BUCKET}/fleet3",
                    "--spark", "local[1]", "--separate")
    assert r.returncode == 0, r.stderr
    assert "exported 3 of 3 captures" in r.stderr


def test_a_report_of_a_bucket_without_spark_is_refused_in_one_line(s3):
    env, _ = s3
    r = gimbalscope(env, "report", f"s3a://{BUCKET}/fleet")
    assert r.returncode == 2 and r.stderr.count("\n") == 1
