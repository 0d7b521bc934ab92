"""Every command and result decoder against values worked out by hand from the
spec's tables (Tables 4-18) and docs/decoding.md. Numbers in comments show the
arithmetic; none of the expectations come from running the code."""

import pytest

from dissectors import BY_ID, dissect_command, dissect_result
from dissectors.commands import COMMANDS


def cmd(payload: str):
    d = dissect_command(payload.encode("latin-1"))
    return d.command, d.fields, list(d.problems)


def res(command_id: str, payload: str):
    fields, problems = dissect_result(BY_ID[command_id], payload.encode("latin-1"))
    return fields, list(problems)


def categories(problems):
    return [p.split(":")[0] for p in problems]


# ------------------------------------------------------------- Table 15 positions
def test_go_to_position_worked_example():
    # 0x0FA0 = 4000 -> +40.00 deg; 0xFC18 = 64536 - 65536 = -1000 -> -10.00 deg
    assert cmd("P0FA0FC18") == ("P", {"azimuth_deg": 40.0, "elevation_deg": -10.0}, [])


def test_position_extremes_are_signed_16_bit():
    # 0x7FFF = 32767 -> 327.67; 0x8000 = -32768 -> -327.68
    assert cmd("P7FFF8000")[1] == {"azimuth_deg": 327.67, "elevation_deg": -327.68}


@pytest.mark.parametrize("payload", ["0FA0FC18", "P0FA0FC18"])
def test_position_query_result_with_or_without_leading_p(payload):
    assert res("P?", payload) == ({"azimuth_deg": 40.0, "elevation_deg": -10.0}, [])


def test_preset_commands():
    assert cmd("P0A") == ("Pnn", {"preset": 10}, [])
    assert cmd("P?0A") == ("P?nn", {"preset": 10}, [])
    assert cmd("S0A") == ("Snn", {"preset": 10}, [])
    assert cmd("S?FF") == ("S?nn", {"preset": 255}, [])
    # 0xFF9C = -100 -> -1.00 deg; 0x0064 = 100 -> 1.00 deg
    assert res("S?nn", "FF9C0064")[0] == {"azimuth_deg": -1.0, "elevation_deg": 1.0}
    assert res("P?nn", "00000000")[0] == {"azimuth_deg": 0.0, "elevation_deg": 0.0}


# ------------------------------------------------------------- Tables 12, 13 rates
def test_rate_and_acceleration_worked_example():
    # Table 12: 10.25 is sent as 1025 = 0x0401
    assert cmd("RP0401") == ("RP", {"rate_deg_s": 10.25}, [])
    assert cmd("RT0401") == ("RT", {"rate_deg_s": 10.25}, [])
    assert cmd("AP0401") == ("AP", {"accel_deg_s2": 10.25}, [])
    assert cmd("AT2710") == ("AT", {"accel_deg_s2": 100.0}, [])  # 0x2710 = 10000


def test_rate_queries_and_results():
    for q in ("RP?", "RT?"):
        assert cmd(q) == (q, {}, [])
        assert res(q, "0401") == ({"rate_deg_s": 10.25}, [])
    for q in ("AP?", "AT?"):
        assert res(q, "0064") == ({"accel_deg_s2": 1.0}, [])
    # R? and A?: one value, or pan then tilt (docs/decoding.md, "Results whose layout the tables leave open")
    assert res("R?", "0401")[0] == {"rate_deg_s": 10.25}
    assert res("R?", "04010064")[0] == {"pan_rate_deg_s": 10.25, "tilt_rate_deg_s": 1.0}
    assert res("A?", "00C8")[0] == {"accel_deg_s2": 2.0}
    assert res("A?", "00C80190")[0] == {"pan_accel_deg_s2": 2.0, "tilt_accel_deg_s2": 4.0}


# ------------------------------------------------------------- Tables 7, 8 gains
def test_rate_gain_in_tenths():
    # 1.5 is 15 = 0x0F (Table 7's "0E" is a typo, docs/decoding.md "Numbers")
    assert cmd("GRP0F") == ("GRP", {"gain": 1.5}, [])
    assert cmd("GRT0E") == ("GRT", {"gain": 1.4}, [])
    assert cmd("GRP03")[2] == [] and cmd("GRP1E")[2] == []   # 0.3 and 3.0 are the bounds


@pytest.mark.parametrize("payload,value", [("GRP02", 0.2), ("GRT1F", 3.1)])
def test_rate_gain_outside_range_warns(payload, value):
    _, fields, problems = cmd(payload)
    assert fields["gain"] == value
    assert categories(problems) == ["value out of range"]


def test_gain_query_result():
    # Table 8: 13 hex -> 19 / 10 = 1.9
    fields, problems = res("G?", "G?13130000")
    assert (fields["pan_gain"], fields["tilt_gain"], problems) == (1.9, 1.9, [])
    assert res("G?", "G?0F0A0000")[0]["tilt_gain"] == 1.0


