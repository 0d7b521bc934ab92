"""``saleae.analyzers``: the High Level Analyzer base, ``AnalyzerFrame`` and the
settings, as Logic 2 documents them. Settings are class attributes; Logic 2
gives the instance each setting's value (the chosen string, the number) before
it calls ``__init__`` (tests/saleae_logic.py does the same)."""

from __future__ import annotations

from typing import Any, ClassVar

from .data import GraphTime

# what Logic 2 shows as a frame's data value
DATA_TYPES = (str, int, float, bool, bytes)


class HighLevelAnalyzer:
    """Subclasses implement ``decode(frame)``: None, an ``AnalyzerFrame`` or a list of them."""

    result_types: ClassVar[dict[str, dict[str, str]]] = {}

    def decode(self, frame: AnalyzerFrame) -> Any:
        raise NotImplementedError


class AnalyzerFrame:
    """A frame: its type, its start and end, and its data (key/value)."""

    def __init__(self, type: str, start_time: GraphTime, end_time: GraphTime,
                 data: dict | None = None) -> None:
        if not isinstance(type, str):
            raise TypeError(f"a frame's type is a str, not {type!r}")
        if not isinstance(start_time, GraphTime) or not isinstance(end_time, GraphTime):
            raise TypeError("a frame's start_time and end_time are GraphTimes")
        data = {} if data is None else data
        for key, value in data.items():
            if not isinstance(key, str) or not isinstance(value, DATA_TYPES):
                raise TypeError(f"data {key!r}: {value!r} is not a value Logic 2 shows ({DATA_TYPES})")
        self.type = type
        self.start_time = start_time
        self.end_time = end_time
        self.data = data


class Setting:
    def __init__(self, **kwargs: Any) -> None:
        self.label = kwargs.pop("label", None)
        if kwargs:
            raise TypeError(f"unknown setting arguments {sorted(kwargs)}")

    def default(self) -> Any:
        raise NotImplementedError

    def check(self, value: Any) -> None:
        raise NotImplementedError


class StringSetting(Setting):
    def default(self) -> str:
        return ""

    def check(self, value: Any) -> None:
        if not isinstance(value, str):
            raise TypeError(f"{self.label}: {value!r} is no string")


class NumberSetting(Setting):
    def __init__(self, *, min_value: float | None = None, max_value: float | None = None, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.min_value, self.max_value = min_value, max_value

    def default(self) -> float:
        return float(self.min_value) if self.min_value is not None else 0.0

    def check(self, value: Any) -> None:
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise TypeError(f"{self.label}: {value!r} is no number")
        if (self.min_value is not None and value < self.min_value) or (
                self.max_value is not None and value > self.max_value):
            raise ValueError(f"{self.label}: {value} outside {self.min_value}..{self.max_value}")


class ChoicesSetting(Setting):
    def __init__(self, choices: Any = (), **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.choices = tuple(choices)
        if not self.choices or not all(isinstance(c, str) for c in self.choices):
            raise TypeError("a ChoicesSetting's choices are strings")

    def default(self) -> str:
        return self.choices[0]

    def check(self, value: Any) -> None:
        if value not in self.choices:
            raise ValueError(f"{self.label}: {value!r} is none of {self.choices}")
