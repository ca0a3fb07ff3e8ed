"""``MemberSet``: an initiator's current participants, as a set in a fixed order.

A ``frozenset`` iterates in hash order, which changes with ``PYTHONHASHSEED``: a role
that sent to each member in turn made seeded runs differ from one process to the next
(STYLE.md §7). A ``MemberSet`` is a set all the same (``in``, ``==`` with any set, ``-``,
``&``, ``|``, hashable) and iterates by node id.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Set
from typing import Any

from objectplaces.core.ids import ParticipantRef

__all__ = ["MemberSet"]


class MemberSet(Set[ParticipantRef]):
    """An immutable set of participants that iterates in node-id order.

    Set operations (``-``, ``&``, ``|``) return plain ``frozenset`` values.
    """

    __slots__ = ("_order", "_set")

    def __init__(self, refs: Iterable[ParticipantRef] = ()) -> None:
        self._set = frozenset(refs)
        self._order = tuple(sorted(self._set, key=lambda r: (r.node_id, r.session_id)))

    @classmethod
    def _from_iterable(cls, it: Iterable[Any]) -> frozenset[Any]:
        return frozenset(it)

    def __contains__(self, ref: object) -> bool:
        return ref in self._set

    def __iter__(self) -> Iterator[ParticipantRef]:
        return iter(self._order)

    def __len__(self) -> int:
        return len(self._order)

    def __hash__(self) -> int:
        return hash(self._set)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, MemberSet):
            return self._set == other._set
        return self._set == other if isinstance(other, Set) else NotImplemented

    def __repr__(self) -> str:
        return f"MemberSet({list(self._order)!r})"
