"""Every schema gimbalscope writes reads in the Foxglove app.

The app's reading logic is the port in ``foxglove_schema.py`` (its rules are
listed there, with the lines of ``parseJsonSchema.ts`` they come from). Each
schema is read the way the app reads a channel: the MCAP Schema record's name
as the root type name, its data as the schema. The expected message
definitions come from the protocol tables: angles and rates are hundredths
(Table 15, Tables 12-13), so decimal numbers; presets, limits and bit fields
are whole numbers; raw bytes are bytes.
"""

from __future__ import annotations

import json

import pytest
from mcap.reader import make_reader

from analyzer.formats import mcap_schemas as S
from tests.conftest import run_cli
from tests.interop.foxglove_schema import parse_json_schema


@pytest.mark.parametrize("key", sorted(S.SCHEMAS))
def test_the_app_reads_every_schema(key):
    schema = S.SCHEMAS[key]
    datatypes = parse_json_schema(json.loads(S.encoded(schema)), schema["title"])
    assert schema["title"] in datatypes


def definitions(key: str) -> dict[str, dict[str, dict]]:
    """type name -> field name -> definition, as the app derives them."""
    schema = S.SCHEMAS[key]
    return {name: {f["name"]: f for f in fields if not f.get("isConstant")}
            for name, fields in parse_json_schema(schema, schema["title"]).items()}


def test_event_fields_are_typed_as_the_tables_give_them():
    fields = definitions("event")["gimbalscope.Event.fields"]
    expected = {
        "azimuth_deg": "float64", "elevation_deg": "float64",      # Table 15: hundredths of a degree
        "rate_deg_s": "float64", "accel_deg_s2": "float64",        # Tables 12-13: hundredths
        "gain": "float64",                                          # Table 7: tenths
        "preset": "int32", "pan_ccw": "int32", "zoom": "int32",    # whole numbers (Tables 10, 11, 17)
        "baud": "int32", "previous_baud": "int32",                 # Table 4 rates
        "vector": "bool", "motors_off": "bool",                    # VM1/VM0; Table 5 bit 2
        "parity": "string", "name": "string",                      # Table 18 names; Table 6 text
    }
    assert {name: fields[name]["type"] for name in expected} == expected
    assert fields["azimuth_errors"] == {"name": "azimuth_errors", "type": "string", "isArray": True}
    assert fields["relays_on"]["type"] == "int32" and fields["relays_on"]["isArray"]


def test_bytes_are_byte_arrays_and_optional_values_have_one_type():
    event = definitions("event")["gimbalscope.Event"]
    assert event["t_end"]["type"] == "float64" and event["checksum_ok"]["type"] == "bool"
    assert event["dst"] == {"name": "dst", "type": "uint32", "isArray": True}
    raw = definitions("raw")["gimbalscope.RawChunk"]
    assert raw["data"] == {"name": "data", "type": "uint8", "isArray": True}
    assert definitions("txn")["gimbalscope.Transaction"]["result_latency"]["type"] == "float64"


def test_position_paths_of_the_plot_panel_exist():
    types = definitions("position")
    top = types["gimbalscope.Position"]
    for part in ("target", "reported"):
        assert top[part] == {"name": part, "type": f"gimbalscope.Position.{part}", "isComplex": True}
        assert {n: f["type"] for n, f in types[f"gimbalscope.Position.{part}"].items()} == \
            {"azimuth_deg": "float64", "elevation_deg": "float64"}


def test_the_schemas_in_a_recording_read_in_the_app(tmp_path):
    """The records a recording carries, not only the module's dicts."""
    out = tmp_path / "rec.mcap"
    r = run_cli("convert", "captures/demo-socat.log", "-o", out)
    assert r.returncode == 0, r.stderr
    with open(out, "rb") as f:
        summary = make_reader(f).get_summary()
    names = set()
    for schema in summary.schemas.values():
        assert schema.encoding == "jsonschema"
        assert schema.name in parse_json_schema(json.loads(schema.data), schema.name)
        names.add(schema.name)
    assert names == {s["title"] for s in S.SCHEMAS.values()}