# ------------------------------------------------------------- Table 4
def test_set_address():
    assert cmd("#0A") == ("#NN", {"new_address": 10}, [])
    assert cmd("#FE")[2] == []
    assert categories(cmd("#00")[2]) == ["value out of range"]
    assert categories(cmd("#FF")[2]) == ["value out of range"]


@pytest.mark.parametrize("code,baud", [(0, 1200), (1, 2400), (2, 4800), (3, 9600), (4, 19200),
                                       (5, 38400), (6, 57600), (7, 115200)])
def test_set_data_rate(code, baud):
    assert cmd(f"C{code}") == ("C", {"rate_code": code, "baud": baud}, [])


@pytest.mark.parametrize("code", "89ABCDEF")
def test_data_rates_c8_to_cf_are_reserved(code):
    command, fields, problems = cmd(f"C{code}")
    assert command == "C" and fields["baud"] is None
    assert categories(problems) == ["reserved code"]


def test_max_data_rate_result():
    assert res("B?", "C7")[0]["max_baud"] == 115200
    assert res("B?", "C3")[0]["max_baud"] == 9600
    assert categories(res("B?", "CA")[1]) == ["reserved code"]


def test_awake_status_table5():
    # 5 = bits 0 and 2: azimuth not initialised, motors off
    fields, problems = res("AW", "5")
    assert fields["status"] == 5 and problems == []
    assert fields["azimuth_not_initialized"] and fields["motors_off"]
    assert not fields["elevation_not_initialized"] and not fields["error"]
    assert res("AW", "8")[0]["error"] is True
    assert res("AW", "0")[0]["status"] == 0


def test_identification_table6():
    payload = "01" + " 9" + "PTG-200".ljust(20) + "SN000123".ljust(20)
    fields, problems = res("D?", payload)
    assert problems == []
    assert (fields["device_id"], fields["revision"], fields["name"], fields["serial"]) == \
        ("01", "9", "PTG-200", "SN000123")
    assert categories(res("D?", "01 9short")[1]) == ["malformed payload"]


def test_error_codes_table6a():
    # 0x11 = bits 0 and 4; 0x60 = bits 5 and 6
    fields, _ = res("E?", "1160")
    assert fields["azimuth_error_bits"] == 0x11 and fields["elevation_error_bits"] == 0x60
    assert fields["azimuth_errors"] == ["center reference", "initialization"]
    assert fields["elevation_errors"] == ["motor time-out", "temperature"]


@pytest.mark.parametrize("payload", ["0302", "00030002"])
def test_status_bits_table6b_two_or_four_hex(payload):
    fields, problems = res("I?", payload)
    assert problems == []
    assert fields["azimuth_status_bits"] == 3 and fields["elevation_status_bits"] == 2
    assert fields["azimuth_status"] == ["not initialized", "positive limit found"]
    assert fields["elevation_status"] == ["positive limit found"]


def test_initialization_result_table9():
    # 0x09 = center detected (bit 0) + limit switch hit (bit 3): good; 0x0D adds a hard limit (bit 2)
    fields, problems = res("IX", "0909090D")
    assert problems == []
    assert fields["azimuth_ccw_result"] == 9 and fields["elevation_cw_result"] == 0x0D
    assert fields["azimuth_ccw_ok"] and fields["azimuth_cw_ok"] and fields["elevation_ccw_ok"]
    assert fields["elevation_cw_ok"] is False
    assert res("IX", "0009000900090009")[0]["azimuth_ccw_result"] == 9


@pytest.mark.parametrize("code,relay,action", [("L2", 2, "open"), ("L3", 3, "open"),
                                               ("LA", 2, "close"), ("LB", 3, "close")])
def test_relays(code, relay, action):
    command, _, problems = cmd(code)
    assert command == code and problems == []
    assert BY_ID[code].summary == f"{action} relay {relay}"


@pytest.mark.parametrize("code", ["L0", "L1", "L8", "L9"])
def test_reserved_relays(code):
    assert categories(cmd(code)[2]) == ["reserved code"]


def test_relay_status_table4a():
    # 5 = relays 0 and 2 on
    assert res("LR", "L5")[0] == {"relays": 5, "relays_on": [0, 2]}
    assert res("LR", "LF")[0]["relays_on"] == [0, 1, 2, 3]


def test_software_limits_table10():
    # 0x7FF = 2047, 0x800 = 2048, 0x3E8 = 1000, 0x0FA = 250
    expected = {"pan_ccw": 2047, "pan_cw": 2048, "tilt_ccw": 1000, "tilt_cw": 250}
    assert cmd("LS7FF8003E80FA") == ("LS", expected, [])
    assert res("L?", "7FF8003E80FA") == (expected, [])
    assert cmd("LC") == ("LC", {}, [])


def test_verify_home_table14():
    fields, _ = res("HV", "313")
    assert (fields["limit_switch_bits"], fields["center_switch_bits"], fields["count_correct_bits"]) == (3, 1, 3)
    assert fields["azimuth_initialized"] and fields["elevation_initialized"]


