"""``saleae.data``: ``GraphTime`` and ``GraphTimeDelta`` as Logic 2 documents
them. A ``GraphTime`` is a wall clock time: subtracting two gives a
``GraphTimeDelta``; adding or subtracting a delta gives a ``GraphTime``; it has
no comparison and no float (a HLA measures time by the delta between two).
A delta adds, subtracts, compares and converts to float seconds. Both are kept
in integer picoseconds here, exact."""

from __future__ import annotations

from datetime import datetime, timedelta, timezone

_PS = {"second": 10**12, "millisecond": 10**9, "microsecond": 10**6, "nanosecond": 10**3, "picosecond": 1}
_EPOCH = datetime(1970, 1, 1, tzinfo=timezone.utc)   # noqa: UP017 - runs under Python 3.8 too, as Logic's


def _picoseconds(**parts: float) -> int:
    return round(sum(float(v) * _PS[k] for k, v in parts.items()))


class GraphTimeDelta:
    """A duration."""

    __slots__ = ("ps",)

    def __init__(self, second: float = 0, millisecond: float = 0, *, microsecond: float = 0, nanosecond: float = 0,
                 picosecond: float = 0) -> None:
        self.ps = _picoseconds(second=second, millisecond=millisecond, microsecond=microsecond,
                               nanosecond=nanosecond, picosecond=picosecond)

    @classmethod
    def _of(cls, ps: int) -> GraphTimeDelta:
        d = cls()
        d.ps = ps
        return d

    def _other(self, other: object) -> int:
        if not isinstance(other, GraphTimeDelta):
            raise TypeError(f"a GraphTimeDelta takes a GraphTimeDelta, not {type(other).__name__}")
        return other.ps

    def __add__(self, other: object) -> GraphTimeDelta:
        return GraphTimeDelta._of(self.ps + self._other(other))

    def __sub__(self, other: object) -> GraphTimeDelta:
        return GraphTimeDelta._of(self.ps - self._other(other))

    def __float__(self) -> float:
        return self.ps / 10**12

    def __eq__(self, other: object) -> bool:
        return self.ps == self._other(other)

    def __ne__(self, other: object) -> bool:
        return self.ps != self._other(other)

    def __lt__(self, other: object) -> bool:
        return self.ps < self._other(other)

    def __le__(self, other: object) -> bool:
        return self.ps <= self._other(other)

    def __gt__(self, other: object) -> bool:
        return self.ps > self._other(other)

    def __ge__(self, other: object) -> bool:
        return self.ps >= self._other(other)

    __hash__ = None   # type: ignore[assignment]   # as Logic's: compared up to a tolerance, not hashed

    def __repr__(self) -> str:
        return f"GraphTimeDelta({self.ps / 10**12!r})"


class GraphTime:
    """A point in time: a ``datetime`` and a sub-millisecond part."""

    __slots__ = ("ps",)

    def __init__(self, datetime: datetime, millisecond: float = 0, *, microsecond: float = 0,
                 nanosecond: float = 0, picosecond: float = 0) -> None:
        whole = (datetime - _EPOCH) // timedelta(microseconds=1)
        self.ps = whole * 10**6 + _picoseconds(millisecond=millisecond, microsecond=microsecond,
                                               nanosecond=nanosecond, picosecond=picosecond)

    @classmethod
    def _of(cls, ps: int) -> GraphTime:
        t = cls.__new__(cls)
        t.ps = ps
        return t

    def __add__(self, other: object) -> GraphTime:
        if not isinstance(other, GraphTimeDelta):
            raise TypeError(f"a GraphTime adds a GraphTimeDelta, not {type(other).__name__}")
        return GraphTime._of(self.ps + other.ps)

    def __sub__(self, other: object) -> GraphTime | GraphTimeDelta:
        if isinstance(other, GraphTime):
            return GraphTimeDelta._of(self.ps - other.ps)
        if isinstance(other, GraphTimeDelta):
            return GraphTime._of(self.ps - other.ps)
        raise TypeError(f"a GraphTime subtracts a GraphTime or a GraphTimeDelta, not {type(other).__name__}")

    def as_datetime(self) -> datetime:
        return _EPOCH + timedelta(microseconds=self.ps // 10**6)

    def __str__(self) -> str:
        return self.as_datetime().strftime("%Y-%m-%dT%H:%M:%S.") + f"{self.ps % 10**12:012d}Z"

    def __repr__(self) -> str:
        return f"GraphTime({self})"
