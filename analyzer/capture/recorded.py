"""The options a capture decodes its source with: those given, and where they
give none, what the source brings of itself (docs/time.md, "Recordings"): a
recording's metadata record (read by ``analyzer.info.recorded_settings``), a
logic capture's measured rate and format."""

from __future__ import annotations

import dataclasses
from typing import Any

from ..errors import BadMetadata
from ..info import recorded_settings
from ..sources import Source
from .options import Options

# Options a recording's metadata gives back, with the flag that overrides each.
FLAGS = {"baud": "--baud", "data_bits": "--data-bits", "parity": "--parity", "stop_bits": "--stop-bits",
         "ack_timeout": "--ack-timeout", "result_timeout": "--result-timeout", "timeouts": "--timeout",
         "frame_gap": "--frame-gap", "follow_rate": "--no-follow-rate"}


def recorded_options(options: Options, source: Source, name: str) -> tuple[Options, list[str]]:
    """The options to decode a recording with: what its metadata says, except
    where the user gave an option explicitly (``options.explicit``). Returns
    (options, messages): one message per explicit option that differs from the
    recording, or one saying the metadata is missing or garbled (then the options
    given and the defaults stand). A logic capture's measured settings are taken
    the same way, silently; other sources (logs, dumps, ports) get ``options``
    back unchanged."""
    measured = {k: v for k, v in source.measured_settings().items() if k not in options.explicit}
    if measured:
        return dataclasses.replace(options, **measured), []
    if not source.carries_metadata:
        return options, []
    meta = source.metadata
    if meta is None:
        why = source.metadata_problem or "it has no gimbalscope metadata record"
        return options, [(f"{name}: {why}: decoding with the options given and the defaults "
                          f"({_described(options)})")]
    try:
        recorded = recorded_settings(meta)
    except BadMetadata as e:
        return options, [(f"{name}: the gimbalscope metadata is garbled ({e}): decoding with the options "
                          f"given and the defaults ({_described(options)})")]
    return _with_recorded(options, recorded, name)


def _with_recorded(options: Options, recorded: dict[str, Any], name: str) -> tuple[Options, list[str]]:
    """``options`` with the ``recorded`` settings it was not given, and a message
    for each given one that differs from the recording."""
    t = options.timeouts
    current = options.settings()
    changes: dict[str, Any] = {}
    said: list[str] = []
    for key, value in recorded.items():
        if key not in options.explicit:
            changes[key] = value
        elif current[key] != value:
            said.append(f"{FLAGS[key]} {_shown(key, current[key])} overrides the {_shown(key, value)} "
                        f"{name} was recorded with")
    timeouts = dataclasses.replace(
        t, ack=changes.pop("ack_timeout", t.ack), result=changes.pop("result_timeout", t.result),
        result_by_command=changes.pop("timeouts", t.result_by_command))
    return dataclasses.replace(options, timeouts=timeouts, **changes), said


def _shown(key: str, value: Any) -> str:
    if key == "follow_rate":
        return "(rate changes followed)" if value else "(rate kept fixed)"
    if key == "timeouts":
        return ",".join(f"{c}={s:g}" for c, s in sorted(value.items())) or "(none)"
    if key == "frame_gap" and value is None:
        return "(default)"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def _described(options: Options) -> str:
    return f"{options.baud} {options.data_bits}{options.parity}{options.stop_bits:g}"
