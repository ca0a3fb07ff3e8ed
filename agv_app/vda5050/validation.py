"""The VDA 5050 3.0 JSON schemas shipped in ``schemas/`` (MIT licence there), and a check.

Only the schemas of the messages the bridge sends or accepts are shipped: ``order``,
``instantActions``, ``state``, ``visualization``, ``connection`` and ``factsheet``.
"""

from __future__ import annotations

import functools
import json
from importlib import resources
from typing import Any

from jsonschema import Draft202012Validator

__all__ = ["SCHEMA_NAMES", "schema", "schema_errors"]

SCHEMA_NAMES = ("order", "instantActions", "state", "visualization", "connection", "factsheet")
"""The message kinds whose schema is shipped."""

_MAX_ERRORS = 5


@functools.cache
def schema(name: str) -> dict[str, Any]:
    """The JSON schema of message kind ``name`` (one of :data:`SCHEMA_NAMES`).

    Raises:
        KeyError: no schema of that name is shipped.
    """
    if name not in SCHEMA_NAMES:
        raise KeyError(f"no VDA 5050 schema {name!r}")
    text = (resources.files("agv_app.vda5050") / "schemas" / f"{name}.schema.json").read_text()
    loaded: dict[str, Any] = json.loads(text)
    return loaded


@functools.cache
def _validator(name: str) -> Draft202012Validator:
    return Draft202012Validator(schema(name), format_checker=Draft202012Validator.FORMAT_CHECKER)


def schema_errors(name: str, message: Any) -> list[str]:
    """What makes ``message`` invalid against schema ``name`` (empty: valid), at most 5.

    Each entry names where in the message the problem is, e.g. ``nodes/0: 'released'
    is a required property``.
    """
    found = []
    for error in _validator(name).iter_errors(message):
        where = "/".join(str(p) for p in error.absolute_path) or "(message)"
        found.append(f"{where}: {error.message}")
        if len(found) >= _MAX_ERRORS:
            break
    return found
