"""MCAP topics and their JSON Schemas (issue: MCAP recording).

Every message is JSON with a JSON Schema, so Foxglove shows the fields. The raw
byte topics are the ground truth: a newer dissector re-decodes an old capture
from them. Field names are the JSON Lines contract of the README.
"""

from __future__ import annotations

import json

from dissectors.event import KINDS, STATUSES

RAW_TOPIC = "/serial/{line}/raw"     # line A, B, or AB (single-line tap)
EVENTS_TOPIC = "/events"
TRANSACTIONS_TOPIC = "/transactions"
LOG_TOPIC = "/log"                   # foxglove.Log: human-readable anomalies
METADATA_NAME = "gimbalscope"
PROFILE = "gimbalscope"

_NULLABLE_NUMBER = {"type": ["number", "null"]}
_NULLABLE_INT = {"type": ["integer", "null"]}
_NULLABLE_STRING = {"type": ["string", "null"]}
_ADDRESS = {"type": ["array", "null"], "items": {"type": "integer"}, "minItems": 3, "maxItems": 3,
            "description": "destination [group, port, device]"}

RAW = {
    "title": "gimbalscope.RawChunk",
    "description": "Bytes read from one serial line, as read",
    "type": "object",
    "properties": {
        "line": {"type": "string", "enum": ["A", "B", "AB"],
                 "description": "A controller→device, B device→controller, AB single-line tap"},
        "offset": {"type": "integer", "description": "offset of the first byte in the line's stream"},
        "t": {**_NULLABLE_NUMBER, "description": "wire time of the first byte, s since capture start"},
        "data": {"type": "string", "description": "the bytes, lower-case hex"},
    },
    "required": ["line", "offset", "t", "data"],
}

EVENT = {
    "title": "gimbalscope.Event",
    "description": "One decoded event (README, 'Event contract')",
    "type": "object",
    "properties": {
        "number": {"type": "integer"},
        "t": _NULLABLE_NUMBER,
        "t_end": _NULLABLE_NUMBER,
        "line": {"type": "string"},
        "offset": {"type": "integer"},
        "kind": {"type": "string", "enum": list(KINDS)},
        "command": _NULLABLE_STRING,
        "dst": _ADDRESS,
        "device": {**_NULLABLE_STRING, "description": "the gimbal's address group.port.device: a command's "
                   "destination, a result's sender, an ACK/NAK/NIC's command's (null: noise, orphans)"},
        "src": _NULLABLE_INT,
        "payload": _NULLABLE_STRING,
        "checksum_ok": {"type": ["boolean", "null"]},
        "fields": {"type": "object", "description": "decoded values, named as in docs/fields.md"},
        "problems": {"type": "array", "items": {"type": "string"}},
        "txn": _NULLABLE_INT,
        "status": _NULLABLE_STRING,
        "latency": _NULLABLE_NUMBER,
        "retransmission": {"type": "boolean"},
        "request": _NULLABLE_INT,
        "raw": {"type": "string"},
    },
}

TRANSACTION = {
    "title": "gimbalscope.Transaction",
    "description": "A command and its answers",
    "type": "object",
    "properties": {
        "txn": {"type": "integer"},
        "number": {"type": "integer", "description": "event number of the command"},
        "t": _NULLABLE_NUMBER,
        "command": {"type": "string"},
        "device": {"type": "string", "description": "group.port.device"},
        "status": {"type": "string", "enum": list(STATUSES)},
        "retransmission": {"type": "boolean"},
        "ack_latency": _NULLABLE_NUMBER,
        "result_latency": _NULLABLE_NUMBER,
        "answers": {"type": "array", "items": {"type": "integer"}, "description": "event numbers"},
        "fields": {"type": "object", "description": "the command's fields, then its result's"},
        "problems": {"type": "array", "items": {"type": "string"}},
    },
}

# foxglove.Log, as Foxglove's schema defines it
LOG = {
    "title": "foxglove.Log",
    "description": "A log message",
    "type": "object",
    "properties": {
        "timestamp": {"type": "object", "title": "time",
                      "properties": {"sec": {"type": "integer", "minimum": 0},
                                     "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}},
        "level": {"title": "foxglove.LogLevel", "type": "integer",
                  "oneOf": [{"title": "UNKNOWN", "const": 0}, {"title": "DEBUG", "const": 1},
                            {"title": "INFO", "const": 2}, {"title": "WARNING", "const": 3},
                            {"title": "ERROR", "const": 4}, {"title": "FATAL", "const": 5}]},
        "message": {"type": "string"},
        "name": {"type": "string"},
        "file": {"type": "string"},
        "line": {"type": "integer", "minimum": 0},
    },
}

INFO, WARNING, ERROR = 2, 3, 4


def encoded(schema: dict) -> bytes:
    return json.dumps(schema, separators=(",", ":")).encode()
