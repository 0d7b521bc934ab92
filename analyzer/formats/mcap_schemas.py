"""MCAP and Foxglove topics and their JSON Schemas (docs/foxglove.md).

Every message is JSON with a JSON Schema, so Foxglove shows and plots the
fields. The raw byte topics are the ground truth: a newer dissector re-decodes an
old capture from them. Key names are the JSON Lines contract (docs/json-lines.md).

The schemas are written for the way the Foxglove app reads a JSON Schema (it
turns each into message definitions, docs/foxglove.md, "What the app reads"):

- every property has one ``type``, never a list: a value that can be missing
  (``t`` without time, ``command`` of an orphan) is an optional key, left out of
  the message, instead of ``null``;
- objects name their properties: ``fields`` lists every field name of the
  command table with its type, unit and commands (``dissectors.commands``);
- bytes are base64 strings with ``"contentEncoding": "base64"``.

``required`` lists the keys every message has, and ``additionalProperties`` is
false, so a validator catches a message that drifted from its schema.
"""

from __future__ import annotations

import json
from functools import cache
from typing import Any

from dissectors import problems
from dissectors.commands import COMMANDS, field_types
from dissectors.event import KINDS, STATUSES

RAW_TOPIC = "/serial/{line}/raw"     # line A, B, or AB (single-line tap)
EVENTS_TOPIC = "/events"
TRANSACTIONS_TOPIC = "/transactions"
LOG_TOPIC = "/log"                   # foxglove.Log: human-readable anomalies
MARKS_TOPIC = "/marks"               # foxglove.Log: the events marked, with notes (analyzer/formats/marks.py)
POSITION_TOPIC = "/gimbal/{device}/position"   # per device: analyzer/analysis/positions.py
READS_TOPIC = "/serial/reads"        # lean recordings: the reads of every line, batched in wire order
METADATA_NAME = "gimbalscope"
# the decoded events as the store's columns, Arrow IPC (analyzer/formats/store_ipc.py), in chunks of
# their own; the metadata record saying they are complete, written when the recording closes
COLUMNS_TOPIC = "/gimbalscope/columns"
COLUMNS_ENCODING = "arrow.ipc"
COLUMNS_RECORD = "gimbalscope.columns"
PROFILE = "gimbalscope"

DIALECT = "https://json-schema.org/draft/2020-12/schema"

_TIME = {"type": "number", "description": "seconds since the capture's first byte (left out without time)"}
_BYTES = {"type": "string", "contentEncoding": "base64"}


def _object(title: str, description: str, properties: dict, required: tuple[str, ...] = ()) -> dict:
    schema = {"$schema": DIALECT, "title": title, "description": description, "type": "object",
              "properties": properties, "additionalProperties": False}
    if required:
        schema["required"] = list(required)
    return schema


def _fields_schema() -> dict:
    """``fields``: every field name of the command table, typed, with its unit and
    the commands that carry it in ``description``."""
    carriers: dict[str, list[str]] = {}
    for c in COMMANDS:
        for layout in (c.layout, *c.result):
            for f in layout.fields:
                ids = carriers.setdefault(f.name, [])
                if c.id not in ids:
                    ids.append(c.id)
    properties = {}
    for name, ft in field_types().items():
        what = ft.type if ft.items is None else f"array of {ft.items}"
        text = what + (f", {ft.unit}" if ft.unit else "") + (f": {ft.desc}" if ft.desc else "")
        if name in carriers:
            text += f" ({', '.join(carriers[name])})"
        prop: dict[str, Any] = {"type": ft.type, "description": text}
        if ft.items is not None:
            prop["items"] = {"type": ft.items}
        if ft.unit:
            prop["unit"] = ft.unit   # an annotation: validators and the app skip it, people read it
        properties[name] = prop
    return {"type": "object", "description": "decoded values, named as in docs/fields.md (left out: no value)",
            "properties": properties, "additionalProperties": False}


