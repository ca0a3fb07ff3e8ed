"""The plain JSON form of any value a node holds: a property, a role message, a tuple's
field. What the REST API shows and what a node sends of its tuplespace (never an
exception for a value without a JSON form: that value shows as its ``repr``)."""

from __future__ import annotations

import base64
import math
from collections.abc import Mapping
from typing import Any

__all__ = ["json_value"]


def json_value(value: Any) -> Any:
    """Turn a property or message value into plain JSON.

    Tuples become lists, bytes become base64 text, non-finite floats become None, sets
    become sorted lists, and anything else unknown becomes its ``repr`` (a property must
    never break a response).
    """
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, bytes | bytearray):
        return base64.b64encode(bytes(value)).decode("ascii")
    if isinstance(value, Mapping):
        return {str(k): json_value(v) for k, v in value.items()}
    if isinstance(value, list | tuple | frozenset | set):
        items = sorted(value, key=repr) if isinstance(value, frozenset | set) else value
        return [json_value(v) for v in items]
    return repr(value)
