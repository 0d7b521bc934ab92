"""``gimbalscope foxglove layout``: the Foxglove layout for a capture, run as a user
runs it. The gimbals and lines expected are those the capture is known to hold
(frames built by hand, the demo's installation), never taken from the output;
the layout is checked against the SDK's own classes by building it again from
its JSON with ``foxglove.layouts``."""

from __future__ import annotations

import dataclasses
import gzip
import json
import re
import struct
from base64 import b64encode

import foxglove.layouts as fl
import pytest
from mcap.writer import Writer

from analyzer.formats import mcap_schemas as S
from analyzer.simulation.scenario import DEVICES as DEMO_DEVICES
from dissectors.event import format_address
from tests.conftest import BUS, CTL, DEV, SOCAT_LOG, frame, run_cli

ACK = b"\x06"
GO = "P0FA0FC18"   # go to az +40.00 el -10.00 (Table 11)
AXES = (("az", "azimuth_deg"), ("el", "elevation_deg"))
PARTS = ("target", "reported")
FEW = 3            # plots side by side at most; beyond, each keeps a third of the height


# ------------------------------------------------------------------ reading a layout

def layout_of(*args) -> dict:
    r = run_cli("foxglove", "layout", *args)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    return json.loads(r.stdout)


def panels(node) -> list[dict]:
    """Every panel of the layout, in document order."""
    if isinstance(node, dict):
        if node.get("type") == "panel":
            return [node]
        return [p for value in node.values() for p in panels(value)]
    if isinstance(node, list):
        return [p for value in node for p in panels(value)]
    return []


def of_type(layout: dict, panel_type: str) -> list[dict]:
    return [p for p in panels(layout) if p["panelType"] == panel_type]


def expected_series(device: str) -> set[tuple[str, str]]:
    topic = f"/gimbal/{device}/position"
    return {(f"{axis} {part}", f"{topic}.{part}.{field}") for axis, field in AXES for part in PARTS}


def check_layout(layout: dict, devices: list[str], lines: list[str], *, template: bool = False,
                 lean: bool = False) -> None:
    """The layout's contract: version 1, a Log panel on /log, exactly one plot per
    gimbal (in this order) with its four series, a Raw Messages panel per line,
    tables of the events and transactions, and plots never squeezed. A lean
    recording's: no events table, and one Raw Messages panel on /serial/reads."""
    assert layout["version"] == 1
    assert [p["config"]["topicToRender"] for p in of_type(layout, "Log")] == ["/log"]
    plots = of_type(layout, "Plot")
    assert len(plots) == len(devices)
    for plot, device in zip(plots, devices):
        if template:
            assert device in plot["title"] and "edit" in plot["title"]
        else:
            assert plot["title"] == device
        series = plot["config"]["paths"]
        assert {(s["label"], s["value"]) for s in series} == expected_series(device)
        assert len(series) == 4
        for s in series:   # a target holds until the next command
            assert s["lineInterpolation"] == ("step" if ".target." in s["value"] else "linear")
    raw = ["/serial/reads"] if lean else [f"/serial/{x}/raw" for x in lines]
    assert [p["config"]["topicPath"] for p in of_type(layout, "RawMessages")] == raw
    tables = ["/transactions"] if lean else ["/events", "/transactions"]
    assert sorted(p["config"]["topicPath"] for p in of_type(layout, "Table")) == tables
    check_readable(layout["content"])
    check_sdk_round_trip(layout)


def check_readable(node) -> None:
    """No container shares its height or width among more than a few plots: beyond
    them plots are stacked (scrolling), each a third of the height."""
    if not isinstance(node, dict):
        return
    kind = node.get("type")
    if kind == "split":
        assert sum(item["content"].get("panelType") == "Plot" for item in node["items"]) <= FEW
        for item in node["items"]:
            check_readable(item["content"])
    elif kind == "stack":
        assert all(item["size"] >= 0.33 for item in node["panels"])
    elif kind == "tabs":
        for tab in node["tabs"]:
            check_readable(tab["content"])


# the SDK writes layouts but reads none: build each node again from its JSON with the
# SDK's classes (an unknown key or value type fails) and compare what it writes
SDK_PANELS = {"Plot": (fl.PlotPanel, fl.PlotConfig), "Log": (fl.LogPanel, fl.LogConfig),
              "RawMessages": (fl.RawMessagesPanel, fl.RawMessagesConfig), "Table": (fl.TablePanel, fl.TableConfig)}


