"""How the Foxglove app reads a JSON Schema: a Python port of ``parseJsonSchema``.

Foxglove (and Lichtblick, its open fork) turns the JSON Schema of a ``json``
channel into message definitions ("datatypes") with ``parseJsonSchema`` in the
``mcap-support`` package. A schema it cannot read makes the channel unreadable
in the app; this port lets the tests check a schema the same way.

Source read: github.com/Lichtblick-Suite/lichtblick, commit
9554e1e429c2c6409d4ea44d2f0e3082049f82ab (2025-03-21),
``packages/mcap-support/src/parseJsonSchema.ts``. Its logic last changed in
foxglove/studio #7100 (eaed976, 2023-11-15, "Tolerate missing properties key in
JSON schema"), inherited by the fork; later commits only touch imports and
headers. Line numbers below are of that file. The caller,
``parseChannel.ts`` (same commit, lines 102-127), passes the MCAP Schema
record's *name* as the root type name and the parsed schema data as the schema;
empty schema data means no datatypes at all.

Rules (each holds for the root schema and, recursively, for nested objects):

1. The schema must have ``"type": "object"`` (exactly that string, not a list
   containing it), else ``Expected "type": "object" for schema {typeName}, got
   {JSON.stringify(type)}`` (a missing type prints ``undefined``). [38-42]
2. ``properties`` may be missing or null: it counts as ``{}`` and the type has
   no fields. Fields are read in the order of ``properties``. [43-44]
3. A property with a ``oneOf`` list is an enum, whatever its ``type``: when
   every alternative's ``const`` is a number, each alternative becomes a
   constant ``{name: title, type: "uint32", isConstant: true, value: const}``,
   followed by the field itself as ``uint32``; otherwise ``Unsupported type for
   {keyPath}: oneOf alternatives must have number values``. [45-64]
4. ``"type": "boolean"`` is ``bool``. [66-68]
5. ``"type": "string"`` without ``contentEncoding`` is ``string``; with
   ``"contentEncoding": "base64"`` it is a ``uint8`` array (the value is
   base64-decoded after parsing); any other ``contentEncoding`` (null included)
   throws ``Unsupported contentEncoding {JSON} in {keyPath}``. [69-99]
6. ``"type": "number"`` is ``float64``. [100-102]
7. ``"type": "integer"`` is ``uint32`` when ``minimum`` or ``exclusiveMinimum``
   is a number >= 0, else ``int32``. [103-113]
8. ``"type": "object"`` recurses (rules 1-11) into a nested datatype named
   ``{typeName}.{fieldName}``; the field is ``{type: that name, isComplex:
   true}``. The nested datatype is stored before its parent. [114-131]
9. ``"type": "array"`` looks only at ``items.type``: ``boolean`` / ``number``
   / ``string`` / ``integer`` give arrays of ``bool`` / ``float64`` /
   ``string`` / ``uint32`` or ``int32`` (rule 7 on ``items``); a string item
   with a non-null ``contentEncoding`` throws ``Unsupported contentEncoding
   {JSON} for array item {keyPath}``; ``object`` items recurse as in rule 8,
   with ``isComplex`` and ``isArray``; any other item type (a list, ``array``,
   ``null``, none) throws ``Unsupported type {JSON} for array item
   {keyPath}``. ``items`` missing or null is a JavaScript TypeError. [132-194]
10. Any other ``type`` -- ``"null"``, a list such as ``["number", "null"]``,
    none at all (e.g. a bare ``$ref``, ``anyOf`` or ``enum``) -- throws
    ``Unsupported type {JSON.stringify(type)} for {keyPath}``. [195-201]
11. Nothing else is read: ``required``, ``enum``, ``$ref``/``definitions``/
    ``$defs``, ``anyOf``, ``title``, ``description``, ``maximum``,
    ``minItems``/``maxItems`` are ignored (rule 10 applies when they stand in
    place of ``type``). The root ``title`` does not name the type. [whole file]

``keyPath`` is the field's path from the root joined with ``.`` (just the field
name at the root); ``{JSON}`` is ``JSON.stringify`` of the value, compact.
Where the TypeScript fails on a JavaScript TypeError instead of its own throw
(reading a property of null or undefined), ``UnsupportedSchema`` carries V8's
message. Not ported: ``postprocessValue`` (base64 decoding of values).
"""

from __future__ import annotations

import json

__all__ = ["UnsupportedSchema", "parse_json_schema"]


class UnsupportedSchema(Exception):
    """The app would throw this message and not read the channel."""


class _Undefined:
    def __repr__(self) -> str:
        return "undefined"


_UNDEFINED = _Undefined()


def _get(obj, key: str):
    """``obj[key]`` as JavaScript reads a property: undefined if absent."""
    if obj is None or obj is _UNDEFINED:
        which = "null" if obj is None else "undefined"
        raise UnsupportedSchema(f"Cannot read properties of {which} (reading '{key}')")
    if isinstance(obj, dict):
        return obj.get(key, _UNDEFINED)
    return _UNDEFINED


