"""Typed options of the command lines: a bad value stops the parse with exit status 2
and a line that names the option, what it takes and what it got.

argparse's ``type=float`` takes ``nan``, ``inf`` and ``1e999``, and a run handed such a
value fails deep inside with a traceback, or never ends. Each number option declares
its range here instead (``type=number(above=0)``); group and property options of
``objectplaces node`` are read here too.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from objectplaces import groups
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.groups import GroupDefinition

__all__ = [
    "POSITIVE",
    "NumberArgument",
    "group_argument",
    "number",
    "property_argument",
    "whole",
]


class NumberArgument:
    """An argparse ``type``: a finite number, whole or not, within bounds.

    Args:
        above, at_least: the lower bound, strict or not (None: none).
        below, at_most: the upper bound, strict or not (None: none).
        whole: only whole numbers (the value is then an ``int``).
    """

    __slots__ = ("above", "at_least", "at_most", "below", "whole")

    def __init__(
        self,
        *,
        above: float | None = None,
        at_least: float | None = None,
        below: float | None = None,
        at_most: float | None = None,
        whole: bool = False,
    ) -> None:
        self.above, self.at_least, self.below, self.at_most = above, at_least, below, at_most
        self.whole = whole

    def admits(self, value: float) -> bool:
        """Whether ``value`` is finite and within the bounds."""
        return (
            (isinstance(value, int) or math.isfinite(value))
            and (self.above is None or value > self.above)
            and (self.at_least is None or value >= self.at_least)
            and (self.below is None or value < self.below)
            and (self.at_most is None or value <= self.at_most)
        )

    def __str__(self) -> str:
        kind = "a whole number" if self.whole else "a number"
        low, high = _end(self.above, self.at_least), _end(self.below, self.at_most)
        if low is not None and high is not None:
            opens = "(" if low[1] else "["
            closes = ")" if high[1] else "]"
            return f"{kind} in {opens}{low[0]:g}, {high[0]:g}{closes}"
        if low is not None:
            return f"{kind} {'>' if low[1] else '>='} {low[0]:g}"
        if high is not None:
            return f"{kind} {'<' if high[1] else '<='} {high[0]:g}"
        return kind

    def __call__(self, text: str) -> float:
        try:
            value: float = int(text, 10) if self.whole else float(text)
        except ValueError:
            value = math.nan
        if not self.admits(value):
            raise argparse.ArgumentTypeError(f"expected {self}, got {text!r}")
        return value

    def __repr__(self) -> str:
        return f"NumberArgument({self})"


def _end(strict: float | None, loose: float | None) -> tuple[float, bool] | None:
    """One end of a range: its value and whether it is strict (None: open)."""
    if strict is not None:
        return strict, True
    return None if loose is None else (loose, False)


def number(
    *,
    above: float | None = None,
    at_least: float | None = None,
    below: float | None = None,
    at_most: float | None = None,
) -> NumberArgument:
    """An argparse ``type`` for a finite number within the given bounds."""
    return NumberArgument(above=above, at_least=at_least, below=below, at_most=at_most)


def whole(*, at_least: int | None = None, at_most: int | None = None) -> NumberArgument:
    """An argparse ``type`` for a whole number within the given bounds (an ``int``)."""
    return NumberArgument(at_least=at_least, at_most=at_most, whole=True)


POSITIVE = number(above=0)
"""A finite number > 0: a duration, a rate, a distance."""


def group_argument(spec: str) -> GroupDefinition:
    """``within:D`` (the nodes within ``D`` metres, 5 when left out) or ``circles``."""
    kind, _, arg = spec.partition(":")
    try:
        if kind == "within":
            return groups.within(_DISTANCE(arg) if arg else 5.0)
        if kind == "circles" and not arg:
            return groups.circles_overlap()
    except (argparse.ArgumentTypeError, LocalProtocolError):
        pass
    raise argparse.ArgumentTypeError(
        f"expected within:D (D a distance >= 0, m) or circles, got {spec!r}"
    )


def property_argument(spec: str) -> tuple[str, Any]:
    """``NAME=JSON``: a property's name and value (text that is not JSON stays text)."""
    name, sep, value = spec.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"property must be NAME=JSON, got {spec!r}")
    try:
        parsed = json.loads(value)
    except json.JSONDecodeError:
        parsed = value
    if name == "position" and isinstance(parsed, list):
        parsed = tuple(parsed)
    return name, parsed


_DISTANCE = number(at_least=0)