def _snake(key: str) -> str:
    return re.sub(r"[A-Z]", lambda m: "_" + m.group(0).lower(), key)


def _make(cls, data: dict):
    kwargs = {_snake(key): value for key, value in data.items()}
    unknown = set(kwargs) - {f.name for f in dataclasses.fields(cls)}
    assert not unknown, f"{cls.__name__} has no {unknown}"
    return cls(**kwargs)


def sdk_node(node: dict):
    kind = node["type"]
    if kind == "split":
        return fl.SplitContainer(direction=node["direction"], items=[
            fl.SplitItem(proportion=item["proportion"], content=sdk_node(item["content"])) for item in node["items"]])
    if kind == "tabs":
        return fl.TabContainer(selected_tab_index=node["selectedTabIndex"], tabs=[
            fl.TabItem(title=tab["title"], content=sdk_node(tab["content"])) for tab in node["tabs"]])
    if kind == "stack":
        return fl.StackContainer(title=node.get("title"), panels=[
            fl.StackItem(panel=sdk_node(item["panel"]), size=item["size"]) for item in node["panels"]])
    assert kind == "panel" and node["version"] == 1, node
    panel_class, config_class = SDK_PANELS[node["panelType"]]
    config = dict(node["config"])
    if "paths" in config:
        config["paths"] = [_make(fl.PlotSeries, series) for series in config["paths"]]
    assert set(node) <= {"type", "panelType", "config", "title", "version"}
    return panel_class(title=node.get("title"), config=_make(config_class, config))


def check_sdk_round_trip(layout: dict) -> None:
    assert set(layout) == {"version", "content"}
    again = fl.Layout(content=sdk_node(layout["content"]))
    assert json.loads(again.to_json()) == layout


# ------------------------------------------------------------------ captures

def _go(dst) -> bytes:
    return frame(dst, 0, GO)


def hand_built() -> tuple[list[tuple[bytes, bytes]], list[str]]:
    """(command, answer) pairs, and the gimbals they give positions to, in address
    order: go-to commands to four gimbals (1.1.9 before 1.1.10: numbers, not
    text), and none for a home command, a garbled go-to and a broadcast."""
    garbled = bytearray(_go((1, 1, 5)))
    garbled[-1] ^= 0xFF   # bad checksum: the gimbal ignores it
    pairs = [(_go((1, 1, 10)), ACK), (_go((1, 1, 9)), ACK), (frame((1, 1, 4), 0, "HO"), ACK),
             (bytes(garbled), b""), (_go((255, 255, 255)), b""), (_go((2, 1, 1)), ACK), (_go((1, 2, 3)), ACK)]
    return pairs, ["1.1.9", "1.1.10", "1.2.3", "2.1.1"]


@pytest.fixture
def bus_dump(tmp_path):
    pairs, devices = hand_built()
    path = tmp_path / "bus.bin"
    path.write_bytes(b"".join(cmd + answer for cmd, answer in pairs))
    return path, devices


@pytest.fixture
def two_dumps(tmp_path):
    pairs, devices = hand_built()
    ctl, dev = tmp_path / "ctl.bin", tmp_path / "dev.bin"
    ctl.write_bytes(b"".join(cmd for cmd, _ in pairs))
    dev.write_bytes(b"".join(answer for _, answer in pairs))
    return (ctl, dev), devices


DEMO_ADDRESSES = [format_address(d) for d in DEMO_DEVICES]


@pytest.fixture(scope="module")
def demo_recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("demo") / "demo.mcap"
    r = run_cli("demo", "--record", path, "--no-tui", "--seconds", "3", "--clean", timeout=120)
    assert r.returncode == 0, r.stderr
    return path


def without_summary(path, out):
    """``path`` cut where its summary starts (the Footer says where), as a tap killed
    after its last chunk leaves it: no summary, no footer."""
    data = path.read_bytes()
    summary_start = struct.unpack_from("<Q", data, len(data) - 8 - 4 - 8 - 8)[0]   # Footer: start, offset, crc; magic
    assert 0 < summary_start < len(data)
    out.write_bytes(data[:summary_start])
    return out


