"""What may be sent without asking twice (docs/talk.md, "What may be sent"): a
command that only asks, or stops a motion. One that moves the gimbal needs
``--allow-motion``; one that changes its address, rate, settings or outputs needs
``--allow-config``. The command table says which each command is (``effect``)."""

from __future__ import annotations

from dataclasses import dataclass

from dissectors.commands import CONFIG, MOTION
from dissectors.dissect import dissect_command, summarize

DOES = {MOTION: "moves the gimbal", CONFIG: "changes the gimbal's address, rate, settings or outputs"}
ALLOWED_BY = {MOTION: "--allow-motion", CONFIG: "--allow-config"}


@dataclass(frozen=True)
class Allowed:
    """What the command line allows beyond asking and stopping."""
    motion: bool = False
    config: bool = False

    def allows(self, effect: str) -> bool:
        return {MOTION: self.motion, CONFIG: self.config}.get(effect, True)


ASK_ONLY = Allowed()   # asking and stopping only: what nothing on the command line adds to


def refusal(payload: bytes | None, allowed: Allowed) -> str | None:
    """The one line refusing to send a frame of ``payload``, or None when it may be
    sent. A payload that is no command of the table (``--raw``; None: no frame at
    all) could do anything: it needs both permissions."""
    decoded = dissect_command(payload) if payload else None
    command = decoded.entry if decoded is not None and not decoded.problems else None
    if command is None:
        if allowed.motion and allowed.config:
            return None
        return "the bytes are no command of the table, so what they would do is unknown: " \
               "add --allow-motion --allow-config to send them"
    if allowed.allows(command.effect):
        return None
    assert decoded is not None
    would = summarize(command.summary, decoded.fields) if command.summary else command.name.lower()
    return (f"{command.id} ({command.name}) {DOES[command.effect]}: it would {would}; "
            f"add {ALLOWED_BY[command.effect]} to send it")
