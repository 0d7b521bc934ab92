"""What the simulated gimbal does for each command: one table keyed by command id
(the ids of ``dissectors.commands``), each entry a small handler.

A handler takes the gimbal (``GimbalState``: ``GimbalModel``'s state) and the command's decoded fields,
changes the gimbal's state and returns its answer: None when the ACK says it all,
the result payload (sent at once) or ``(extra delay, result payload)``. Teaching
the simulator a command is one entry here; a command without an entry is
acknowledged and nothing more (camera power, focus and zoom speeds). The data
rate (``C0``…``C7``, Table 4) changes the gimbal's UART, not its state: the model
says so with its ACK and the bus switches the port (docs/time.md, "Rate changes").
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol


class GimbalState(Protocol):
    """What a handler reads and changes of the gimbal: ``GimbalModel``
    (analyzer/simulation/gimbal.py) has it. Declared here so that the table does
    not import the model that uses it."""

    address: tuple[int, int, int]
    name: str
    serial: str
    init_seconds: float
    az: float
    el: float
    target: tuple[float, float] | None
    sweep: tuple[float, float]
    gain: list[float]
    vector: bool
    presets: dict[int, tuple[float, float]]
    limits: list[int]
    zoom: int
    focus: int
    relays: int
    motors_on: bool
    initialized: list[bool]


Answer = str | tuple[float, str] | None
Handler = Callable[[GimbalState, dict], Answer]

PAN, TILT = 0, 1


def h4(value: float) -> str:
    """Hundredths as 4 upper-case hex digits, two's complement (Table 15)."""
    return f"{round(value * 100) & 0xFFFF:04X}"


# ------------------------------------------------------------------ motion
def _go_to(g: GimbalState, v: dict) -> None:
    g.target = (v["azimuth_deg"], v["elevation_deg"])


def _position(g: GimbalState, v: dict) -> str:
    return h4(g.az) + h4(g.el)


def _go_to_preset(g: GimbalState, v: dict) -> None:
    g.target = g.presets.get(v["preset"], (0.0, 0.0))


def _preset_position(g: GimbalState, v: dict) -> str:
    a, e = g.presets.get(v["preset"], (0.0, 0.0))
    return h4(a) + h4(e)


def _store_preset(g: GimbalState, v: dict) -> None:
    g.presets[v["preset"]] = (g.az, g.el)


def _with_axis(sweep: tuple[float, float], axis: int, direction: float) -> tuple[float, float]:
    return (direction, sweep[TILT]) if axis == PAN else (sweep[PAN], direction)


def _sweep(axis: int, direction: float) -> Handler:
    """Continuous motion of one axis (PL/PR, TD/TU: -1 or +1); it ends a go-to."""
    def run(g: GimbalState, v: dict) -> None:
        g.target, g.sweep = None, _with_axis(g.sweep, axis, direction)
    return run


def _axis_stop(axis: int) -> Handler:
    """PS/TS: stops one axis's continuous motion (a go-to target stays)."""
    def run(g: GimbalState, v: dict) -> None:
        g.sweep = _with_axis(g.sweep, axis, 0.0)
    return run


def _stop(g: GimbalState, v: dict) -> None:
    g.target, g.sweep = None, (0.0, 0.0)


def _home(g: GimbalState, v: dict) -> None:
    g.target = (0.0, 0.0)


def _halt(g: GimbalState, v: dict) -> None:
    g.presets[0xFF] = (g.az, g.el)   # halt stores the position (Table 11)
    g.target, g.sweep, g.motors_on = None, (0.0, 0.0), False


def _verify_home(g: GimbalState, v: dict) -> str:
    ok = 3 if all(g.initialized) else 0
    return f"{ok:X}{ok:X}{ok:X}"


def _initialize(g: GimbalState, v: dict) -> tuple[float, str]:
    # the result comes when the sweep to both limits is over (Table 9)
    g.initialized = [True, True]
    g.motors_on = True
    g.target = (0.0, 0.0)
    return g.init_seconds, "09090909"


# ------------------------------------------------------------ settings per axis
def _set(setting: str, axis: int, field: str) -> Handler:
    """A per-axis setting (``rate``, ``accel``, ``gain``, ``speed``) from a field."""
    def run(g: GimbalState, v: dict) -> None:
        getattr(g, setting)[axis] = v[field]
    return run


def _get(setting: str, *axes: int) -> Handler:
    """A per-axis setting's hundredths, one axis or both in order."""
    def run(g: GimbalState, v: dict) -> str:
        values = getattr(g, setting)
        return "".join(h4(values[axis]) for axis in axes)
    return run


