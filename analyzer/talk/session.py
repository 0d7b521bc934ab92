"""Talking from the TUI (``live --talk PORT``, docs/talk.md, "From the TUI"): a
line typed at the ``:`` prompt, in ``send``'s words, becomes a frame written on
the port the screen is watching; its answers come back through the tap's own
capture, as every other event does. The session's ``--allow-motion`` and
``--allow-config`` hold for every line; a line may also give them itself."""

from __future__ import annotations

from dataclasses import dataclass

from dissectors.dissect import dissect_command
from dissectors.event import format_address

from .link import TalkLink
from .request import frame_for, frame_payload, parse_line
from .safety import ASK_ONLY, Allowed


@dataclass(frozen=True)
class Sent:
    """What a line sent: its bytes, and the command they carry (for the screen's note)."""
    frame: bytes

    def __str__(self) -> str:
        payload = frame_payload(self.frame)
        if payload is None:
            return f"sent {len(self.frame)} raw bytes"
        code = dissect_command(payload).command or "raw bytes"
        return f"sent {code} to {format_address(self.frame[1:4])} ({len(self.frame)} bytes)"


class TalkSession:
    """The port a live TUI may send on, and what it allows (``Allowed``)."""

    def __init__(self, link: TalkLink, allowed: Allowed = ASK_ONLY) -> None:
        self.link = link
        self.allowed = allowed

    def send(self, line: str) -> Sent:
        """Send what ``line`` asks (``request.USAGE``), or raise ``TalkError`` saying why not."""
        frame = frame_for(parse_line(line, self.allowed))
        self.link.write(frame)
        return Sent(frame)
