"""The sigrok-cli command that shows a capture through the decoder ``gimbal``
(docs/instruments.md, "The sigrok decoder"): the ``uart`` decoder told what our
software UART measured of each line (its channel, rate, format and idle
level), with ``gimbal`` stacked on it.

sigrok's ``uart`` decoder finds out nothing by itself: given the wrong channel
name sigrok-cli refuses to start, and given the wrong rate or polarity it
annotates garbage. So nothing is measured here again: the capture is opened
through gimbalscope's own reader (analyzer/sources/sampled.py) and its
``LineReport``\\ s are read.

sigrok-cli reads sessions (``.sr``) and VCD (``-I vcd``). It cannot read a
Saleae export (its CSV input takes rows as samples, not as transitions), nor a
compressed file; those are refused in one line that says what to do instead.
"""

from __future__ import annotations

import math
import re
import shlex
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..errors import CaptureError
from ..lines import LINE_A, LINE_AB, LINE_B
from ..outfile import show
from ..physical.bitrate import named_rate
from ..physical.report import LineReport
from ..sources.sampled import hz
from ..words import counted
from .decoder import DECODER_ID

if TYPE_CHECKING:
    from ..physical.edges import Waveform
    from ..sources.sampled import SampledSource
    from ..sources.vcd import Header

# What the uart decoder calls our parity letters (mark parity is a 1 bit, space a 0).
PARITY = {"N": "none", "E": "even", "O": "odd", "M": "one", "S": "zero"}
# sigrok-cli's -P takes its argument apart at these: a channel named with one cannot be given.
SPLITS = re.compile(r"[:,=]")
# A line whose clock is off its standard rate by more than this is given its measured
# rate: sigrok's uart decoder samples each bit at the middle its rate puts it, so
# 5 % off over a character's ten bits lands the stop bit's sample in the next bit.
OFF_NOMINAL = 0.02
# Samples a bit sigrok-cli is asked to make of a VCD's times at least. sigrok's VCD
# input makes a sample of every time unit: a simulator's 1 ns unit is a billion a
# second, which the uart decoder walks through for seconds a character.
VCD_SAMPLES_A_BIT = 100
# The annotation rows shown: the conversation and its problems (the fields row is
# one annotation a field, more than a terminal wants).
ROWS = "frames:problems"
ROLE = {LINE_A: "line A (the controller's commands)", LINE_B: "line B (the devices' answers)",
        LINE_AB: "one line carrying both directions"}


@dataclass
class SigrokCommand:
    """``argv``: sigrok-cli's arguments; ``env``: the environment it needs
    (SIGROKDECODE_DIR for a decoder installed elsewhere); ``notes``: what each
    line was measured as, and what the command cannot do for this capture."""
    argv: list[str]
    env: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def text(self) -> str:
        """The command as a shell line."""
        env = "".join(f"{k}={shlex.quote(v)} " for k, v in self.env.items())
        return env + " ".join(shlex.quote(a) for a in self.argv)


def generic(decoders: str | None = None) -> SigrokCommand:
    """The command for a typical capture: two channels named as fx2lafw names them
    (the cheap Cypress FX2 analysers; PulseView keeps those names)."""
    return SigrokCommand(["sigrok-cli", "-i", "CAPTURE.sr", "-P", "uart:baudrate=9600:tx=D0:rx=D1,gimbal",
                          "-A", f"{DECODER_ID}={ROWS}"], _env(decoders))


def generic_hints() -> list[str]:
    """How to make the typical command fit a capture."""
    return [
        ("tx= is line A (the controller's commands), rx= line B (the devices' answers), each by its channel's "
         "name in the capture (D0, D1 are fx2lafw's); sigrok-cli -i CAPTURE.sr --show lists them"),
        ("a line that idles low (probed on the RS-232 side, without a transceiver, or with its wires crossed) "
         "needs :invert_tx=yes (line A) or :invert_rx=yes (line B) after the channels"),
        "one wire carrying both directions: -P uart:baudrate=9600:rx=D0,gimbal:lines=single-line",
        ("gimbalscope sigrok command CAPTURE prints the command for a capture: its channels, rate, format "
         "and idle levels as gimbalscope measures them"),
    ]


