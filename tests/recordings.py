"""Every message of a recording matches the JSON Schema its channel declares.

``check_recording`` is run on every MCAP file a test leaves in its ``tmp_path``
(``tests/conftest.py``), so any recording any test writes is checked, with the
``jsonschema`` package (not our code) reading our schemas. A file cut short or
damaged on purpose is checked up to where a reader stops; messages on channels
without a JSON Schema are not ours to check.
"""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
from mcap.reader import make_reader

from analyzer.formats import mcap_schemas as S

OUR_SCHEMAS = {schema["title"] for schema in S.ALL_SCHEMAS.values()}


class SchemaMismatch(AssertionError):
    pass


def _messages(path: Path):
    """(schema, channel, message) as the mcap library reads them, up to where it stops."""
    with open(path, "rb") as f:
        try:
            reader = make_reader(f)
            yield from reader.iter_messages(log_time_order=False)
        except Exception:  # noqa: BLE001 - a file damaged on purpose: checked as far as it reads
            return


def check_recording(path: Path) -> int:
    """Validate every message of ``path``; the number checked. Raises
    ``SchemaMismatch`` naming the first message that does not match."""
    validators: dict[int, jsonschema.Draft202012Validator | None] = {}
    checked = 0
    for schema, channel, message in _messages(path):
        if schema is None or schema.encoding != "jsonschema" or schema.name not in OUR_SCHEMAS:
            continue
        validator = validators.get(schema.id, False)
        if validator is False:
            definition = json.loads(schema.data)
            jsonschema.Draft202012Validator.check_schema(definition)
            validator = validators[schema.id] = jsonschema.Draft202012Validator(definition)
        try:
            obj = json.loads(message.data)
        except ValueError:
            raise SchemaMismatch(f"{path.name}: {channel.topic} message at {message.log_time} is not JSON") from None
        error = jsonschema.exceptions.best_match(validator.iter_errors(obj))
        if error is not None:
            raise SchemaMismatch(f"{path.name}: {channel.topic} message {obj!r:.300} does not match "
                                 f"{schema.name}: {error.message} (at {list(error.absolute_path)})")
        checked += 1
    return checked