# ------------------------------------------------------------------ tests

def test_template_without_capture():
    r = run_cli("foxglove", "layout")
    assert r.returncode == 0 and r.stderr == ""
    check_layout(json.loads(r.stdout), ["1.1.1"], ["A", "B"], template=True)


def test_demo_recording_has_a_plot_per_gimbal(demo_recording):
    check_layout(layout_of(demo_recording), DEMO_ADDRESSES, ["A", "B"])


def test_demo_recording_in_parts(tmp_path):
    base = tmp_path / "site.mcap"
    r = run_cli("demo", "--record", base, "--no-tui", "--seconds", "3", "--clean", "--rotate-mb", "0.005",
                timeout=120)
    assert r.returncode == 0, r.stderr
    parts = sorted(tmp_path.glob("site-*.mcap"))
    assert len(parts) >= 2
    check_layout(layout_of(*reversed(parts)), DEMO_ADDRESSES, ["A", "B"])


def test_lean_recording_has_its_reads_panel_and_no_events_table(tmp_path):
    # a lean recording (docs/mcap.md): the reads of both lines on /serial/reads, no /events
    path = tmp_path / "lean.mcap"
    r = run_cli("demo", "--record", path, "--lean", "--no-tui", "--seconds", "3", "--clean", timeout=120)
    assert r.returncode == 0, r.stderr
    check_layout(layout_of(path), DEMO_ADDRESSES, ["A", "B"], lean=True)
    check_layout(layout_of(path, "--baud", "9600"), DEMO_ADDRESSES, ["A", "B"], lean=True)   # decoded, still lean
    cut = without_summary(path, tmp_path / "killed.mcap")   # its channels found by the walk too
    check_layout(layout_of(cut), DEMO_ADDRESSES, ["A", "B"], lean=True)


def test_recording_without_summary_is_walked(demo_recording, tmp_path):
    cut = without_summary(demo_recording, tmp_path / "killed.mcap")
    assert layout_of(cut) == layout_of(demo_recording)


def test_compressed_recording(demo_recording, tmp_path):
    packed = tmp_path / "demo.mcap.gz"
    packed.write_bytes(gzip.compress(demo_recording.read_bytes()))
    assert layout_of(packed) == layout_of(demo_recording)


def test_single_line_dump_is_decoded(bus_dump):
    path, devices = bus_dump
    assert len(devices) > FEW   # plots stacked
    check_layout(layout_of(path), devices, ["AB"])


def test_two_dumps_are_decoded(two_dumps):
    paths, devices = two_dumps
    check_layout(layout_of(*paths), devices, ["A", "B"])


@pytest.mark.parametrize("inputs", [[SOCAT_LOG], [BUS], [CTL, DEV], "bus", "two"],
                         ids=["socat-log", "bus-sample", "two-dump-samples", "hand-built-bus", "hand-built-two"])
def test_decoded_capture_and_its_recording_give_the_same_layout(inputs, tmp_path, request):
    if inputs == "bus":
        path, _ = request.getfixturevalue("bus_dump")
        inputs = [path]
    elif inputs == "two":
        inputs = list(request.getfixturevalue("two_dumps")[0])
    recording = tmp_path / "converted.mcap"
    r = run_cli("convert", *inputs, "-o", recording)
    assert r.returncode == 0, r.stderr
    decoded = layout_of(*inputs)
    assert of_type(decoded, "Plot")
    assert layout_of(recording) == decoded
    assert layout_of(without_summary(recording, tmp_path / "cut.mcap")) == decoded


def handmade_recording(path, *, position_topics: bool) -> None:
    """A recording whose raw bytes hold one home command (no position). With
    ``position_topics`` it was made with the position topics and has one for
    gimbal 3.2.1; without, it predates them (no gimbalscope.Position schema)."""
    raw = b"".join((frame((3, 2, 1), 0, "HO"), ACK)) if position_topics else _go((3, 2, 1)) + ACK
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile=S.PROFILE, library="test")
        raw_schema = writer.register_schema(S.RAW["title"], "jsonschema", S.encoded(S.RAW))
        channel = writer.register_channel("/serial/AB/raw", "json", raw_schema)
        writer.add_message(channel, 1_795_000_000_000_000_000, json.dumps(
            {"line": "AB", "offset": 0, "data": b64encode(raw).decode()}).encode(), 1_795_000_000_000_000_000)
        if position_topics:
            schema = writer.register_schema(S.POSITION["title"], "jsonschema", S.encoded(S.POSITION))
            position = writer.register_channel("/gimbal/3.2.1/position", "json", schema)
            writer.add_message(position, 1_795_000_000_000_000_001, json.dumps(
                {"device": "3.2.1", "number": 1, "source": "command",
                 "target": {"azimuth_deg": 0.0, "elevation_deg": 0.0}}).encode(), 1_795_000_000_000_000_001)
        writer.finish()