def command_for(path: str, *, decoders: str | None = None, **given: Any) -> tuple[SigrokCommand, list[str]]:
    """The command for the capture at ``path``, and the warnings reading it gave.
    ``given``: the reading options the user gave (``channels``, ``baud``,
    ``data_bits``, ``parity``, ``stop_bits``; None: measured). Raises
    CaptureError (one line) for a capture sigrok-cli cannot read or the command
    cannot name."""
    from ..capture import open as open_capture
    from ..sources.sampled import SampledSource
    from ..sources.vcd import ValueChangeDump

    name = show(path)
    if path == "-":
        raise CaptureError("standard input: sigrok-cli reads a file; give the capture's path")
    cap = open_capture(path, **{key: value for key, value in given.items() if value is not None})
    source = cap.source
    try:
        if not isinstance(source, SampledSource):
            raise CaptureError(f"{name}: this is no logic analyser's capture: the sigrok decoder stacks on "
                               "sigrok's uart decoder, which reads waveforms (a .sr session or a VCD)")
        wave = source.waveform
        inputs = _input_args(name, path, wave)
        _read_until_measured(source)
        reports = [source.physical[line] for line in source.lines]
        notes: list[str] = []
        if isinstance(wave, ValueChangeDump):   # read with -I vcd
            names = _vcd_names(wave.header, name, reports)
            notes += _downsample(inputs, wave.header.unit, reports)
        else:
            names = _session_names(name, wave, reports)
        cmd = _command(name, inputs, reports, names, source.lines)
        cmd.notes[:0] = notes
        cmd.env = _env(decoders)
        return cmd, list(cap.warnings)
    finally:
        source.close()


def _env(decoders: str | None) -> dict[str, str]:
    return {"SIGROKDECODE_DIR": show(decoders)} if decoders is not None else {}


def _input_args(name: str, path: str, wave: Waveform) -> list[str]:
    """sigrok-cli's input arguments for the capture, or a CaptureError saying
    why sigrok-cli cannot read it."""
    from ..sources.sigrok import SigrokSession
    from ..sources.vcd import ValueChangeDump

    if isinstance(wave, (SigrokSession, ValueChangeDump)):
        compression = wave.input.compression
        if compression is not None:
            raise CaptureError(f"{name}: sigrok-cli cannot read a {compression}-compressed capture; decompress it "
                               "first and run gimbalscope sigrok command on that")
        return ["-i", path] if isinstance(wave, SigrokSession) else ["-I", "vcd", "-i", path]
    raise CaptureError(f"{name}: sigrok-cli reads sessions (.sr) and VCD, not this capture (its CSV input takes "
                       "a row as a sample, where a Saleae export's rows are transitions); export it from Saleae "
                       "Logic 2 as VCD (File, Export Data, VCD) and run gimbalscope sigrok command on that")


def _read_until_measured(source: SampledSource) -> None:
    """Opening measured the lines on the capture's first blocks; a line that had
    not shown its rate by then is read on until it does (or the capture ends)."""
    def measured() -> bool:
        return all(r.nominal is not None or not r.edges for r in source.physical.values())

    if measured():
        return
    for _ in source.chunks():
        if measured():
            return


def _rate(r: LineReport) -> int | None:
    """The rate to give sigrok's uart decoder for the line (its first, when it
    changed): its standard rate, or what it measured when its clock is too far
    off that for sigrok's sampling."""
    if r.nominal is None:
        return None
    if r.given:
        return int(r.nominal)
    if r.rate_changes:
        measured = r.rate_changes[0].before
        base = named_rate(measured)
    elif r.measured is not None:
        measured, base = r.measured, int(r.nominal)
    else:
        return int(r.nominal)
    return base if abs(measured - base) <= OFF_NOMINAL * base else round(measured)


def _command(name: str, inputs: list[str], reports: list[LineReport], names: dict[str, str],
             lines: tuple[str, ...]) -> SigrokCommand:
    """``names``: each line's channel as sigrok-cli names it."""
    rated = [r for r in reports if _rate(r) is not None]
    if not rated:
        shown = ", ".join(f"{r.channel} ({counted(r.edges, 'edge')})" for r in reports)
        raise CaptureError(f"{name}: no line shows a bit rate ({shown}); give it with --baud")
    lead = rated[0]
    baud = _rate(lead)
    assert baud is not None   # a rated line's
    opts = [f"baudrate={baud}"]
    if lead.data_bits != 8:
        opts.append(f"data_bits={lead.data_bits}")
    if lead.parity != "N":
        opts.append(f"parity={PARITY[lead.parity]}")
    if lead.stop_bits == 1.5:   # 2 stop bits read as 1: a receiver checks the first (and 2.0 is not in 0.5.x)
        opts.append("stop_bits=1.5")
    single = lines == (LINE_AB,)
    sides = {LINE_AB: "rx"} if single else {LINE_A: "tx", LINE_B: "rx"}
    notes: list[str] = []
    for r in reports:
        channel = names[r.line]
        if not channel or SPLITS.search(channel):
            raise CaptureError(f"{name}: channel {channel!r} cannot be named to sigrok-cli (its -P option "
                               "takes names apart at : , and =): rename it (in PulseView, click its name) and "
                               "save the session again")
        side = sides[r.line]
        opts.append(f"{side}={channel}")
        if r.inverted:
            opts.append(f"invert_{side}=yes")
        notes.append(f"{side}: {ROLE[r.line]}, channel {channel}: {_described(r)}")
    for r in rated[1:]:
        own = _rate(r)
        if own is not None and abs(own - baud) > OFF_NOMINAL * baud:
            notes.append(f"line {r.line} runs at {own:,} bit/s and line {lead.line} at {baud:,}: sigrok's uart "
                         f"decoder reads both at one rate; for line {r.line}'s frames, run it again with "
                         f"baudrate={own}")
        if r.format != lead.format:
            notes.append(f"line {r.line} is {r.format} and line {lead.line} {lead.format}: sigrok's uart decoder "
                         f"reads both as {lead.format}")
    for r in reports:
        if r.rate_changes:
            c = r.rate_changes[0]
            notes.append(f"line {r.line} changes rate at {c.t:.6g} s ({c.before:,.0f} to {c.after:,.0f} bit/s): "
                         "sigrok's uart decoder keeps one rate, so what follows shows as noise")
    stack = "uart:" + ":".join(opts) + f",{DECODER_ID}" + (":lines=single-line" if single else "")
    return SigrokCommand(["sigrok-cli", *inputs, "-P", stack, "-A", f"{DECODER_ID}={ROWS}"], notes=notes)