FIELDS = _fields_schema()
# the receiver's own errors on a chunk's bytes, as a logic or USB capture's source
# tells them (docs/mcap.md, "Below the bytes"; analyzer/formats/mcap_lines.py)
_LINE_ERRORS = {
    "type": "array", "description": "the receiver's own errors on these bytes (left out: none, or a source that "
                                    "cannot see them)",
    "items": {"type": "object", "properties": {
        "at": {"type": "integer", "minimum": 0, "description": "the byte's index in data"},
        "problem": {"type": "string", "enum": [p.name for p in problems.TABLE if p.parent is problems.LINE],
                    "description": "the problem's id"},
        "detail": {"type": "string", "description": "the problem's text after its category"},
    }, "required": ["at", "problem"], "additionalProperties": False}}
_PROBLEMS = {"type": "array", "items": {"type": "string"},
             "description": "each 'category: detail' (docs/json-lines.md); empty when clean"}

RAW = _object(
    "gimbalscope.RawChunk", "Bytes read from one serial line, as read",
    {
        "line": {"type": "string", "enum": ["A", "B", "AB"],
                 "description": "A controller→device, B device→controller, AB single-line tap"},
        "offset": {"type": "integer", "minimum": 0, "description": "offset of the first byte in the line's stream"},
        "t": {**_TIME, "description": "wire time of the read, s since capture start (left out without time)"},
        "data": {**_BYTES, "description": "the bytes (empty: time ran on with nothing on the wire)"},
        "line_errors": _LINE_ERRORS,
    },
    ("line", "offset", "data"))

EVENT = _object(
    "gimbalscope.Event", "One decoded event (docs/json-lines.md); keys without a value are left out, and so "
    "are t (the message's log time) and raw (on the line's raw topic at offset)",
    {
        "number": {"type": "integer", "minimum": 1, "description": "event number, 1-based, in wire order"},
        "t_end": {**_TIME, "description": "wire time of the end of the last byte"},
        "line": {"type": "string", "enum": ["A", "B", "AB"]},
        "offset": {"type": "integer", "minimum": 0, "description": "byte offset in the line's stream"},
        "kind": {"type": "string", "enum": list(KINDS)},
        "command": {"type": "string", "description": "command id (a result: the command it answers)"},
        "dst": {"type": "array", "items": {"type": "integer", "minimum": 0, "maximum": 255},
                "minItems": 3, "maxItems": 3, "description": "frames: [group, port, device] as written"},
        "src": {"type": "integer", "minimum": 0, "maximum": 255, "description": "frames: source group"},
        "payload": {"type": "string", "description": "frames: the payload as text, other bytes as \\xNN"},
        "checksum_ok": {"type": "boolean", "description": "frames: the checksum fits"},
        "fields": FIELDS,
        "problems": _PROBLEMS,
        "txn": {"type": "integer", "minimum": 1, "description": "transaction shared by a command and its answers"},
        "status": {"type": "string", "enum": list(STATUSES), "description": "commands: how the command ended"},
        "latency": {"type": "number", "description": "answers: s from the command's end to the answer"},
        "retransmission": {"type": "boolean", "description": "commands: resends a failed command"},
        "request": {"type": "integer", "minimum": 1, "description": "answers: number of the command answered"},
        "device": {"type": "string", "description": "the gimbal's address group.port.device: a command's "
                   "destination, a result's sender, an ACK/NAK/NIC's command's"},
    },
    ("number", "line", "offset", "kind", "fields", "problems", "retransmission"))

TRANSACTION = _object(
    "gimbalscope.Transaction", "A command and its answers (keys without a value are left out; its time is the "
    "message's log time)",
    {
        "txn": {"type": "integer", "minimum": 1},
        "number": {"type": "integer", "minimum": 1, "description": "event number of the command"},
        "command": {"type": "string", "description": "command id"},
        "device": {"type": "string", "description": "group.port.device"},
        "status": {"type": "string", "enum": list(STATUSES)},
        "retransmission": {"type": "boolean"},
        "ack_latency": {"type": "number", "description": "s from the command's end to its ACK/NAK"},
        "result_latency": {"type": "number", "description": "s from the command's end to its result"},
        "answers": {"type": "array", "items": {"type": "integer", "minimum": 1}, "description": "event numbers"},
        "fields": {**FIELDS, "description": "the command's fields, then its result's"},
        "problems": _PROBLEMS,
    },
    ("txn", "number", "device", "retransmission", "answers", "fields", "problems"))

