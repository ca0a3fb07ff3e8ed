"""Reading another node's tuplespace, a page at a time, with the middleware's own roles.

A node that lets trusted peers see what its space holds calls :func:`serve_space`: it
publishes the property :data:`SERVED_PROPERTY` (its own id) and registers the
participant role :data:`SPACE_ROLE`. A reader starts a session whose group is that one
node (``property_equals(SERVED_PROPERTY, node_id)``), asks for a page and stops the
session when the answer comes (:func:`read_space`).

Who may read is the serving node's choice: it answers only initiators whose node id it
was given, and a node's id is the common name of its certificate (the mesh refuses a
hello naming another id), so a member cannot read by claiming another's id. The reader
in turn takes an answer only from the node it asked, whatever another node publishes
as :data:`SERVED_PROPERTY`.

An answer fits in one role message: a page holds fewer tuples than asked when more
would not fit; page on from ``offset + len(tuples)``. Fields are in their plain JSON
form (:func:`~objectplaces.json_form.json_value`).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Collection, Mapping
from typing import Any, Final

import msgpack

from objectplaces.activator import RoleActivator
from objectplaces.core.comparisons import property_equals
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.ids import ParticipantRef
from objectplaces.core.roles import Initiator, Participant
from objectplaces.core.values import MAX_VALUE_SIZE
from objectplaces.json_form import json_value
from tuplespace.paging import page

__all__ = [
    "MAX_OFFSET",
    "MAX_PAGE",
    "SERVED_PROPERTY",
    "SPACE_ROLE",
    "SpacePage",
    "SpacePageReader",
    "SpacePageServer",
    "SpaceUnreadable",
    "read_space",
    "serve_space",
]

SPACE_ROLE: Final = "space-pages"
"""The participant role that answers a page of its node's tuplespace."""

SERVED_PROPERTY: Final = "serves_space"
"""A node that serves its tuplespace publishes its own id under this name."""

MAX_PAGE: Final = 500
"""Most tuples one answer holds."""

MAX_OFFSET: Final = 1_000_000
"""The largest offset a server takes."""

_ANSWER_BUDGET = MAX_VALUE_SIZE // 2  # bytes of tuples in one answer, with room to spare

SpacePage = tuple[int, list[list[Any]]]
"""How many tuples the space holds in all, and the page read (each field plain JSON)."""


class SpaceUnreadable(LookupError):
    """The node serves no tuplespace to this reader, refused, or did not answer."""


def serve_space(node: RoleActivator, readers: Collection[str]) -> None:
    """Let the nodes ``readers`` read ``node``'s tuplespace (:func:`read_space`)."""
    allowed = frozenset(readers)
    node.set_participant_factory(SPACE_ROLE, lambda: SpacePageServer(allowed))
    node.update_node_property(SERVED_PROPERTY, node.node_id)


def _bounded_int(message: Mapping[str, Any], name: str, low: int, high: int) -> int | None:
    value = message.get(name)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        return None
    return value


class SpacePageServer(Participant):
    """Answers ``{"offset": O, "limit": L}`` with ``{"total": T, "tuples": [...]}``, to
    the readers it was given alone (anyone else hears ``{"refused": why}``)."""

    def __init__(self, readers: frozenset[str]) -> None:
        self._readers = readers

    def receive(self, message: Any) -> None:
        """Answer one request for a page."""
        if self.initiator.node_id not in self._readers:
            self.send({"refused": f"{self.node_id} serves its tuplespace to its control only"})
            return
        request = message if isinstance(message, Mapping) else {}
        offset = _bounded_int(request, "offset", 0, MAX_OFFSET)
        limit = _bounded_int(request, "limit", 1, MAX_PAGE)
        if offset is None or limit is None:
            self.send({"refused": f"offset 0..{MAX_OFFSET} and limit 1..{MAX_PAGE} expected"})
            return
        total, tuples = page(self.space, offset, limit)
        rows: list[list[Any]] = []
        size = 0
        for tup in tuples:
            row = [json_value(field) for field in tup]
            size += len(msgpack.packb(row))
            if size > _ANSWER_BUDGET:
                if not rows:  # one tuple larger than an answer: say so in its place
                    rows.append([f"a tuple of {len(tup)} fields, too large to show"])
                break
            rows.append(row)
        self.send({"total": total, "tuples": rows})


class SpacePageReader(Initiator):
    """Asks the node ``target`` for a page and hands its answer to ``done``."""

    def __init__(self, target: str, offset: int, limit: int, done: Callable[[Any], None]) -> None:
        self._target = target
        self._request = {"offset": offset, "limit": limit}
        self._done = done

    def in_group(self, participant: ParticipantRef) -> None:
        """Ask the node, once it is in the group."""
        if participant.node_id == self._target:
            self.send(participant, self._request)

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        """Take the answer of the node asked, and of no other."""
        if participant.node_id == self._target:
            self._done(message)


def _page_from(target: str, answer: Any) -> SpacePage:
    if isinstance(answer, Mapping) and isinstance(answer.get("refused"), str):
        raise SpaceUnreadable(f"node {target} refused: {answer['refused']}")
    total = answer.get("total") if isinstance(answer, Mapping) else None
    tuples = answer.get("tuples") if isinstance(answer, Mapping) else None
    if (
        isinstance(total, bool)
        or not isinstance(total, int)
        or total < 0
        or not isinstance(tuples, list)
        or not all(isinstance(t, list) for t in tuples)
    ):
        raise SpaceUnreadable(f"node {target} answered something that is not a page")
    return total, [[json_value(field) for field in t] for t in tuples]


async def read_space(node: RoleActivator, target: str, *, offset: int, limit: int) -> SpacePage:
    """Read tuples ``offset`` to ``offset + limit`` of node ``target``'s tuplespace, as
    ``node`` (which must be one of the readers ``target`` serves). Called from the
    event loop that runs ``node``; bound the wait with ``asyncio.timeout``: the session
    ends however the call ends.

    Raises:
        SpaceUnreadable: ``target`` serves no tuplespace (as ``node`` sees its
            properties), refused, or answered something that is not a page.
        ValueError: ``offset`` or ``limit`` out of range.
    """
    if not 0 <= offset <= MAX_OFFSET or not 1 <= limit <= MAX_PAGE:
        raise ValueError(f"offset must be 0..{MAX_OFFSET} and limit 1..{MAX_PAGE}")
    if node.view().get(target, {}).get(SERVED_PROPERTY) != target:
        raise SpaceUnreadable(f"node {target} does not serve its tuplespace")
    loop = asyncio.get_running_loop()
    answered: asyncio.Future[Any] = loop.create_future()

    def settle(message: Any) -> None:
        if not answered.done():
            answered.set_result(message)

    def heard(message: Any) -> None:  # role callbacks may run on the transport's thread
        loop.call_soon_threadsafe(settle, message)

    reader = SpacePageReader(target, offset, limit, heard)
    session = node.start_interaction(reader, property_equals(SERVED_PROPERTY, target), SPACE_ROLE)
    try:
        answer = await answered
    finally:
        with contextlib.suppress(LocalProtocolError):  # the session had ended already
            node.stop_interaction(session)
    return _page_from(target, answer)
