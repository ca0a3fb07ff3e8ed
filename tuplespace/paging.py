"""A tuplespace read a page at a time, for whoever shows what it holds."""

from __future__ import annotations

from ._match import ANY
from ._space import Tup, TupleSpace

__all__ = ["page"]


def page(space: TupleSpace, offset: int, limit: int) -> tuple[int, list[Tup]]:
    """Tuples ``offset`` to ``offset + limit`` of ``space`` (by arity, then oldest
    first), and how many it holds in all.

    Raises:
        ValueError: ``offset`` < 0 or ``limit`` < 1.
    """
    if offset < 0 or limit < 1:
        raise ValueError(f"offset must be >= 0 and limit >= 1, got {offset} and {limit}")
    total = 0
    found: list[Tup] = []
    for arity in space.arities():
        tuples = space.rd_all((ANY,) * arity)
        start = max(0, offset - total)
        room = limit - len(found)
        if room > 0 and start < len(tuples):
            found.extend(tuples[start : start + room])
        total += len(tuples)
    return total, found
