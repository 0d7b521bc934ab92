"""Foxglove's own MCAP reader, ``@mcap/core`` (the TypeScript library the Foxglove
app opens files with), reads our recordings whole: default ones with their
stored columns (a schemaless ``arrow.ipc`` channel in zstd chunks of its own),
lean ones and rotated parts, by their index and front to back, each message and
metadata record as the mcap Python library and our own reader find them.

``js/read.mjs`` does the reading; its packages are pinned in ``js/package-lock.json``
and installed by ``.ci/run`` (``npm ci --prefix tests/interop/js``)."""

from __future__ import annotations

import json
import os
import subprocess
from collections import Counter
from pathlib import Path

import pytest
from mcap.reader import make_reader

import analyzer
from analyzer.formats.mcap_schemas import COLUMNS_RECORD, COLUMNS_TOPIC
from analyzer.simulation.traffic import generate
from tests.conftest import SOCAT_LOG
from tests.integration.test_mcap_parts import record
from tests.integration.test_recorded_columns import converted
from tests.interop.node import JS_DIR, node_with

READ = os.path.join(JS_DIR, "read.mjs")
PACKAGES = ("@mcap/core", "@foxglove/wasm-zstd")
ARROW_ENCODING = "arrow.ipc"


def mcap_core(path: str) -> dict:
    """What read.mjs found, by the index (``indexed``) and front to back (``stream``)."""
    node = node_with(*PACKAGES)
    out = subprocess.run([node, READ, path], capture_output=True, text=True, timeout=300, check=False)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def python_counts(path: str) -> dict[str, int]:
    with open(path, "rb") as f:
        return dict(Counter(channel.topic for _s, channel, _m in make_reader(f).iter_messages(log_time_order=False)))


def python_metadata(path: str) -> dict[str, dict[str, str]]:
    with open(path, "rb") as f:
        return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}


def read_whole(path: str) -> dict:
    """Both of @mcap/core's readers read every message and record of ``path``, as the
    mcap Python library does; what its indexed reader found."""
    report = mcap_core(path)
    indexed, stream = report["indexed"], report["stream"]
    assert stream["footer"]
    for key in ("messages", "encodings", "schemas", "metadata", "columns"):
        assert indexed[key] == stream[key], key
    counts = python_counts(path)
    assert indexed["messages"] == counts
    total = sum(counts.values())
    assert indexed["read_message_count"] == indexed["statistics_message_count"] == total > 0
    assert indexed["metadata"] == python_metadata(path)
    assert set(indexed["chunk_compressions"]) <= {"zstd", ""} and indexed["chunks"] >= 1
    for topic, encoding in indexed["encodings"].items():
        if topic == COLUMNS_TOPIC:
            assert encoding == ARROW_ENCODING and indexed["schemas"][topic] is None   # its stream carries its schema
        else:
            assert encoding == "json" and indexed["schemas"][topic]["encoding"] == "jsonschema", topic
    return indexed


def check_columns(indexed: dict, events: int) -> None:
    """The columns messages are the record's, Arrow IPC each; the record counts ``events``."""
    columns = indexed["columns"]
    assert indexed["messages"][COLUMNS_TOPIC] == len(columns) >= 1
    assert all(c["arrow"] and c["bytes"] > 8 for c in columns), columns
    columns_record = indexed["metadata"][COLUMNS_RECORD]
    assert int(columns_record["messages"]) == len(columns)
    assert int(columns_record["events"]) == events
    assert indexed["messages"]["/events"] == events


def decoded(*paths: str) -> int:
    return sum(1 for _ev in analyzer.open(*paths, redecode=True))


@pytest.fixture(scope="module")
def generated_capture(tmp_path_factory: pytest.TempPathFactory) -> str:
    """A capture of some 13,000 events: several MCAP chunks (the rotated parts below
    hold several columns messages: one a part)."""
    path = tmp_path_factory.mktemp("generated") / "bus.log"
    path.write_text(generate(5_000, seed=5).socat_log(nanoseconds=True))
    return str(path)


@pytest.mark.parametrize("capture", ["demo-socat", "generated"])
def test_mcap_core_reads_a_default_recording_and_its_columns_whole(tmp_path: Path, capture: str,
                                                                   generated_capture: str) -> None:
    inputs = {"demo-socat": SOCAT_LOG, "generated": generated_capture}[capture]
    out = converted(tmp_path, [inputs])
    indexed = read_whole(out)
    check_columns(indexed, decoded(out))
    assert indexed["chunk_compressions"].get("zstd", 0) >= 1   # the app's zstd decompressor did inflate them
    if capture == "generated":
        assert indexed["chunks"] >= 3 and len(indexed["columns"]) >= 1


def test_mcap_core_reads_a_lean_recording_whole(tmp_path: Path) -> None:
    lean = converted(tmp_path, [SOCAT_LOG], "--lean", name="lean.mcap")
    plain = converted(tmp_path, [SOCAT_LOG], name="plain.mcap")
    indexed = read_whole(lean)
    assert COLUMNS_TOPIC not in indexed["messages"] and COLUMNS_RECORD not in indexed["metadata"]
    assert "/events" not in indexed["messages"] and indexed["messages"]["/serial/reads"] >= 1
    assert indexed["metadata"]["gimbalscope"]["profile"] == "lean"
    full = read_whole(plain)
    # the same capture: its events decode from the reads, its transactions are those of the default
    assert decoded(lean) == full["messages"]["/events"] == decoded(plain)
    assert indexed["messages"]["/transactions"] == full["messages"]["/transactions"]


def test_mcap_core_reads_rotated_parts_whole(tmp_path: Path) -> None:
    parts, _info = record(tmp_path / "rec.mcap", [SOCAT_LOG], rotate_bytes=20_000)
    assert len(parts) >= 3, parts
    events = 0
    for part in parts:
        indexed = read_whole(part)
        check_columns(indexed, indexed["messages"]["/events"])   # its record counts its own /events
        events += indexed["messages"]["/events"]
    assert events == decoded(*parts) == decoded(SOCAT_LOG)
