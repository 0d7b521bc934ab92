"""The command table: every command of protocol rev 1.9 (Tables 4, 11, 16 and the
list of §1.2), with its parameters, its result layouts and its spec reference.

This one table drives decoding (``dissectors.dissect``), pairing (which commands
are due a result, and which result layouts fit), the text summaries and the
generated field reference in docs/fields.md. Result layouts follow
docs/decoding.md where the tables leave them open.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from .fields import Derive, Field, Layout, choice, decimal, hexnum, text
from .problems import OUT_OF_RANGE, RESERVED, Problem

NONE = "none"          # ACK only
DUE = "due"            # ACK + result
OPTIONAL = "optional"  # a result may come (rev 1.9 commands whose format is not given)

# What sending a command does to a gimbal (docs/talk.md, "What may be sent"):
QUERY = "query"      # only asks: harmless, what `probe` sends
STOP = "stop"        # stops a motion: always allowed, as a controller's emergency key is
MOTION = "motion"    # moves the mount or the lens
CONFIG = "config"    # changes the address, the rate, a stored setting, a relay or an output
EFFECTS = (QUERY, STOP, MOTION, CONFIG)

# Table 4, C0…C7; C8…CF are reserved for future rates.
BAUD_CODES = {0: 1200, 1: 2400, 2: 4800, 3: 9600, 4: 19200, 5: 38400, 6: 57600, 7: 115200}


@dataclass(frozen=True)
class Command:
    id: str                      # the spec's code without parameters; may use {aux_port}
    name: str
    layout: Layout
    ref: str                     # spec table / section
    result: tuple[Layout, ...] = ()
    result_due: str = NONE
    summary: str = ""            # text summary of the command, str.format over its fields
    result_summary: str = ""     # text summary of its result
    result_timeout: float | None = None  # seconds; None = the pairing default
    reserved: bool = False       # the spec marks this code "Reserved"
    notes: str = ""
    effect: str = ""             # QUERY, STOP, MOTION or CONFIG: set from EFFECT_OF below

    def command_id(self, values: dict) -> str:
        return self.id.format(**values) if "{" in self.id else self.id


COMMANDS: list[Command] = []


def cmd(id: str, name: str, parts: Sequence[bytes | Field], ref: str, *,
        result: Sequence[Sequence[bytes | Field]] = (), due: str | None = None,
        derive: Derive | None = None, result_derive: Derive | None = None, **kw: Any) -> Command:
    layouts = tuple(Layout(tuple(r), result_derive) for r in result)
    c = Command(id, name, Layout(tuple(parts), derive), ref, layouts,
                due if due is not None else (DUE if layouts else NONE), **kw)
    COMMANDS.append(c)
    return c


# ---------------------------------------------------------------- fields
def az() -> Field:
    return hexnum("azimuth_deg", 4, scale=0.01, signed=True, unit="deg",
                  desc="azimuth (pan), hundredths of a degree, signed 16-bit; + is ccw (Table 15)")


def el() -> Field:
    return hexnum("elevation_deg", 4, scale=0.01, signed=True, unit="deg",
                  desc="elevation (tilt), hundredths of a degree, signed 16-bit; + is ccw (Table 15)")


def preset() -> Field:
    return hexnum("preset", 2, desc="preset number 00..FF (Table 11)")


def rate(name: str = "rate_deg_s") -> Field:
    return hexnum(name, 4, scale=0.01, unit="deg/s", desc="hundredths of deg/s (Tables 12, 13)")


def accel(name: str = "accel_deg_s2") -> Field:
    return hexnum(name, 4, scale=0.01, unit="deg/s^2", desc="hundredths of deg/s² (Tables 12, 13)")


def gain(name: str = "gain") -> Field:
    return hexnum(name, 2, scale=0.1, valid=(0.3, 3.0), desc="rate gain in tenths, 0.3..3.0 (Table 7)")


def limit(name: str) -> Field:
    return hexnum(name, 3, desc="12-bit software limit (Table 10)")


def aux_port() -> Field:
    return decimal("aux_port", 1, valid=(0, 1), desc="auxiliary serial port, 0 or 1 (Table 16)")


def free_text(name: str) -> Field:
    return text(name, desc="shown as text: the document gives no format")


# ---------------------------------------------------------------- derived values
def _baud(values: dict) -> list[Problem] | None:
    code = values["rate_code"]
    values["baud"] = BAUD_CODES.get(code)   # None: a reserved code names no rate
    if code not in BAUD_CODES:
        return [RESERVED.problem(f"rate code C{code:X} is reserved for future data rates (Table 4)")]
    return None


def _max_baud(values: dict) -> list[Problem] | None:
    code = values["max_rate_code"]
    values["max_baud"] = BAUD_CODES.get(code)
    if code not in BAUD_CODES:
        return [RESERVED.problem(f"rate code C{code:X} is reserved for future data rates (Table 4)")]
    return None


def _awake(values: dict) -> list[Problem] | None:
    s = values["status"]
    values["azimuth_not_initialized"] = bool(s & 1)
    values["elevation_not_initialized"] = bool(s & 2)
    values["motors_off"] = bool(s & 4)
    values["error"] = bool(s & 8)
    if s & ~0xF:
        return [RESERVED.problem("status bits 4..7 are reserved (Table 5)")]
    return None


ERROR_BITS = {0: "center reference", 4: "initialization", 5: "motor time-out", 6: "temperature"}
STATUS_BITS = {0: "not initialized", 1: "positive limit found", 2: "negative limit found",
               3: "positive center found", 4: "negative center found", 5: "positive hard stop",
               6: "negative hard stop", 7: "error code present"}


def bit_names(bits: int, table: dict[int, str]) -> list[str]:
    """The names of the bits set in ``bits``, in the table's order (``ERROR_BITS``,
    ``STATUS_BITS``)."""
    return [name for bit, name in table.items() if bits >> bit & 1]


def _errors(values: dict) -> None:
    values["azimuth_errors"] = bit_names(values["azimuth_error_bits"], ERROR_BITS)
    values["elevation_errors"] = bit_names(values["elevation_error_bits"], ERROR_BITS)


def _status(values: dict) -> None:
    values["azimuth_status"] = bit_names(values["azimuth_status_bits"], STATUS_BITS)
    values["elevation_status"] = bit_names(values["elevation_status_bits"], STATUS_BITS)


def _relays(values: dict) -> None:
    values["relays_on"] = [k for k in range(4) if values["relays"] >> k & 1]


def _init_results(values: dict) -> None:
    # Table 9, low byte: bit 0 center switch detected (good), bit 2 hard limit
    # (0 = good), bit 3 physical limit switch hit (good).
    for key in ("azimuth_ccw_result", "azimuth_cw_result", "elevation_ccw_result", "elevation_cw_result"):
        v = values[key]
        values[key.replace("_result", "_ok")] = bool(v & 0x1) and not v & 0x4 and bool(v & 0x8)


def _home(values: dict) -> None:
    values["azimuth_initialized"] = bool(values["count_correct_bits"] & 1)
    values["elevation_initialized"] = bool(values["count_correct_bits"] & 2)


def _aux_data(values: dict) -> list[Problem] | None:
    values["data_length"] = n = len(values["data"])
    if n > 200:
        return [OUT_OF_RANGE.problem(f"data_length {n} outside 0..200 (Table 16)")]
    return None


POSITION = [(az(), el()), (b"P", az(), el())]
_STATUS = "status bits (Table 6B)"
_INIT = "initialization result bits (Table 9)"

# ---------------------------------------------------------------- Table 4
cmd("#NN", "Set device address", (b"#", hexnum("new_address", 2, valid=(1, 254), desc="new device ID 01..FE")),
    "Table 4, §1.5.4", summary="set device address to {new_address}")
cmd("AW", "Request awake status", (b"AW",), "Table 4, Table 5",
    result=[(hexnum("status", (1, 2), desc="status bits (Table 5)"),)], result_derive=_awake,
    summary="awake status?", result_summary="status {status:X}")
cmd("B?", "Request maximum data rate", (b"B?",), "Table 4, §1.5.6",
    result=[(b"C", hexnum("max_rate_code", 1, desc="code of the fastest rate, C0..C7 (Table 4, §1.5.6)")),], result_derive=_max_baud,
    summary="max data rate?", result_summary="max {max_baud} bps")
cmd("C", "Set communication data rate", (b"C", hexnum("rate_code", 1, desc="C0..C7, Table 4")),
    "Table 4", derive=_baud, summary="set data rate {baud} bps")
cmd("D?", "Request ID information", (b"D?",), "Table 4, Table 6",
    result=[(text("device_id", 2, desc="device type (Table 6)"),
             text("revision", 2, strip=True, desc="firmware revision (Table 6)"),
             text("name", 20, strip=True, desc="device name (Table 6)"),
             text("serial", 20, strip=True, desc="serial number (Table 6)"))],
    summary="identify?", result_summary="{name} rev {revision} s/n {serial}")
cmd("E?", "Request error codes", (b"E?",), "Table 4, Table 6A",
    result=[(hexnum("azimuth_error_bits", 2, desc="error bits (Table 6A)"),
             hexnum("elevation_error_bits", 2, desc="error bits (Table 6A)"))], result_derive=_errors,
    summary="error codes?", result_summary="az errors: {azimuth_errors}; el errors: {elevation_errors}")
cmd("I?", "Request status bits", (b"I?",), "Table 4, Table 6B",
    result=[(hexnum("azimuth_status_bits", 2, desc=_STATUS), hexnum("elevation_status_bits", 2, desc=_STATUS)),
            (hexnum("azimuth_status_bits", 4, desc=_STATUS), hexnum("elevation_status_bits", 4, desc=_STATUS))], result_derive=_status,
    summary="status bits?", result_summary="az status: {azimuth_status}; el status: {elevation_status}")
cmd("GRP", "Set pan rate gain", (b"GRP", gain()), "Table 4, Table 7", summary="pan rate gain {gain}")
cmd("GRT", "Set tilt rate gain", (b"GRT", gain()), "Table 4, Table 7", summary="tilt rate gain {gain}")
cmd("G?", "Rate gains request", (b"G?",), "Table 4, Table 8",
    result=[(b"G?", gain("pan_gain"), gain("tilt_gain"), text("unused", 4, desc="characters the table leaves unused (Table 8)"))],
    summary="rate gains?", result_summary="pan gain {pan_gain} tilt gain {tilt_gain}")
cmd("IX", "Initialization", (b"IX",), "Table 4, Table 9",
    result=[tuple(hexnum(n, 2, desc=_INIT) for n in ("azimuth_ccw_result", "azimuth_cw_result",
                                         "elevation_ccw_result", "elevation_cw_result")),
            tuple(hexnum(n, 4, desc=_INIT) for n in ("azimuth_ccw_result", "azimuth_cw_result",
                                         "elevation_ccw_result", "elevation_cw_result"))],
    result_derive=_init_results, result_timeout=60.0,
    summary="initialize", result_summary="az ccw ok {azimuth_ccw_ok} cw ok {azimuth_cw_ok}, "
                                         "el ccw ok {elevation_ccw_ok} cw ok {elevation_cw_ok}")
for _code, _relay, _action in (("L0", 0, "open"), ("L1", 1, "open"), ("L2", 2, "open"), ("L3", 3, "open"),
                               ("L8", 0, "close"), ("L9", 1, "close"), ("LA", 2, "close"), ("LB", 3, "close")):
    cmd(_code, f"{_action.capitalize()} relay {_relay}", (_code.encode(),), "Table 4",
        reserved=_relay in (0, 1), summary=f"{_action} relay {_relay}")
cmd("LR", "Auxiliary relay status request", (b"LR",), "Table 4, Table 4A",
    result=[(b"L", hexnum("relays", 1, desc="relay bits, 1 = on (Table 4A)"))], result_derive=_relays,
    summary="relay status?", result_summary="relays on {relays_on}")
cmd("LC", "Clear software limits", (b"LC",), "Table 4", summary="clear software limits")
_LIMITS = (limit("pan_ccw"), limit("pan_cw"), limit("tilt_ccw"), limit("tilt_cw"))
cmd("LS", "Set software limits", (b"LS",) + _LIMITS, "Table 4, Table 10",
    summary="limits pan {pan_ccw}..{pan_cw} tilt {tilt_ccw}..{tilt_cw}")
cmd("L?", "Software limits request", (b"L?",), "Table 4, Table 10", result=[_LIMITS],
    summary="software limits?", result_summary="pan {pan_ccw}..{pan_cw} tilt {tilt_ccw}..{tilt_cw}")

# ---------------------------------------------------------------- Table 11 (and 12-15)
cmd("AP", "Set pan acceleration", (b"AP", accel()), "Table 11, Table 12", summary="pan accel {accel_deg_s2} deg/s²")
cmd("AT", "Set tilt acceleration", (b"AT", accel()), "Table 11, Table 12", summary="tilt accel {accel_deg_s2} deg/s²")
cmd("AP?", "Request pan acceleration", (b"AP?",), "Table 12, Table 13", result=[(accel(),)],
    summary="pan accel?", result_summary="{accel_deg_s2} deg/s²")
cmd("AT?", "Request tilt acceleration", (b"AT?",), "Table 12, Table 13", result=[(accel(),)],
    summary="tilt accel?", result_summary="{accel_deg_s2} deg/s²")
cmd("A?", "Request current acceleration settings", (b"A?",), "Table 11, Tables 12-13",
    result=[(accel(),), (accel("pan_accel_deg_s2"), accel("tilt_accel_deg_s2"))],
    summary="accelerations?", result_summary="{_values}")
cmd("HA", "Halt", (b"HA",), "Table 11", summary="halt (store position, motors off)")
cmd("HV", "Verify home", (b"HV",), "Table 11, Table 14",
    result=[(hexnum("limit_switch_bits", 1, desc="limit switch bits (Table 14)"),
             hexnum("center_switch_bits", 1, desc="center switch bits (Table 14)"),
             hexnum("count_correct_bits", 1, desc="count correct bits (Table 14)"))],
    result_derive=_home, summary="verify home?",
    result_summary="limit {limit_switch_bits} center {center_switch_bits} count {count_correct_bits}")
cmd("HO", "Go to home position", (b"HO",), "Table 11", summary="go home")
cmd("HS", "Stop", (b"HS",), "Table 11", summary="stop (motors off)")
cmd("P?", "Current position query", (b"P?",), "Table 11, Table 15", result=POSITION,
    summary="position?", result_summary="at az {azimuth_deg:+.2f}° el {elevation_deg:+.2f}°")
cmd("P", "Go to pan-tilt position", (b"P", az(), el()), "Table 11, Table 15",
    summary="go to az {azimuth_deg:+.2f}° el {elevation_deg:+.2f}°")
cmd("PL", "Pan left (cw)", (b"PL",), "Table 11", summary="pan left")
cmd("PR", "Pan right (ccw)", (b"PR",), "Table 11", summary="pan right")
cmd("PS", "Pan stop", (b"PS",), "Table 11", summary="pan stop")
cmd("PT", "Stop motion", (b"PT",), "Table 11", summary="stop motion")
cmd("Pnn", "Go to preset", (b"P", preset()), "Table 11", summary="go to preset {preset}")
cmd("P?nn", "Get preset", (b"P?", preset()), "Table 11, Table 15", result=POSITION,
    summary="preset {preset}?", result_summary="preset at az {azimuth_deg:+.2f}° el {elevation_deg:+.2f}°")
cmd("RP", "Set pan rate", (b"RP", rate()), "Table 11, Table 12", summary="pan rate {rate_deg_s} deg/s")
cmd("RT", "Set tilt rate", (b"RT", rate()), "Table 11, Table 12", summary="tilt rate {rate_deg_s} deg/s")
cmd("RP?", "Request pan rate", (b"RP?",), "Table 12, Table 13", result=[(rate(),)],
    summary="pan rate?", result_summary="{rate_deg_s} deg/s")
cmd("RT?", "Request tilt rate", (b"RT?",), "Table 12, Table 13", result=[(rate(),)],
    summary="tilt rate?", result_summary="{rate_deg_s} deg/s")
cmd("R?", "Request current rate settings", (b"R?",), "Table 11, Tables 12-13",
    result=[(rate(),), (rate("pan_rate_deg_s"), rate("tilt_rate_deg_s"))],
    summary="rates?", result_summary="{_values}")
cmd("Snn", "Store position as preset", (b"S", preset()), "Table 11", summary="store preset {preset}")
cmd("SP", "Set proportional pan speed", (b"SP", hexnum("speed", 1, desc="0 slow/proportional .. F max")),
    "Table 11", summary="pan speed {speed}")
cmd("ST", "Set proportional tilt speed", (b"ST", hexnum("speed", 1, desc="0 slow/proportional .. F max")),
    "Table 11", summary="tilt speed {speed}")
cmd("S?nn", "Request position stored at preset", (b"S?", preset()), "Table 11, Table 15", result=POSITION,
    summary="preset {preset} stored?", result_summary="stored az {azimuth_deg:+.2f}° el {elevation_deg:+.2f}°")
cmd("TD", "Tilt down (cw)", (b"TD",), "Table 11", summary="tilt down")
cmd("TS", "Tilt stop", (b"TS",), "Table 11", summary="tilt stop")
cmd("TU", "Tilt up (ccw)", (b"TU",), "Table 11", summary="tilt up")
cmd("VM", "Set vector motion", (b"VM", choice("vector", {b"1": True, b"0": False}, desc="1 on, 0 off")),
    "Table 11", summary="vector motion {vector}")

# ---------------------------------------------------------------- Table 16 (and 17-18)
cmd("CN", "Camera power on", (b"CN",), "Table 16", summary="camera power on")
cmd("CX", "Camera power off", (b"CX",), "Table 16", summary="camera power off")
cmd("F", "Focus speed", (b"F", decimal("focus_speed", 1, desc="F0 slowest .. F9 fastest")), "Table 16",
    summary="focus speed {focus_speed}")
cmd("FA", "Auto-focus on", (b"FA",), "Table 16", summary="auto-focus on", notes="not implemented per the spec")
cmd("FF", "Focus far", (b"FF",), "Table 16", summary="focus far")
cmd("FN", "Focus near", (b"FN",), "Table 16", summary="focus near")
cmd("FS", "Focus stop", (b"FS",), "Table 16", summary="focus stop")
cmd("FX", "Auto-focus off", (b"FX",), "Table 16", summary="auto-focus off", notes="not implemented per the spec")
_lens = (hexnum("zoom", 3, desc="12-bit zoom position (Table 17)"), hexnum("focus", 3, desc="12-bit focus position"))
cmd("V", "Lens go-to", (b"V",) + _lens, "Table 16, Table 17", summary="lens zoom {zoom} focus {focus}")
cmd("V?", "Lens position request", (b"V?",), "Table 16, Table 17", result=[_lens, (b"V",) + _lens],
    summary="lens position?", result_summary="zoom {zoom} focus {focus}")
cmd("Z", "Zoom speed", (b"Z", decimal("zoom_speed", 1, desc="Z0 slowest .. Z9 fastest")), "Table 16",
    summary="zoom speed {zoom_speed}")
cmd("ZA-ZF", "Digital zoom", (b"Z", Field("digital_zoom", rb"[A-Fa-f]", lambda r: int(r, 16), hexdigits=True,
                                          lead=rb"[A-Fa-f]", desc="ZA..ZF",
                                          type="integer", codec="hex")), "Table 16",
    summary="digital zoom {digital_zoom:X}", notes="ZA..ZF; not implemented per the spec")
cmd("ZI", "Zoom in", (b"ZI",), "Table 16", summary="zoom in")
cmd("ZO", "Zoom out", (b"ZO",), "Table 16", summary="zoom out")
cmd("ZS", "Zoom stop", (b"ZS",), "Table 16", summary="zoom stop")
cmd("*x{aux_port}c", "Configure auxiliary serial port",
    (b"*x", aux_port(), b"c,", decimal("baud", 6, valid=(50, 115200), unit="bps"), b",",
     decimal("data_bits", 1, valid=(5, 8), desc="5..8 (Table 18)"), b",", decimal("stop_bits", 1, valid=(1, 2), desc="1 or 2 (Table 18)"), b",",
     choice("parity", {b"0": "none", b"1": "odd", b"2": "even"}, desc="Table 18: 0 none, 1 odd, 2 even")),
    "Table 16, Table 18", summary="aux {aux_port}: {baud} bps {data_bits} data {stop_bits} stop parity {parity}")
cmd("*x{aux_port}t", "Transmit to auxiliary serial port", (b"*x", aux_port(), b"t", text("data", desc="characters to send (Table 16)")),
    "Table 16", derive=_aux_data, summary="aux {aux_port} send {data!r}")
cmd("*x{aux_port}r", "Receive from auxiliary serial port",
    (b"*x", aux_port(), b"r", decimal("max_bytes", 3, desc="decimal, like *xpc and *xpn")),
    "Table 16", result=[(text("data", desc="characters received (Table 16)"),)], summary="aux {aux_port} read up to {max_bytes}",
    result_summary="{data!r}")
cmd("*x{aux_port}n", "Characters in auxiliary port buffer", (b"*x", aux_port(), b"n"), "Table 16",
    result=[(decimal("count", 3, desc="decimal ASCII count"),)], summary="aux {aux_port} count?",
    result_summary="{count} in the buffer")
cmd("*x{aux_port}f", "Flush auxiliary port buffer", (b"*x", aux_port(), b"f"), "Table 16",
    summary="aux {aux_port} flush")

# ---------------------------------------------------------------- §1.2: new in rev 1.9, format not given
for _code, _name, _due in (
        ("VS", "Camera and relay status", DUE), ("F?", "Current focus speed number", DUE),
        ("Z?", "Current zoom speed number", DUE), ("C?", "Lens software limits or preset values", DUE),
        ("*dA", "Analog channel values", DUE), ("*di", "Digital input values", DUE),
        ("*do", "Digital output values", DUE), ("*dl", "Status messages", DUE),
        ("*dm", "Set loop mode", OPTIONAL), ("*mr", "Send rate commands", OPTIONAL),
        ("*me", "Position in encoder counts", OPTIONAL), ("*mp", "Position in floating point", OPTIONAL),
        ("*mu", "User parameters (integer)", OPTIONAL), ("*sa", "Inertial gain (floating point)", OPTIONAL),
        ("*sgr", "Rate gain (floating point)", OPTIONAL), ("*sgp", "Position gain (floating point)", OPTIONAL),
        ("*sl", "Rate/acceleration limits (floating point)", OPTIONAL),
        ("HP", "Go to last saved gimbal position", NONE), ("VP", "Go to last saved lens position", NONE)):
    cmd(_code, _name, (_code.encode(), free_text("arguments")), "§1.2 (rev 1.9, format not given)",
        result=[(free_text("text"),)] if _due != NONE else [], due=_due,
        summary=_name.lower() + " {arguments}", result_summary="{text}")

BY_ID = {c.id: c for c in COMMANDS}



# ---------------------------------------------------------------- what each command does
# Read from the tables' descriptions. A command whose format the document does not
# give (§1.2) and that may set something is CONFIG: without its format, sending it
# cannot be known to be harmless. `*x?r` reads the auxiliary port's buffer and so
# empties it: CONFIG too. Lens motions (focus, zoom) are MOTION, as the mount's are.
EFFECT_OF = {
    QUERY: ("AW", "B?", "D?", "E?", "I?", "G?", "LR", "L?", "AP?", "AT?", "A?", "HV", "P?", "P?nn",
            "RP?", "RT?", "R?", "S?nn", "V?", "*x{aux_port}n", "VS", "F?", "Z?", "C?", "*dA", "*di", "*do", "*dl"),
    STOP: ("HA", "HS", "PS", "PT", "TS", "FS", "ZS"),
    MOTION: ("IX", "HO", "P", "PL", "PR", "Pnn", "TD", "TU", "VM", "FF", "FN", "V", "ZI", "ZO", "ZA-ZF",
             "HP", "VP", "*mr"),
    CONFIG: ("#NN", "C", "GRP", "GRT", "L0", "L1", "L2", "L3", "L8", "L9", "LA", "LB", "LC", "LS", "AP", "AT",
             "RP", "RT", "Snn", "SP", "ST", "CN", "CX", "F", "FA", "FX", "Z", "*x{aux_port}c", "*x{aux_port}t",
             "*x{aux_port}r", "*x{aux_port}f", "*dm", "*me", "*mp", "*mu", "*sa", "*sgr", "*sgp", "*sl"),
}


def _set_effects() -> None:
    """Each command's ``effect`` from ``EFFECT_OF``: a command missing from it, or
    named twice, stops the import (the table is incomplete)."""
    effect_of: dict[str, str] = {}
    for effect, ids in EFFECT_OF.items():
        for id in ids:
            if id in effect_of:
                raise ValueError(f"command {id!r} has two effects: {effect_of[id]} and {effect}")
            effect_of[id] = effect
    table = {c.id for c in COMMANDS}
    if set(effect_of) != table:
        raise ValueError(f"EFFECT_OF and COMMANDS differ: {sorted(set(effect_of) ^ table)}")
    for c in COMMANDS:
        object.__setattr__(c, "effect", effect_of[c.id])


_set_effects()


@dataclass(frozen=True)
class Derived:
    """A value a derive function above adds to the decoded fields."""
    name: str
    type: str                 # JSON type, as Field.type; "array" with ``items``
    desc: str
    unit: str = ""
    items: str | None = None  # JSON type of an array's items


_BITS = "names of the bits set"
DERIVED = (
    Derived("baud", "integer", "the rate a rate code names (Table 4); null for reserved codes", "bps"),
    Derived("max_baud", "integer", "the rate the maximum rate code names (Table 4, §1.5.6)", "bps"),
    Derived("azimuth_not_initialized", "boolean", "awake status bit 0 (Table 5)"),
    Derived("elevation_not_initialized", "boolean", "awake status bit 1 (Table 5)"),
    Derived("motors_off", "boolean", "awake status bit 2 (Table 5)"),
    Derived("error", "boolean", "awake status bit 3: an error code is present (Table 5)"),
    Derived("azimuth_errors", "array", f"azimuth error bits: {_BITS} (Table 6A)", items="string"),
    Derived("elevation_errors", "array", f"elevation error bits: {_BITS} (Table 6A)", items="string"),
    Derived("azimuth_status", "array", f"azimuth status bits: {_BITS} (Table 6B)", items="string"),
    Derived("elevation_status", "array", f"elevation status bits: {_BITS} (Table 6B)", items="string"),
    Derived("relays_on", "array", "relays that are on, 0..3 (Table 4A)", items="integer"),
    *(Derived(f"{axis}_{way}_ok", "boolean", f"{axis} {way} initialization good (Table 9)")
      for axis in ("azimuth", "elevation") for way in ("ccw", "cw")),
    Derived("azimuth_initialized", "boolean", "count correct bit 0 (Table 14)"),
    Derived("elevation_initialized", "boolean", "count correct bit 1 (Table 14)"),
    Derived("data_length", "integer", "characters of data sent to the auxiliary port (Table 16)"),
    # a rate event's (docs/time.md, "Rate changes"): the rate before it
    Derived("previous_baud", "integer", "the rate before a rate change", "bps"),
)
# Names the derive functions above add to decoded fields (for filters and docs).
DERIVED_FIELDS = tuple(d.name for d in DERIVED)


@dataclass(frozen=True)
class FieldType:
    """What every value of one field name is, across all commands and results."""
    type: str
    unit: str
    desc: str
    items: str | None = None


def field_types() -> dict[str, FieldType]:
    """Every field name of the table (parameters, results, derived values), with
    its JSON type and unit: a name means one thing everywhere, so one name has
    one type (ValueError otherwise)."""
    out: dict[str, FieldType] = {}

    def add(name: str, ft: FieldType) -> None:
        known = out.get(name)
        if known is None:
            out[name] = ft
        elif (known.type, known.items) != (ft.type, ft.items):
            raise ValueError(f"field {name!r} is {known.type} in one layout and {ft.type} in another")
        elif not known.desc and ft.desc:
            out[name] = FieldType(known.type, known.unit or ft.unit, ft.desc, known.items)

    for c in COMMANDS:
        for layout in (c.layout, *c.result):
            for f in layout.fields:
                add(f.name, FieldType(f.type, f.unit, f.desc))
    for d in DERIVED:
        add(d.name, FieldType(d.type, d.unit, d.desc, d.items))
    return out
