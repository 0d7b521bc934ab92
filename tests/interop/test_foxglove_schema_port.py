"""Tests of the port of Foxglove's parseJsonSchema (tests/interop/foxglove_schema.py).

Cases marked "TS:" mirror ``packages/mcap-support/src/parseJsonSchema.test.ts``
of Lichtblick-Suite/lichtblick at 9554e1e (the test names are quoted). The
others pin down behaviour the TS source shows but its tests do not exercise.
"""

from __future__ import annotations

import pytest

from tests.interop.foxglove_schema import UnsupportedSchema, parse_json_schema


def obj(**properties) -> dict:
    return {"type": "object", "properties": properties}


def error(schema: dict, name: str = "X") -> str:
    with pytest.raises(UnsupportedSchema) as info:
        parse_json_schema(schema, name)
    return str(info.value)


# TS: "rejects invalid schema" (toThrow matches a substring; here the whole message)
@pytest.mark.parametrize(("schema", "message"), [
    ({}, 'Expected "type": "object" for schema X, got undefined'),
    ({"type": 3}, 'Expected "type": "object" for schema X, got 3'),
    ({"type": "string"}, 'Expected "type": "object" for schema X, got "string"'),
    (obj(x={"type": "null"}), 'Unsupported type "null" for x'),
    (obj(x={"type": "string", "contentEncoding": "X"}), 'Unsupported contentEncoding "X" in x'),
    (obj(x={"type": "array", "items": {"type": "string", "contentEncoding": "base64"}}),
     'Unsupported contentEncoding "base64" for array item x'),
])
def test_rejects_invalid_schema(schema, message):
    assert error(schema) == message


# TS: "converts schema to datatypes and decodes base64", case 1
def test_empty_properties():
    assert parse_json_schema({"type": "object", "properties": {}}, "Foo") == {"Foo": []}


# TS: "converts schema to datatypes and decodes base64", case 2
def test_scalar_fields():
    schema = obj(str={"type": "string"}, bin={"type": "string", "contentEncoding": "base64"},
                 num={"type": "number"}, int={"type": "integer"},
                 uint={"type": "integer", "minimum": 0},
                 uint2={"type": "integer", "exclusiveMinimum": 0}, bool={"type": "boolean"})
    assert parse_json_schema(schema, "Foo") == {"Foo": [
        {"name": "str", "type": "string"},
        {"name": "bin", "type": "uint8", "isArray": True},
        {"name": "num", "type": "float64"},
        {"name": "int", "type": "int32"},
        {"name": "uint", "type": "uint32"},
        {"name": "uint2", "type": "uint32"},
        {"name": "bool", "type": "bool"},
    ]}


# TS: "converts schema to datatypes and decodes base64", case 3
def test_array_fields():
    schema = obj(str={"type": "array", "items": {"type": "string"}},
                 num={"type": "array", "items": {"type": "number"}},
                 int={"type": "array", "items": {"type": "integer"}},
                 uint={"type": "array", "items": {"type": "integer", "minimum": 0}},
                 uint2={"type": "array", "items": {"type": "integer", "exclusiveMinimum": 0}},
                 bool={"type": "array", "items": {"type": "boolean"}})
    assert parse_json_schema(schema, "Foo") == {"Foo": [
        {"name": "str", "type": "string", "isArray": True},
        {"name": "num", "type": "float64", "isArray": True},
        {"name": "int", "type": "int32", "isArray": True},
        {"name": "uint", "type": "uint32", "isArray": True},
        {"name": "uint2", "type": "uint32", "isArray": True},
        {"name": "bool", "type": "bool", "isArray": True},
    ]}


# TS: "converts schema to datatypes and decodes base64", case 4
def test_nested_object():
    schema = obj(bar={"type": "object", "properties": {"str": {"type": "string"}}})
    assert parse_json_schema(schema, "Foo") == {
        "Foo": [{"name": "bar", "type": "Foo.bar", "isComplex": True}],
        "Foo.bar": [{"name": "str", "type": "string"}],
    }


