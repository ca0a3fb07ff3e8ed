"""Group definitions: which nodes take part in a session.

A group definition is any callable ``(initiator_props, participant_props) -> bool``.
The declarative ones here are callables too, and say more about themselves: they
serialise to JSON (so the REST API and the dashboard can carry them) and they state a
*reach*, the largest distance from the initiator at which a candidate can still match.
The node engine uses the reach to ask its spatial index for candidates instead of
testing every node it knows, which is what makes a session among N nodes cost about
O(neighbours) per update rather than O(N).

``&`` and ``|`` combine declarative definitions with each other and with plain
callables. A callable part is wrapped in ``Predicate``: it has no reach and no JSON
form, so a conjunction keeps the reach of its declarative parts (``within(40) & f``
tries ``f`` only on the nodes within 40 m) but no longer serialises.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from typing import Any, TypeAlias

from mypy_extensions import mypyc_attr

from objectplaces.core.errors import LocalProtocolError

__all__ = [
    "AllOf",
    "AnyOf",
    "DefinitionLike",
    "GroupDefinition",
    "MaxOf",
    "Predicate",
    "Props",
    "Reach",
    "as_definition",
    "checked_definition",
    "describe",
]

Props: TypeAlias = Mapping[str, Any]
DefinitionLike: TypeAlias = Callable[[Props, Props], bool]
"""What ``start_interaction`` and ``view_group`` take as a group definition: a
``GroupDefinition``, or any callable ``(initiator_props, participant_props) -> bool``."""
MaxOf: TypeAlias = Callable[[str], float]
"""Asks the index for the largest numeric value of a property over the known nodes."""


class Reach:
    """Candidates' ``position`` must lie within ``radius`` of ``centre``, or without one,
    of the initiator's ``position`` property."""

    __slots__ = ("centre", "position", "radius")

    def __init__(
        self, position: str, radius: float, centre: tuple[float, float] | None = None
    ) -> None:
        self.position = position
        self.radius = radius
        self.centre = centre

    def __repr__(self) -> str:
        return f"Reach({self.position!r}, {self.radius!r}, {self.centre!r})"


@mypyc_attr(allow_interpreted_subclasses=True)
class GroupDefinition(ABC):
    """A declarative, serialisable, spatially indexable group definition."""

    @abstractmethod
    def __call__(self, initiator: Props, participant: Props) -> bool:
        """True when ``participant`` belongs to the initiator's group."""

    @abstractmethod
    def to_json(self) -> dict[str, Any]:
        """A JSON-ready description that ``definition_from_json`` turns back into this."""

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        """The bound on candidates' distance, or None when any node may match."""
        return None

    def key(self) -> Any:
        """What equality and hashing compare: the JSON form, as a string."""
        return repr(self.to_json())

    def __and__(self, other: DefinitionLike) -> GroupDefinition:
        return AllOf(self, as_definition(other, "&"))

    def __rand__(self, other: DefinitionLike) -> GroupDefinition:
        return AllOf(as_definition(other, "&"), self)

    def __or__(self, other: DefinitionLike) -> GroupDefinition:
        return AnyOf(self, as_definition(other, "|"))

    def __ror__(self, other: DefinitionLike) -> GroupDefinition:
        return AnyOf(as_definition(other, "|"), self)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, GroupDefinition) and self.key() == other.key()

    def __hash__(self) -> int:
        return hash(self.key())

    def __repr__(self) -> str:
        return f"definition_from_json({self.to_json()!r})"


class Predicate(GroupDefinition):
    """A plain callable inside a combination (``within(40) & f``): tried as it is, with
    no reach (any node may match) and no JSON form.

    Raises:
        LocalProtocolError: ``fn`` is not callable.
    """

    def __init__(self, fn: DefinitionLike) -> None:
        if not callable(fn):
            raise LocalProtocolError(f"a group definition must be callable, got {fn!r}")
        self.fn = fn

    def __call__(self, initiator: Props, participant: Props) -> bool:
        return bool(self.fn(initiator, participant))

    def to_json(self) -> dict[str, Any]:
        """Raises ``LocalProtocolError``: a callable has no JSON form."""
        raise LocalProtocolError(
            f"{self.fn!r} is a callable: it has no JSON form, nor has any definition that "
            "holds it (write it as a declarative definition to send it)"
        )

    def key(self) -> Any:
        return ("callable", self.fn)

    def __repr__(self) -> str:
        return f"Predicate({self.fn!r})"


