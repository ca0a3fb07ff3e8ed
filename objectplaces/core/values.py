"""What a property value or a role message may be: checked once, at the boundary.

Two boundaries, two answers (DESIGN.md, "Boundaries validate once"):

* **The local API** (``update_node_property``, a role's ``send``) refuses a bad value at
  the call, with an exception that shows it and says where in the value it sits, and
  queues nothing. A value that is not plain data (dict, list, tuple, str, int, float,
  bool, None, bytes, nested) is a ``NotPlainDataError`` (a ``TypeError``); plain data
  that is still unacceptable (nested too deep, too large, an integer msgpack cannot
  carry, a position that is not two finite numbers) is an ``InvalidValueError`` (a
  ``ValueError``). Both are ``LocalProtocolError``s, so older callers that catch that
  keep working.
* **Frames from peers** are checked by the codec as a whole, before any part of the
  machine sees them (codec.py raises ``InvalidPropertyError``); the machine drops and
  counts such a frame (intake.py). The well-known properties are the ones the
  machine itself computes with, so they are the ones a peer could use to make it
  raise: ``position`` feeds the spatial index and the scope (``float``, ``floor``),
  ``hull_length`` the running maximum behind ``circles_overlap``'s reach. Other
  properties are opaque to the middleware and only need to be plain data, which
  msgpack guarantees for anything it decodes.

Everything inside the machine then trusts its data: no ``float()`` deep in an index
wonders what it was given (STYLE.md, "What to grow out of").
"""

from __future__ import annotations

import math
from typing import Any, Final

from objectplaces.core.errors import InvalidValueError, NotPlainDataError

__all__ = [
    "MAX_COORDINATE",
    "MAX_DEPTH",
    "MAX_VALUE_SIZE",
    "POSITION",
    "RADIUS",
    "check_plain",
    "checked_position",
    "checked_radius",
    "is_finite_number",
]

POSITION: Final = "position"
RADIUS: Final = "hull_length"
MAX_COORDINATE: Final = 1e12
"""Largest magnitude of a coordinate or hull length, in metres: positions travel as whole
millimetres, which stay exact (below 2**53) up to about 9e12 m."""
MAX_DEPTH: Final = 32
"""Deepest nesting of containers in one value (a position is depth 1)."""
MAX_VALUE_SIZE: Final = 64 * 1024
"""Largest encoded size of one property value, in bytes: every republication carries
every property, so one huge value would cost every heartbeat of every node."""

_SCALARS: Final = (str, int, float, bool, bytes, type(None))
_INT_RANGE: Final = range(-(2**63), 2**64)  # what msgpack can carry


def is_finite_number(value: object) -> bool:
    """Whether ``value`` is an int or float (not a bool) and finite."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _is_coordinate(value: Any) -> bool:
    return is_finite_number(value) and -MAX_COORDINATE <= value <= MAX_COORDINATE


def checked_position(value: Any) -> tuple[float, float]:
    """``value`` as a position: a pair of finite numbers, as floats.

    Raises:
        InvalidValueError: not a list or tuple of exactly two finite numbers within
            ``MAX_COORDINATE``.
    """
    if (
        isinstance(value, tuple | list)
        and len(value) == 2
        and _is_coordinate(value[0])
        and _is_coordinate(value[1])
    ):
        return float(value[0]), float(value[1])
    raise InvalidValueError(
        f"{POSITION!r} must be two finite numbers (x, y) within +-{MAX_COORDINATE:g} m, "
        f"got {value!r:.80}"
    )


def checked_radius(value: Any) -> float:
    """``value`` as a hull length: a finite number >= 0, as a float.

    Raises:
        InvalidValueError: not a finite number >= 0.
    """
    if _is_coordinate(value) and value >= 0:
        return float(value)
    raise InvalidValueError(
        f"{RADIUS!r} must be a finite number >= 0 and <= {MAX_COORDINATE:g} m, got {value!r:.80}"
    )


def check_plain(value: Any, what: str = "value") -> None:
    """Check that ``value`` is plain data, nested at most ``MAX_DEPTH`` deep.

    Args:
        value: the value to check.
        what: how to name it in an error (``"property 'status'"``).

    Raises:
        NotPlainDataError: something in it is not plain data (the message shows where).
        InvalidValueError: nested too deep, or an integer outside msgpack's range.
    """
    _walk(value, what, 0)


def _walk(value: Any, path: str, depth: int) -> None:
    if isinstance(value, _SCALARS):
        if isinstance(value, int) and value not in _INT_RANGE:
            raise InvalidValueError(f"{path}: integer {value} is out of the wire's range")
        return
    if depth >= MAX_DEPTH:
        raise InvalidValueError(f"{path}: nested deeper than {MAX_DEPTH} levels")
    if isinstance(value, list | tuple):
        for i, item in enumerate(value):
            _walk(item, f"{path}[{i}]", depth + 1)
    elif isinstance(value, dict):
        for key, item in value.items():
            if not isinstance(key, _SCALARS):
                raise NotPlainDataError(
                    f"{path}: key {key!r:.80} of type {type(key).__name__} is not plain data"
                )
            _walk(item, f"{path}[{key!r}]", depth + 1)
    else:
        raise NotPlainDataError(
            f"not serialisable as plain data: {path} is {value!r:.80} "
            f"of type {type(value).__name__} (allowed: dict, list, tuple, str, int, "
            "float, bool, None, bytes)"
        )