# TS: "converts schema to datatypes and decodes base64", case 5
def test_nested_objects_and_arrays_of_objects():
    b64 = {"type": "string", "contentEncoding": "base64"}
    schema = obj(bin=b64, nested={"type": "object", "properties": {
        "bin2": b64,
        "bar": {"type": "array", "items": {"type": "object", "properties": {"bin3": b64}}},
    }})
    datatypes = parse_json_schema(schema, "Foo")
    assert datatypes == {
        "Foo": [{"name": "bin", "type": "uint8", "isArray": True},
                {"name": "nested", "type": "Foo.nested", "isComplex": True}],
        "Foo.nested": [{"name": "bin2", "type": "uint8", "isArray": True},
                       {"name": "bar", "type": "Foo.nested.bar", "isComplex": True, "isArray": True}],
        "Foo.nested.bar": [{"name": "bin3", "type": "uint8", "isArray": True}],
    }
    # datatypes.set runs after the recursion: nested types come before their parent
    assert list(datatypes) == ["Foo.nested.bar", "Foo.nested", "Foo"]


# TS: "converts oneOf to enum"
def test_one_of_is_an_enum():
    schema = obj(level={"oneOf": [{"title": "X", "const": 1}, {"title": "Y", "const": 2}]})
    assert parse_json_schema(schema, "Log") == {"Log": [
        {"name": "X", "type": "uint32", "isConstant": True, "value": 1},
        {"name": "Y", "type": "uint32", "isConstant": True, "value": 2},
        {"name": "level", "type": "uint32"},
    ]}


# TS: "tolerates an 'any object' schema" -- since foxglove/studio #7100 (2023-11)
def test_object_without_properties_is_tolerated():
    assert parse_json_schema({"type": "object"}, "Any object") == {"Any object": []}
    schema = obj(fields={"type": "object", "description": "free-form"})
    assert parse_json_schema(schema, "E") == {
        "E.fields": [], "E": [{"name": "fields", "type": "E.fields", "isComplex": True}]}


def test_type_union_throws():
    assert error(obj(t={"type": ["number", "null"]})) == 'Unsupported type ["number","null"] for t'
    assert error({"type": ["object", "null"], "properties": {}}, "R") == \
        'Expected "type": "object" for schema R, got ["object","null"]'
    assert error(obj(a={"type": "array", "items": {"type": ["integer", "null"]}})) == \
        'Unsupported type ["integer","null"] for array item a'


def test_base64_string_is_a_uint8_array():
    schema = obj(data={"type": "string", "contentEncoding": "base64"})
    assert parse_json_schema(schema, "Raw") == {"Raw": [{"name": "data", "type": "uint8", "isArray": True}]}


def test_key_path_names_nested_fields():
    schema = obj(a={"type": "array", "items": {"type": "object", "properties": {
        "b": {"type": "object", "properties": {"c": {"type": "null"}}}}}})
    assert error(schema) == 'Unsupported type "null" for a.b.c'
    assert error(obj(a={"type": "object", "properties": {"b": {"oneOf": [{"const": "x"}]}}})) == \
        "Unsupported type for a.b: oneOf alternatives must have number values"


@pytest.mark.parametrize(("field", "message"), [
    ({"$ref": "#/definitions/T"}, "Unsupported type undefined for f"),
    ({"anyOf": [{"type": "number"}, {"type": "null"}]}, "Unsupported type undefined for f"),
    ({"enum": ["A", "B"]}, "Unsupported type undefined for f"),
    ({"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
     'Unsupported type "array" for array item f'),
    ({"type": "array", "items": [{"type": "number"}]}, "Unsupported type undefined for array item f"),
    ({"type": "array"}, "Cannot read properties of undefined (reading 'type')"),
    ({"type": "string", "contentEncoding": None}, "Unsupported contentEncoding null in f"),
    ({"oneOf": [{"title": "T", "const": True}]},
     "Unsupported type for f: oneOf alternatives must have number values"),
])
def test_what_is_not_read_throws(field, message):
    assert error(obj(f=field)) == message


def test_ignored_keywords():
    schema = {"type": "object", "title": "Other", "required": ["s", "n"], "properties": {
        "s": {"type": "string", "enum": ["A", "B"], "description": "d"},
        "n": {"type": "integer", "maximum": 5, "minimum": -1},
        "l": {"type": "array", "items": {"type": "string", "contentEncoding": None}, "minItems": 3},
        "k": {"type": "integer", "oneOf": [{"title": "K", "const": 7}]},
    }}
    assert parse_json_schema(schema, "Name") == {"Name": [
        {"name": "s", "type": "string"},
        {"name": "n", "type": "int32"},
        {"name": "l", "type": "string", "isArray": True},
        {"name": "K", "type": "uint32", "isConstant": True, "value": 7},
        {"name": "k", "type": "uint32"},
    ]}
