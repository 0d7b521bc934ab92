"""The detail pane's content, without Textual: an event's tree of frame,
fields (with the bytes each covers), problems and pairing, and the hex dump's
lines. Fields follow the command table (dissectors/commands.py, Tables 4-18).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from dissectors.commands import Command
from dissectors.dissect import field_spans
from dissectors.event import ACK, COMMAND, NAK, NIC, RESULT, Event, format_address
from dissectors.fields import Field

from ..output import fmt_seconds
from ..words import counted


@dataclass
class DetailNode:
    """A line of the detail tree: a label, children, and where Enter goes."""
    label: str
    children: list[DetailNode] = field(default_factory=list)
    jump: int | None = None                 # an event number
    span: tuple[int, int] | None = None     # bytes of the event this field covers
    expanded: bool = True


def detail(ev: Event, answers_of: Callable[[int], list[int]], event: Callable[[int], Event | None]) -> list[DetailNode]:
    """The detail tree of one event: frame, fields, problems, pairing.
    ``answers_of(number)`` gives a command's answers, ``event(number)`` an event."""
    nodes: list[DetailNode] = []
    n = len(ev.raw)
    head = DetailNode(f"#{ev.number} {ev.kind} on line {ev.line}, bytes {ev.offset}–{ev.offset + n - 1}"
                      f" of the line ({counted(n, 'byte')})")
    if ev.t is not None:
        head.children.append(DetailNode(f"time {ev.t:.6f} s → {ev.t_end:.6f} s"))
    if ev.dst is not None:
        head.children.append(DetailNode(f"address {format_address(ev.dst)} (group.port.device)", span=(1, 4)))
        head.children.append(DetailNode(f"source group {ev.src}", span=(4, 5)))
        head.children.append(DetailNode(f"length {len(ev.payload or b'')}", span=(5, 6)))
        ok = "ok" if ev.checksum_ok else "BAD"
        head.children.append(DetailNode(f"checksum 0x{ev.raw[-1]:02x} {ok}", span=(len(ev.raw) - 1, len(ev.raw))))
    device = _device_line(ev)
    if device is not None:
        head.children.append(device)
    nodes.append(head)
    if ev.command or ev.fields:
        entry = ev.entry
        title = f"{ev.command or '?'}"
        if entry is not None:
            title += f" — {entry.name} ({entry.ref})"
        cmd = DetailNode(title)
        spans = {name: (a, b) for name, a, b in field_spans(ev)}
        units = {f.name: f.unit for f in _fields_of(entry)} if entry is not None else {}
        for name, value in (ev.fields or {}).items():
            unit = units.get(name, "")
            span = spans.get(name)
            where = f"  [bytes {span[0]}–{span[1] - 1}]" if span else ""
            cmd.children.append(DetailNode(f"{name} = {value}{(' ' + unit) if unit else ''}{where}", span=span))
        nodes.append(cmd)
    if ev.problems:
        nodes.append(DetailNode("problems", [DetailNode(p) for p in ev.problems]))
    pairing = DetailNode("pairing")
    if ev.kind == COMMAND:
        pairing.children.append(DetailNode(f"status {ev.status or 'waiting'}"
                                           + (" (retransmission)" if ev.retransmission else "")))
        for num in answers_of(ev.number):
            ans = event(num)
            if ans is None:
                continue
            what = {ACK: "ACK", NAK: "NAK", NIC: "NIC", RESULT: "result"}.get(ans.kind, ans.kind)
            after = f" after {fmt_seconds(ans.latency)}" if ans.latency is not None else ""
            pairing.children.append(DetailNode(f"{what} in #{num}{after}", jump=num))
    elif ev.request is not None:
        after = f", {fmt_seconds(ev.latency)} after it ended" if ev.latency is not None else ""
        pairing.children.append(DetailNode(f"answers #{ev.request}{after}", jump=ev.request))
    else:
        pairing.children.append(DetailNode("not paired"))
    nodes.append(pairing)
    return nodes



def _device_line(ev: Event) -> DetailNode | None:
    """Where the device is not the header's destination as written: a result
    (its header addresses the controller) and an ACK/NAK/NIC (no header)."""
    device = ev.device
    if device is None or ev.kind == COMMAND:
        return None
    if ev.kind == RESULT:
        return DetailNode(f"device {device} (source group {ev.src}, port and device as addressed)", span=(2, 5))
    return DetailNode(f"device {device} (the command's, #{ev.request})", jump=ev.request)


def _fields_of(entry: Command) -> list[Field]:
    out = list(entry.layout.fields)
    for layout in entry.result:
        out += list(layout.fields)
    return out


def hex_lines(raw: bytes, highlight: tuple[int, int] | None = None,
              width: int = 16) -> list[tuple[str, str, str, list[tuple[int, int]]]]:
    """Hex and ASCII of ``raw``, ``width`` bytes a line: (offset, hex, ascii) and,
    per line, the character ranges of the hex text to highlight."""
    out = []
    for start in range(0, len(raw), width):
        part = raw[start:start + width]
        hx = " ".join(f"{b:02x}" for b in part)
        asc = "".join(chr(b) if 0x20 <= b < 0x7F else "." for b in part)
        marks = []
        if highlight is not None:
            a, b = max(highlight[0], start), min(highlight[1], start + len(part))
            if a < b:   # half-open columns of the hex text: "0e 0f" without the space after
                marks.append(((a - start) * 3, (b - start) * 3 - 1))
        out.append((f"{start:04x}", hx, asc, marks))
    return out