def _js_number(value) -> bool:
    """``typeof value === "number"``."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _stringify(value) -> str:
    """``${JSON.stringify(value)}`` for JSON-decoded values."""
    if value is _UNDEFINED:
        return "undefined"

    def norm(v):
        if isinstance(v, float) and v.is_integer():
            return int(v)
        if isinstance(v, list):
            return [norm(x) for x in v]
        if isinstance(v, dict):
            return {k: norm(x) for k, x in v.items()}
        return v

    return json.dumps(norm(value), separators=(",", ":"), ensure_ascii=False)


def _entries(value) -> list:
    """``Object.entries(value)``."""
    if isinstance(value, dict):
        return list(value.items())
    if isinstance(value, (list, str)):
        return [(str(i), item) for i, item in enumerate(value)]
    return []


def _integer_type(schema) -> str:
    minimum = _get(schema, "minimum")
    exclusive = _get(schema, "exclusiveMinimum")
    if (_js_number(minimum) and minimum >= 0) or (_js_number(exclusive) and exclusive >= 0):
        return "uint32"
    return "int32"


def parse_json_schema(schema: dict, type_name: str) -> dict[str, list[dict]]:
    """The datatypes the app derives from ``schema``: type name -> field definitions.

    Field definitions carry the keys the TypeScript sets (``name``, ``type`` and,
    when set, ``isArray``, ``isComplex``, ``isConstant``, ``value``). Raises
    ``UnsupportedSchema`` with the app's message where the app throws.
    """
    datatypes: dict[str, list[dict]] = {}

    def add_fields(schema, type_name: str, key_path: list[str]) -> None:
        fields: list[dict] = []
        schema_type = _get(schema, "type")
        if not (isinstance(schema_type, str) and schema_type == "object"):
            raise UnsupportedSchema(
                f'Expected "type": "object" for schema {type_name}, got {_stringify(schema_type)}')
        properties = _get(schema, "properties")
        if properties is None or properties is _UNDEFINED:
            properties = {}
        for field_name, field_schema in _entries(properties):
            path = ".".join([*key_path, field_name])
            one_of = _get(field_schema, "oneOf")
            if isinstance(one_of, list):
                if all(_js_number(_get(alt, "const")) for alt in one_of):
                    for alt in one_of:
                        title = _get(alt, "title")
                        fields.append({"name": None if title is _UNDEFINED else title,
                                       "type": "uint32", "isConstant": True,
                                       "value": _get(alt, "const")})
                    fields.append({"name": field_name, "type": "uint32"})
                    continue
                raise UnsupportedSchema(
                    f"Unsupported type for {path}: oneOf alternatives must have number values")
            field_type = _get(field_schema, "type")
            if field_type == "boolean" and isinstance(field_type, str):
                fields.append({"name": field_name, "type": "bool"})
            elif field_type == "string" and isinstance(field_type, str):
                encoding = _get(field_schema, "contentEncoding")
                if encoding is _UNDEFINED:
                    fields.append({"name": field_name, "type": "string"})
                elif encoding == "base64" and isinstance(encoding, str):
                    fields.append({"name": field_name, "type": "uint8", "isArray": True})
                else:
                    raise UnsupportedSchema(
                        f"Unsupported contentEncoding {_stringify(encoding)} in {path}")
            elif field_type == "number" and isinstance(field_type, str):
                fields.append({"name": field_name, "type": "float64"})
            elif field_type == "integer" and isinstance(field_type, str):
                fields.append({"name": field_name, "type": _integer_type(field_schema)})
            elif field_type == "object" and isinstance(field_type, str):
                nested = f"{type_name}.{field_name}"
                add_fields(field_schema, nested, [*key_path, field_name])
                fields.append({"name": field_name, "type": nested, "isComplex": True})
            elif field_type == "array" and isinstance(field_type, str):
                item_schema = _get(field_schema, "items")
                item_type = _get(item_schema, "type")
                if item_type == "boolean" and isinstance(item_type, str):
                    fields.append({"name": field_name, "type": "bool", "isArray": True})
                elif item_type == "string" and isinstance(item_type, str):
                    encoding = _get(item_schema, "contentEncoding")
                    if encoding is not _UNDEFINED and encoding is not None:  # `!= undefined`
                        raise UnsupportedSchema(
                            f"Unsupported contentEncoding {_stringify(encoding)} for array item {path}")
                    fields.append({"name": field_name, "type": "string", "isArray": True})
                elif item_type == "number" and isinstance(item_type, str):
                    fields.append({"name": field_name, "type": "float64", "isArray": True})
                elif item_type == "integer" and isinstance(item_type, str):
                    fields.append({"name": field_name, "type": _integer_type(item_schema),
                                   "isArray": True})
                elif item_type == "object" and isinstance(item_type, str):
                    nested = f"{type_name}.{field_name}"
                    add_fields(item_schema, nested, [*key_path, field_name])
                    fields.append({"name": field_name, "type": nested, "isComplex": True,
                                   "isArray": True})
                else:
                    raise UnsupportedSchema(
                        f"Unsupported type {_stringify(item_type)} for array item {path}")
            else:
                raise UnsupportedSchema(f"Unsupported type {_stringify(field_type)} for {path}")
        datatypes[type_name] = fields

    add_fields(schema, type_name, [])
    return datatypes