_ANGLES = {"type": "object", "properties": {
    "azimuth_deg": {"type": "number", "unit": "deg", "description": "number, deg: azimuth (pan); + is ccw"},
    "elevation_deg": {"type": "number", "unit": "deg", "description": "number, deg: elevation (tilt); + is ccw"}},
    "required": ["azimuth_deg", "elevation_deg"], "additionalProperties": False}

POSITION = _object(
    "gimbalscope.Position",
    "One gimbal's commanded target and reported position (analyzer/analysis/positions.py): plot "
    "target.azimuth_deg against reported.azimuth_deg",
    {
        "device": {"type": "string", "description": "group.port.device"},
        "number": {"type": "integer", "minimum": 1, "description": "the event this message comes from"},
        "source": {"type": "string", "enum": ["command", "result"],
                   "description": "command: a new target (P, or Pnn of a known preset); result: a P? report"},
        "preset": {"type": "integer", "minimum": 0, "maximum": 255, "description": "the preset a Pnn target is"},
        "target": {**_ANGLES, "description": "the last target commanded (left out until one is)"},
        "reported": {**_ANGLES, "description": "the position the gimbal reported (result messages only)"},
    },
    ("device", "number", "source"))

# foxglove.Log, as Foxglove's schema defines it
LOG = _object(
    "foxglove.Log", "A log message",
    {
        "timestamp": {"type": "object", "title": "time",
                      "properties": {"sec": {"type": "integer", "minimum": 0},
                                     "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}},
                      "required": ["sec", "nsec"]},
        "level": {"title": "foxglove.LogLevel", "type": "integer",
                  "oneOf": [{"title": "UNKNOWN", "const": 0}, {"title": "DEBUG", "const": 1},
                            {"title": "INFO", "const": 2}, {"title": "WARNING", "const": 3},
                            {"title": "ERROR", "const": 4}, {"title": "FATAL", "const": 5}]},
        "message": {"type": "string"},
        "name": {"type": "string"},
        "file": {"type": "string"},
        "line": {"type": "integer", "minimum": 0},
    },
    ("timestamp", "level", "message", "name", "file", "line"))

READS = _object(
    "gimbalscope.RawReads", "Consecutive reads from the serial lines, in the order they were read across the "
    "lines (a lean recording's ground truth, docs/mcap.md, \"Lean recordings\"); a read's offset is the sum of "
    "the sizes of its line's earlier reads",
    {
        "reads": {"type": "array", "minItems": 1, "description": "in the order read, whatever their line",
                  "items": {"type": "object", "properties": {
                      "line": RAW["properties"]["line"],
                      "t": RAW["properties"]["t"],
                      "data": RAW["properties"]["data"],
                      "line_errors": _LINE_ERRORS,
                  }, "required": ["line", "data"], "additionalProperties": False}},
    },
    ("reads",))

INFO, WARNING, ERROR = 2, 3, 4

# every schema, by the key messages name it with (analyzer/formats/mcap_messages.py)
SCHEMAS = {"raw": RAW, "event": EVENT, "txn": TRANSACTION, "log": LOG, "position": POSITION}
# a lean recording's (docs/mcap.md, "Lean recordings"): no /events, raw reads batched
LEAN_SCHEMAS = {"reads": READS, "txn": TRANSACTION, "log": LOG, "position": POSITION}
ALL_SCHEMAS = {**SCHEMAS, **LEAN_SCHEMAS}
# the recording profiles (the metadata record's ``profile``)
DEFAULT, LEAN = "default", "lean"
PROFILES = (DEFAULT, LEAN)


@cache
def encoded_by_key(key: str) -> bytes:
    return encoded(ALL_SCHEMAS[key])


def encoded(schema: dict) -> bytes:
    return json.dumps(schema, separators=(",", ":"), ensure_ascii=False).encode()
