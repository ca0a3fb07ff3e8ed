"""The layout a command runs, from its ``--layout`` argument, and the digest that names it.

Every process of one fleet must drive the same floor: a vehicle that plans on another
layout locks areas the others do not know. :func:`layout_digest` names a layout by its
content (its JSON form, canonical), so processes compare it when they link and refuse a
peer of another floor, naming both digests.
"""

from __future__ import annotations

import hashlib
import json

from agv_app.layout.demo import demo_warehouse
from agv_app.layout.generated import generated_warehouse, parse_generated
from agv_app.layout.graph import Layout
from agv_app.layout.json_format import layout_to_json, load_any

__all__ = ["layout_digest", "layout_from_argument"]

_DIGEST_CHARS = 16


def layout_from_argument(argument: str | None) -> Layout:
    """The layout ``--layout`` names: a ``.json`` or openTCS ``.xml`` file, ``generated:N``,
    or ``demo``; the demo warehouse when None.

    Raises:
        LayoutError: the file cannot be read or is not a valid layout (its message says
            where); ValueError: a bad ``generated:N``.
    """
    if argument is None:
        return demo_warehouse()
    generated = parse_generated(argument)
    if generated is not None:
        return generated_warehouse(generated)
    return load_any(argument)


def layout_digest(layout: Layout) -> str:
    """A short digest of ``layout``'s content: equal layouts, equal digests."""
    text = json.dumps(layout_to_json(layout), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:_DIGEST_CHARS]