def _described(r: LineReport) -> str:
    rate = _rate(r)
    if rate is None:
        return (f"too few edges ({r.edges}) to measure: read at the other line's rate" if r.edges
                else "never toggles")
    if r.given:
        text = f"{rate:,} bit/s (given)"
    elif r.measured is not None:
        text = f"{rate:,} bit/s (measured {r.measured:,.0f})"
    else:
        text = f"{rate:,} bit/s"
    text += f", {r.format}"
    if r.inverted:
        text += ", idles low (inverted)"
    return text


def _session_names(name: str, wave: Waveform, reports: list[LineReport]) -> dict[str, str]:
    """Each line's channel: the session's name for it, which sigrok-cli takes
    unless two channels share it."""
    for r in reports:
        if wave.channels.count(r.channel) > 1:
            raise CaptureError(f"{name}: two channels are named {r.channel}, which sigrok-cli cannot tell apart: "
                               "rename one (in PulseView, click its name) and save the session again")
    return {r.line: r.channel for r in reports}


def _vcd_names(header: Header, name: str, reports: list[LineReport]) -> dict[str, str]:
    """Each line's channel as sigrok's VCD input names it, or a CaptureError when
    it leaves the channel out or gives two channels its name. ``header``: the
    VCD's, as our reader read it (analyzer/sources/vcd.py, ``Header``)."""
    names = _vcd_channels(header)
    out = {}
    for r in reports:
        found = [theirs for theirs, ours in names if ours == r.channel]
        if not found:
            raise CaptureError(f"{name}: sigrok-cli's VCD input leaves out {r.channel} (it reads the 1-bit wire "
                               "and reg variables only)")
        if sum(1 for theirs, _ in names if theirs == found[0]) > 1:
            raise CaptureError(f"{name}: sigrok-cli names a VCD's channels without their scope, and two of them "
                               f"are {found[0]}: it cannot be told which is {r.channel}")
        out[r.line] = found[0]
    return out


def _downsample(inputs: list[str], unit: float | None, reports: list[LineReport]) -> list[str]:
    """Ask sigrok's VCD input for fewer samples than a time ``unit`` (seconds)
    each when the unit is far finer than the lines need (``inputs`` completed in
    place)."""
    rates = [rate for rate in map(_rate, reports) if rate]
    if not unit or not rates:
        return []
    per_second = round(1.0 / unit) if unit <= 1 else 1.0 / unit
    spare = per_second / (max(rates) * VCD_SAMPLES_A_BIT)
    if spare < 10:
        return []
    factor = 10 ** math.floor(math.log10(spare))
    inputs[1] = f"vcd:downsample={factor}"
    return [(f"the VCD's time unit is {_seconds(unit)}: downsample={factor} has sigrok-cli read it as "
             f"{hz(per_second / factor)} samples")]


def _seconds(unit: float) -> str:
    for name, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9), ("ps", 1e-12), ("fs", 1e-15)):
        if unit >= scale * 0.999:
            return f"{unit / scale:g} {name}"
    return f"{unit:g} s"


_VCD_CHANNEL_KINDS = ("wire", "reg")      # what sigrok's VCD input (libsigrok 0.5) reads


def _vcd_channels(header: Header) -> list[tuple[str, str]]:
    """(sigrok's name, ours) of every channel sigrok's VCD input reads, in the
    order declared. sigrok names a channel by its reference alone; ours adds the
    scope to a name two scopes use (analyzer/sources/vcd.py)."""
    return [(reference, ours) for ours, reference, kind in zip(header.channels, header.references, header.kinds)
            if kind in _VCD_CHANNEL_KINDS]