def _gains(g: GimbalState, v: dict) -> str:
    return f"G?{round(g.gain[PAN] * 10):02X}{round(g.gain[TILT] * 10):02X}0000"   # Table 8


def _vector(g: GimbalState, v: dict) -> None:
    g.vector = bool(v["vector"])


# ------------------------------------------------------------------ status
def _awake(g: GimbalState, v: dict) -> str:
    status = (0 if g.initialized[PAN] else 1) | (0 if g.initialized[TILT] else 2) | (0 if g.motors_on else 4)
    return f"{status:X}"


def _identity(g: GimbalState, v: dict) -> str:
    return f"{g.address[2]:02X} 9{g.name:<20.20}{g.serial:<20.20}"   # Table 6


def _status_bits(g: GimbalState, v: dict) -> str:
    az = 0 if g.initialized[PAN] else 1
    el = 0 if g.initialized[TILT] else 1
    return f"{az:02X}{el:02X}"


def _constant(payload: str) -> Handler:
    def run(g: GimbalState, v: dict) -> str:
        return payload
    return run


def _set_address(g: GimbalState, v: dict) -> None:
    g.address = (g.address[0], g.address[1], v["new_address"])


# --------------------------------------------------------- relays, limits, lens
def _relay(relay: int, on: bool) -> Handler:
    bit = 1 << relay

    def run(g: GimbalState, v: dict) -> None:
        g.relays = g.relays | bit if on else g.relays & ~bit
    return run


def _relays(g: GimbalState, v: dict) -> str:
    return f"L{g.relays & 0xF:X}"


def _clear_limits(g: GimbalState, v: dict) -> None:
    g.limits = [0x000, 0xFFF, 0x000, 0xFFF]


def _set_limits(g: GimbalState, v: dict) -> None:
    g.limits = [v["pan_ccw"], v["pan_cw"], v["tilt_ccw"], v["tilt_cw"]]


def _limits(g: GimbalState, v: dict) -> str:
    return "".join(f"{x:03X}" for x in g.limits)


def _lens_go_to(g: GimbalState, v: dict) -> None:
    g.zoom, g.focus = v["zoom"], v["focus"]


def _lens(g: GimbalState, v: dict) -> str:
    return f"{g.zoom:03X}{g.focus:03X}"


ANSWERS: dict[str, Handler] = {
    # Table 11: motion and presets
    "P": _go_to,
    "P?": _position,
    "Pnn": _go_to_preset,
    "P?nn": _preset_position,
    "S?nn": _preset_position,
    "Snn": _store_preset,
    "PL": _sweep(PAN, -1.0),
    "PR": _sweep(PAN, 1.0),
    "TD": _sweep(TILT, -1.0),
    "TU": _sweep(TILT, 1.0),
    "PS": _axis_stop(PAN),
    "TS": _axis_stop(TILT),
    "PT": _stop,
    "HS": _stop,
    "HO": _home,
    "HA": _halt,
    "HV": _verify_home,
    # Tables 12-13: rates and accelerations
    "RP": _set("rate", PAN, "rate_deg_s"),
    "RT": _set("rate", TILT, "rate_deg_s"),
    "AP": _set("accel", PAN, "accel_deg_s2"),
    "AT": _set("accel", TILT, "accel_deg_s2"),
    "RP?": _get("rate", PAN),
    "RT?": _get("rate", TILT),
    "AP?": _get("accel", PAN),
    "AT?": _get("accel", TILT),
    "R?": _get("rate", PAN, TILT),
    "A?": _get("accel", PAN, TILT),
    # Tables 7-8: gains; proportional speeds, vector motion
    "GRP": _set("gain", PAN, "gain"),
    "GRT": _set("gain", TILT, "gain"),
    "G?": _gains,
    "SP": _set("speed", PAN, "speed"),
    "ST": _set("speed", TILT, "speed"),
    "VM": _vector,
    # Table 4: status, identity, initialisation, address
    "AW": _awake,
    "B?": _constant("C7"),      # 115200 bps (Table 4)
    "D?": _identity,
    "E?": _constant("0000"),    # no errors (Table 6A)
    "I?": _status_bits,
    "IX": _initialize,
    "#NN": _set_address,
    # Tables 4, 4A, 10: relays 2 and 3 (0 and 1 are reserved), software limits
    "L2": _relay(2, False),
    "L3": _relay(3, False),
    "LA": _relay(2, True),
    "LB": _relay(3, True),
    "LR": _relays,
    "LC": _clear_limits,
    "LS": _set_limits,
    "L?": _limits,
    # Tables 16-17: lens
    "V": _lens_go_to,
    "V?": _lens,
}