def as_definition(part: object, operator: str = "&") -> GroupDefinition:
    """``part`` as a declarative definition: itself, or a callable wrapped in ``Predicate``.

    Raises:
        TypeError: ``part`` is not callable; the message says what ``operator`` takes.
    """
    if isinstance(part, GroupDefinition):
        return part
    if callable(part):
        return Predicate(part)
    raise TypeError(
        f"{operator} combines group definitions: a definition of objectplaces.groups or a "
        f"callable (initiator_props, participant_props) -> bool, got {part!r}"
    )


class AllOf(GroupDefinition):
    """Members: nodes that satisfy every one of ``parts``."""

    def __init__(self, *parts: GroupDefinition) -> None:
        self.parts = parts

    def __call__(self, initiator: Props, participant: Props) -> bool:
        # A loop, not all() over a generator: half the cost, on every candidate tried.
        for part in self.parts:  # noqa: SIM110
            if not part(initiator, participant):
                return False
        return True

    def to_json(self) -> dict[str, Any]:
        return {"type": "and", "of": [part.to_json() for part in self.parts]}

    def key(self) -> Any:
        return ("and", tuple(part.key() for part in self.parts))

    def __repr__(self) -> str:
        return " & ".join(f"({part!r})" for part in self.parts)

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        # Any one bounded part bounds the conjunction; the tightest one is the best bound.
        reaches = [r for part in self.parts if (r := part.reach(initiator, max_of)) is not None]
        return min(reaches, key=lambda r: r.radius, default=None)


class AnyOf(GroupDefinition):
    """Members: nodes that satisfy at least one of ``parts``."""

    def __init__(self, *parts: GroupDefinition) -> None:
        self.parts = parts

    def __call__(self, initiator: Props, participant: Props) -> bool:
        return any(part(initiator, participant) for part in self.parts)

    def to_json(self) -> dict[str, Any]:
        return {"type": "or", "of": [part.to_json() for part in self.parts]}

    def key(self) -> Any:
        return ("or", tuple(part.key() for part in self.parts))

    def __repr__(self) -> str:
        return " | ".join(f"({part!r})" for part in self.parts)

    def reach(self, initiator: Props, max_of: MaxOf) -> Reach | None:
        # A disjunction is bounded only if every part is, around the same centre.
        reaches = [part.reach(initiator, max_of) for part in self.parts]
        if not reaches or any(r is None for r in reaches):
            return None
        bounded = [r for r in reaches if r is not None]
        if len({(r.position, r.centre) for r in bounded}) != 1:
            return None
        return max(bounded, key=lambda r: r.radius)


def describe(definition: DefinitionLike) -> Any:
    """A declarative definition's JSON form; any other callable's ``repr`` (and that of a
    definition whose JSON form fails, such as one holding a callable)."""
    if isinstance(definition, GroupDefinition):
        try:
            return definition.to_json()
        except Exception:
            return repr(definition)
    return repr(definition)


def checked_definition(definition: object, own: Props) -> DefinitionLike:
    """``definition``, once it has shown it can resolve a group around ``own``.

    Raises:
        LocalProtocolError: it is not callable, or it is declarative and its reach
            fails (the error it raised is the cause).
    """
    if not callable(definition):
        raise LocalProtocolError(f"group definition must be callable, got {definition!r}")
    if isinstance(definition, GroupDefinition):
        try:
            definition.reach(own, lambda name: 0.0)
        except Exception as exc:
            error = LocalProtocolError(
                f"group definition {definition!r} cannot resolve a group: {exc!r}"
            )
            # Set by hand: compiled with mypyc, ``raise ... from exc`` leaves no cause.
            error.__cause__ = exc
            raise error from exc
    return definition
