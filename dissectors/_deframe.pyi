# The C deframing loop's signatures (dissectors/_deframe.c), for the type checker:
# an extension module carries none of its own.
from .event import Event

INTERFACE: int

def configure(blank: Event, slot_names: tuple[str, ...], /) -> None: ...
def deframe(buf: bytes, i: int, kinds: tuple[str | None, ...], line: str, frame_kind: str, base: int,
            out: list[Event], /, *segments: list[int] | list[float]) -> int: ...
def whole(data: bytes, t: float | None, bt: float, base: int, line: str, frame_kind: str,
          kinds: tuple[str | None, ...], /) -> Event | None: ...
