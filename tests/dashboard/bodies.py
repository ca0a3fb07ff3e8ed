"""Request bodies the hostile-client tests build: a poll session and deep definitions."""

from __future__ import annotations

from typing import Any

__all__ = ["WITHIN", "nested_definition", "poll_body"]

WITHIN = {"type": "within", "distance": 20.0}
"""A well-formed definition every test node can evaluate."""


def poll_body(node: str, definition: Any = WITHIN, **overrides: Any) -> dict[str, Any]:
    """A POST /api/sessions body for a ``poll`` session from ``node``; ``overrides`` win."""
    body = {
        "node": node,
        "role": "poll",
        "participant_role": "poll-responder",
        "definition": definition,
        "params": {"property": "status"},
    }
    body.update(overrides)
    return body


def nested_definition(levels: int) -> str:
    """A definition ``levels`` deep as JSON text (built flat: ``json`` would recurse)."""
    leaf = '{"type": "within", "distance": 5.0}'
    return '{"type": "and", "of": [' * (levels - 1) + leaf + "]}" * (levels - 1)