def test_recording_gimbals_come_from_its_channels(tmp_path):
    """The raw bytes of this recording give no position: the plot for 3.2.1 can only
    come from its channel. A serial option given decodes it instead."""
    path = tmp_path / "handmade.mcap"
    handmade_recording(path, position_topics=True)
    check_layout(layout_of(path), ["3.2.1"], ["AB"])
    check_layout(layout_of(without_summary(path, tmp_path / "cut.mcap")), ["3.2.1"], ["AB"])
    r = run_cli("foxglove", "layout", path, "--baud", "9600")
    assert r.returncode == 0, r.stderr
    check_layout(json.loads(r.stdout), [], ["AB"])
    assert "no gimbal positions" in r.stderr


def test_recording_from_before_the_position_topics_is_decoded(tmp_path):
    path = tmp_path / "old.mcap"
    handmade_recording(path, position_topics=False)
    check_layout(layout_of(path), ["3.2.1"], ["AB"])


def test_capture_without_positions_warns_and_has_no_plots(tmp_path):
    path = tmp_path / "home.bin"
    path.write_bytes(frame((1, 1, 1), 0, "HO") + ACK + frame((1, 1, 2), 0, "HO") + ACK)
    r = run_cli("foxglove", "layout", path)
    assert r.returncode == 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gimbalscope: warning: ") and "no gimbal positions" in lines[0]
    check_layout(json.loads(r.stdout), [], ["AB"])


@pytest.mark.parametrize("content", [None, b"hello, this is no capture\n", b"\x89MCAP0\r\n" + b"\x05" * 40, b""],
                         ids=["missing", "text", "broken-mcap", "folder"])
def test_bad_input_is_one_line_and_exit_2(tmp_path, content):
    path = tmp_path / "input"
    if content is not None:
        if content == b"":
            path.mkdir()   # a folder
        else:
            path.write_bytes(content)
    out = tmp_path / "layout.json"
    r = run_cli("foxglove", "layout", path, "-o", out)
    assert r.returncode == 2
    assert r.stdout == "" and "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gimbalscope: error: ") and str(path) in lines[0]
    assert not out.exists()


def test_output_file(tmp_path, bus_dump):
    path, devices = bus_dump
    out = tmp_path / "gimbal.json"
    r = run_cli("foxglove", "layout", path, "-o", out)
    assert r.returncode == 0 and r.stdout == "", r.stderr
    assert r.stderr == f"gimbalscope: wrote the layout to {out}\n"   # it says what it wrote
    written = json.loads(out.read_text())
    check_layout(written, devices, ["AB"])
    assert written == layout_of(path)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []   # no temporary file left
    r = run_cli("foxglove", "layout", "-o", out)   # an existing file is kept ...
    assert r.returncode == 2 and "--force" in r.stderr and json.loads(out.read_text()) == written
    r = run_cli("foxglove", "layout", "-o", out, "--force")   # ... unless told
    assert r.returncode == 0
    check_layout(json.loads(out.read_text()), ["1.1.1"], ["A", "B"], template=True)
    r = run_cli("foxglove", "layout", path, "-o", path, "--force")   # never over an input
    assert r.returncode == 2 and "input" in r.stderr


def test_foxglove_alone_prints_its_help_and_exits_2():
    r = run_cli("foxglove")
    assert r.returncode == 2
    assert r.stdout.startswith("usage: gimbalscope foxglove") and "layout" in r.stdout
    r = run_cli("foxglove", "layout", "--help")
    assert r.returncode == 0 and r.stdout.startswith("usage: gimbalscope foxglove layout")
