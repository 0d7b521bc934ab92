"""``gimbalscope foxglove``: files for the Foxglove app, which opens gimbalscope's
MCAP recordings and connects to its live servers (docs/foxglove.md).

``gimbalscope foxglove layout [CAPTURE...]`` writes a layout (JSON, imported in
the app's layout menu) for the topics of analyzer/formats/mcap_schemas.py, built
with ``foxglove.layouts`` from the Foxglove SDK:

- a Log panel on ``/log`` (the anomalies and the tap's notes);
- a position plot per gimbal, titled with its address: the commanded target and
  the reported position, azimuth and elevation, from
  ``/gimbal/<group.port.device>/position`` (analyzer/analysis/positions.py);
- Table panels on ``/events`` and ``/transactions``, and a Raw Messages panel per
  line (``/serial/A/raw`` and ``/serial/B/raw``, or ``/serial/AB/raw``); for a
  lean recording (``--lean``: no ``/events``), the transactions' table and one Raw
  Messages panel on ``/serial/reads``.

The gimbals and lines are those of CAPTURE, anything ``decode`` reads. A
gimbalscope recording names its gimbals in its channels (a position topic is
registered when its gimbal is first seen), so they are read from the file's
channel records, from its summary or, without one (a killed tap), by a walk over
its chunks, without decoding it. Other inputs, recordings made before the
position topics, and recordings given serial or pairing options (which may
decode differently from how they were recorded) are decoded, and the gimbals
are those ``PositionTracker`` makes a position message for. Without CAPTURE the
layout is a template: gimbal 1.1.1 (its title says to edit the address) on
lines A and B.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from collections.abc import Container, Iterable, Sequence
from typing import TYPE_CHECKING, Literal

from ..analysis.positions import AZ, EL
from ..capture import Capture
from ..formats import mcap_schemas as S
from ..info import CaptureInfo
from ..listeners import PositionFinder
from ..outfile import AtomicOutput, check_output, show
from ..output import print_out
from ..sources import Source, registry
from .common import Subcommands, add_serial_args, open_inputs, run_tap, warn

if TYPE_CHECKING:
    import foxglove.layouts as fl

COMMAND = "foxglove layout"
TEMPLATE_DEVICE = "1.1.1"
TEMPLATE_LINES = ("A", "B")
# Up to this many position plots share the height of the window; more go into a
# scrolling stack, each plot keeping this share of the height.
PLOTS_SHOWN = 3

_POSITION_TOPIC = re.compile(r"/gimbal/(\d{1,3}\.\d{1,3}\.\d{1,3})/position")
_POSITION_SCHEMA = S.POSITION["title"]

# Azimuth and elevation each have a colour; the commanded target is a dashed line
# holding its value until the next command (a step), the reported position a
# solid line through the P? reports (the gimbal moves between them at its set
# rate, so a straight line between two reports is the better guess).
_AXES = (("az", AZ, "#2f80ed"), ("el", EL, "#eb7a2f"))
_PARTS: tuple[tuple[str, Literal["dashed", "solid"], Literal["step", "linear"]], ...] = (
    ("target", "dashed", "step"), ("reported", "solid", "linear"))


def register(sub: Subcommands) -> None:
    p = sub.add_parser("foxglove", help="files for the Foxglove app: a layout for gimbalscope's topics",
                       description="Files for the Foxglove app, which opens gimbalscope's MCAP recordings "
                                   "and connects to its live servers.")
    p.set_defaults(run=lambda args: _help(p))
    what = p.add_subparsers(dest="foxglove_command", metavar="WHAT", parser_class=type(p))
    layout = what.add_parser(
        "layout", help="a layout (JSON) for a capture's gimbals and lines",
        description="Write a Foxglove layout (JSON; import it in the app's layout menu): the /log panel, "
                    "a plot per gimbal of its commanded and reported azimuth and elevation, tables of "
                    "/events and /transactions, and the raw bytes of each line. The gimbals and lines are "
                    "those of CAPTURE (anything 'decode' reads; a recording's gimbals are read from its "
                    "channels without decoding it, unless serial or pairing options are given); without "
                    "CAPTURE, a template for gimbal 1.1.1 on lines A and B.",
        epilog="example: gimbalscope foxglove layout site.mcap > gimbal.json")
    layout.add_argument("inputs", nargs="*", metavar="CAPTURE",
                        help=f"{registry.input_help()}; none: a template")
    layout.add_argument("-o", "--output", metavar="FILE", help="write the layout to FILE (default: standard output)")
    layout.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    add_serial_args(layout)
    layout.set_defaults(run=run_layout)


def _help(parser: argparse.ArgumentParser) -> int:
    """``gimbalscope foxglove`` alone: its help, and exit 2, as the main command does."""
    parser.print_help()
    return 2


def run_layout(args: argparse.Namespace) -> int:
    if args.output is not None:
        check_output(args.output, args.inputs, force=args.force)   # before any work
    if args.inputs:
        devices, lines, lean = capture_contents(open_inputs(args))
        layout = build_layout(devices, lines, lean=lean)
    else:
        layout = build_layout([TEMPLATE_DEVICE], TEMPLATE_LINES, template=True)
    text = json.dumps(json.loads(layout.to_json()), indent=2, ensure_ascii=False)
    if args.output is None:
        print_out(text)
    else:
        with AtomicOutput(args.output) as target:   # a failure on the way removes it
            target.write(text.encode() + b"\n")
        print(f"gimbalscope: wrote the layout to {show(args.output)}", file=sys.stderr)
    return 0


# ------------------------------------------------------------------ what a capture holds

def capture_contents(capture: Capture) -> tuple[list[str], tuple[str, ...], bool]:
    """(the gimbals with positions, in address order; the capture's lines; whether
    it is a lean recording: its raw reads on /serial/reads, no /events). A capture
    without positions is said on standard error."""
    info = CaptureInfo.of(capture, command=COMMAND)
    lines = tuple(capture.lines)
    try:
        recorded, topics = recorded_devices(capture.source)
        if capture.options.explicit:   # options may decode it otherwise than it was recorded: decode it
            recorded = None
    except BaseException:
        capture.source.close()   # a temporary copy of a piped recording goes with it
        raise
    lean = S.READS_TOPIC in topics and S.EVENTS_TOPIC not in topics
    if recorded is not None:
        capture.source.close()
        devices = recorded
    else:
        finder = PositionFinder()
        run_tap(capture, COMMAND, finder, info=info)
        devices = finder.devices
    if not devices:
        warn(f"{info.source}: no gimbal positions in this capture (no P command or P? result to one "
             "gimbal): the layout has no position plots")
    return sorted(devices, key=address_key), lines, lean


def address_key(device: str) -> tuple:
    """group.port.device in numeric order (1.1.2 before 1.1.10)."""
    try:
        return (0, tuple(int(part) for part in device.split(".")))
    except ValueError:
        return (1, device)


def recorded_devices(source: Source) -> tuple[set[str] | None, set[str]]:
    """The gimbals of a gimbalscope recording (or of its parts) by its position
    channels, and its topics; no gimbals (None) when ``source`` is no recording or
    was recorded without the position topics (no gimbalscope.Position schema): it
    must be decoded."""
    from ..sources.mcapfile import McapSource
    from ..sources.mcapparts import McapPartsSource

    if isinstance(source, McapPartsSource):
        paths = [part.path for part in source.parts]
    elif isinstance(source, McapSource):
        paths = [source.path]
    else:
        return None, set()
    devices: set[str] = set()
    every_topic: set[str] = set()
    with_positions = False
    for path in paths:
        schemas, topics = channel_records(path)
        every_topic |= topics
        with_positions = with_positions or _POSITION_SCHEMA in schemas
        for topic in topics:
            m = _POSITION_TOPIC.fullmatch(topic)
            if m is not None:
                devices.add(m.group(1))
    return (devices if with_positions or devices else None), every_topic


def channel_records(path: str) -> tuple[set[str], set[str]]:
    """(schema names, channel topics) of an MCAP file: from its summary, or
    without one by a walk over its records and chunks (each length checked:
    analyzer/sources/mcapwalk.py). Damage ends the walk through what it hit."""
    from ..sources.mcapwalk import (
        OP_CHANNEL,
        OP_CHUNK,
        OP_SCHEMA,
        Damaged,
        Walk,
        read_chunk,
        read_cut_chunk,
        summary_records,
    )

    wanted = (OP_SCHEMA, OP_CHANNEL)
    schemas: set[str] = set()
    topics: set[str] = set()
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        summary = summary_records(f, size, wanted)
        if any(op == OP_CHANNEL for op, _body in summary):
            _collect(((op, body) for op, body in summary), schemas, topics)
            return schemas, topics
        walk = Walk(f, size)
        for _offset, op, body in walk.records((*wanted, OP_CHUNK)):
            if op != OP_CHUNK:
                _collect([(op, body)], schemas, topics)
                continue
            try:
                records, _crc_ok = read_chunk(body)
            except Damaged:
                continue
            _collect(_records_in(records, wanted), schemas, topics)
        if walk.tail is not None:   # a chunk cut short by the end of the file: its first part
            try:
                _collect(_records_in(read_cut_chunk(walk.tail[1]), wanted), schemas, topics)
            except Damaged:
                pass
    return schemas, topics


def _records_in(records: bytes, wanted: Container[int]) -> Iterable[tuple[int, bytes]]:
    """(opcode, body) of the records in a chunk's content with opcodes in ``wanted``,
    up to one that runs past its end."""
    from ..sources.mcapwalk import RECORD, RECORD_HEAD

    pos, end = 0, len(records)
    while end - pos >= RECORD_HEAD:
        op, length = RECORD.unpack_from(records, pos)
        body = pos + RECORD_HEAD
        if length > end - body:
            return
        if op in wanted:
            yield op, records[body:body + length]
        pos = body + length


def _collect(records: Iterable[tuple[int, bytes]], schemas: set[str], topics: set[str]) -> None:
    from mcap.records import Channel, Schema

    from ..sources.mcapwalk import Damaged, parse

    for op, body in records:
        try:
            record = parse(op, body)
        except Damaged:
            return
        if isinstance(record, Channel):
            topics.add(record.topic)
        elif isinstance(record, Schema):
            schemas.add(record.name)


# ------------------------------------------------------------------ the layout

def build_layout(devices: Sequence[str], lines: Sequence[str], *, template: bool = False,
                 lean: bool = False) -> fl.Layout:
    """The layout for ``devices`` (group.port.device, in the order shown) and
    ``lines`` (``A``, ``B``, ``AB``). Position plots take two thirds of the width,
    the log and the tables the rest; with ``template`` the plots' titles say the
    device address is to be edited. A ``lean`` recording has no /events and its
    raw reads on one topic: no Events table, one raw panel."""
    import foxglove.layouts as fl

    tabs = [] if lean else [fl.TabItem(title="Events", content=fl.TablePanel(
        title="Events", config=fl.TableConfig(topic_path=S.EVENTS_TOPIC)))]
    tabs += [
        fl.TabItem(title="Transactions", content=fl.TablePanel(
            title="Transactions", config=fl.TableConfig(topic_path=S.TRANSACTIONS_TOPIC))),
        fl.TabItem(title="Raw reads" if lean else "Raw lines", content=_raw_reads() if lean else _raw_lines(lines)),
    ]
    side = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=1, content=fl.LogPanel(
            title="Log: anomalies and notes", config=fl.LogConfig(topic_to_render=S.LOG_TOPIC))),
        fl.SplitItem(proportion=1, content=fl.TabContainer(selected_tab_index=0, tabs=tabs)),
    ])
    if not devices:
        return fl.Layout(content=side)
    plots = [position_plot(device, template=template) for device in devices]
    if len(plots) <= PLOTS_SHOWN:
        positions: fl.Content = fl.SplitContainer(
            direction="column", items=[fl.SplitItem(proportion=1, content=plot) for plot in plots])
    else:
        positions = fl.StackContainer(title=f"Positions ({len(plots)} gimbals)", panels=[
            fl.StackItem(panel=plot, size=round(1 / PLOTS_SHOWN, 4)) for plot in plots])
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=2, content=positions),
        fl.SplitItem(proportion=1, content=side),
    ]))


def _raw_lines(lines: Sequence[str]) -> fl.Content:
    """A Raw Messages panel per line, side by side."""
    import foxglove.layouts as fl

    panels = [fl.RawMessagesPanel(title=f"Line {line} raw bytes",
                                  config=fl.RawMessagesConfig(topic_path=S.RAW_TOPIC.format(line=line)))
              for line in lines]
    if len(panels) == 1:
        return panels[0]
    return fl.SplitContainer(direction="row", items=[fl.SplitItem(proportion=1, content=p) for p in panels])


def _raw_reads() -> fl.Content:
    """A lean recording's one Raw Messages panel: every line's reads, in wire order."""
    import foxglove.layouts as fl

    return fl.RawMessagesPanel(title="Raw reads of every line",
                               config=fl.RawMessagesConfig(topic_path=S.READS_TOPIC))


def position_plot(device: str, *, template: bool = False) -> fl.PlotPanel:
    """One gimbal's plot: target and reported azimuth and elevation over time."""
    import foxglove.layouts as fl

    topic = S.POSITION_TOPIC.format(device=device)
    series = [fl.PlotSeries(value=f"{topic}.{part}.{field}", label=f"{axis} {part}", color=color,
                            line_style=style, line_interpolation=interpolation, show_line=True,
                            timestamp_method="receiveTime")
              for axis, field, color in _AXES for part, style, interpolation in _PARTS]
    title = device if not template else f"{device} (template: edit the device address in each series)"
    return fl.PlotPanel(title=title, config=fl.PlotConfig(
        paths=series, x_axis_val="timestamp", y_axis_label="deg", show_legend=True,
        show_plot_values_in_legend=True, is_synced=True))