# ------------------------------------------------------------- Table 11 motion
@pytest.mark.parametrize("code", ["HA", "HO", "HS", "PL", "PR", "PS", "PT", "TD", "TS", "TU",
                                  "CN", "CX", "FA", "FF", "FN", "FS", "FX", "ZI", "ZO", "ZS", "IX",
                                  "AW", "B?", "D?", "E?", "I?", "G?", "LR", "L?", "P?", "V?", "A?", "R?"])
def test_fixed_codes(code):
    assert cmd(code) == (code, {}, [])


def test_proportional_speed():
    assert cmd("SPF") == ("SP", {"speed": 15}, [])
    assert cmd("ST0") == ("ST", {"speed": 0}, [])


def test_vector_motion():
    assert cmd("VM1") == ("VM", {"vector": True}, [])
    assert cmd("VM0") == ("VM", {"vector": False}, [])
    assert categories(cmd("VM2")[2]) == ["value out of range"]


# ------------------------------------------------------------- Tables 16, 17 lens
def test_lens_go_to_and_position():
    # 0x4BF = 1215, 0x123 = 291 (nibbles A-F are 'A'-'F', docs/decoding.md "Numbers")
    assert cmd("V4BF123") == ("V", {"zoom": 1215, "focus": 291}, [])
    assert res("V?", "4BF123")[0] == {"zoom": 1215, "focus": 291}
    assert res("V?", "VFFF000")[0] == {"zoom": 4095, "focus": 0}


def test_focus_and_zoom_speeds():
    assert cmd("F5") == ("F", {"focus_speed": 5}, [])
    assert cmd("Z9") == ("Z", {"zoom_speed": 9}, [])
    assert cmd("ZC") == ("ZA-ZF", {"digital_zoom": 12}, [])


# ------------------------------------------------------------- Table 18 aux ports
def test_aux_port_config_example():
    # Table 18's example: *x0c,9600,8,1,0 = port 0, 9600 baud, 8 data, 1 stop, no parity
    assert cmd("*x0c,9600,8,1,0") == ("*x0c", {"aux_port": 0, "baud": 9600, "data_bits": 8,
                                                "stop_bits": 1, "parity": "none"}, [])
    assert cmd("*x1c,19200,7,2,2")[1]["parity"] == "even"
    assert cmd("*x1c,19200,7,2,1")[1]["parity"] == "odd"


@pytest.mark.parametrize("payload", ["*x0c,9600,9,1,0", "*x0c,9600,8,3,0", "*x0c,9600,8,1,3",
                                     "*x2c,9600,8,1,0"])
def test_aux_port_config_out_of_range(payload):
    assert "value out of range" in categories(cmd(payload)[2])


def test_aux_port_transmit_receive_count_flush():
    assert cmd("*x1tHELLO") == ("*x1t", {"aux_port": 1, "data": "HELLO", "data_length": 5}, [])
    assert categories(cmd("*x0t" + "A" * 201)[2]) == ["value out of range"]
    assert cmd("*x0r010") == ("*x0r", {"aux_port": 0, "max_bytes": 10}, [])
    assert res("*x{aux_port}r", "ABC")[0] == {"data": "ABC"}
    assert cmd("*x1n") == ("*x1n", {"aux_port": 1}, [])
    assert res("*x{aux_port}n", "12")[0] == {"count": 12}
    assert cmd("*x0f") == ("*x0f", {"aux_port": 0}, [])


# ------------------------------------------------------------- rev 1.9 additions
@pytest.mark.parametrize("code", ["VS", "F?", "Z?", "C?", "*dA", "*di", "*do", "*dl", "*dm", "*mr", "*me",
                                  "*mp", "*mu", "*sa", "*sgr", "*sgp", "*sl", "HP", "VP"])
def test_rev19_commands_are_known(code):
    command, fields, problems = cmd(code + "12,3.5")
    assert command == code and problems == []
    assert fields == {"arguments": "12,3.5"}


# ------------------------------------------------------------- problems
def test_lower_case_hex_decodes_with_a_warning():
    command, fields, problems = cmd("P0fa0fc18")
    assert command == "P" and fields == {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    assert categories(problems) == ["lower-case hex"]


def test_unknown_command_keeps_its_code():
    assert cmd("QX") == ("QX", {}, ["unknown command: 'QX' is not in protocol rev 1.9"])
    assert cmd("*zz9")[0] == "*zz"


@pytest.mark.parametrize("payload,command", [("GRP1", "GRP"), ("P0FA", "Pnn"), ("AWX", "AW"),
                                             ("LS123", "LS"), ("V4BF12", "V")])
def test_known_code_with_bad_parameters_is_malformed(payload, command):
    got, fields, problems = cmd(payload)
    assert (got, fields) == (command, {})
    assert categories(problems) == ["malformed payload"]


def test_result_layout_mismatch_is_malformed():
    assert categories(res("P?", "0FA0")[1]) == ["malformed payload"]


def test_every_table_entry_has_reference_and_name():
    assert len({c.id for c in COMMANDS}) == len(COMMANDS)
    for c in COMMANDS:
        assert c.ref and c.name, c.id
