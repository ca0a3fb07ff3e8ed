"""The closed parts of a fleet's floor: what the operator closed, and who is told.

:class:`FloorBlocks` keeps the blocks in force (a segment, a point or a polygon each,
:mod:`agv_app.layout.blocked`), refuses one that would cut a station off from the rest
of the floor unless forced, and hands the open ways to every AGV component of the fleet
whenever they change (the AGV keeps off what is closed:
:mod:`agv_app.vehicle.closures`). It also says why an order waits for a closed part
(:meth:`FloorBlocks.waits`). Closing and reopening are all or nothing: a refused change
leaves everything as it was.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from agv_app.geometry import XY
from agv_app.layout.blocked import (
    CLOSURE_KINDS,
    Closed,
    ClosureKind,
    OpenWays,
    closed_by,
    cut_off_stations,
    known_list,
)
from agv_app.layout.elements import LayoutError
from agv_app.layout.graph import Layout

__all__ = ["Block", "CutsOff", "FloorBlocks", "Routed", "UnknownBlock", "parse_closure"]


class Routed(Protocol):
    """An AGV component that routes over the open ways it is given."""

    ways: OpenWays | None


class CutsOff(LayoutError):
    """A block would cut stations off from the rest of the floor.

    Attributes:
        stations: their ids, sorted.
    """

    def __init__(self, stations: Sequence[str]) -> None:
        super().__init__(
            "the block would cut off every way out of station(s) "
            f"{known_list(stations)} (force it to close anyway)"
        )
        self.stations = tuple(stations)


class UnknownBlock(KeyError):
    """No block in force has that id; ``known`` lists those that are, sorted."""

    def __init__(self, block_id: str, known: Sequence[str]) -> None:
        super().__init__(f"unknown block {block_id!r} (known: {known_list(known) or 'none'})")
        self.known = tuple(known)

    def __str__(self) -> str:
        return str(self.args[0])


@dataclass(frozen=True, slots=True)
class Block:
    """A part of the floor the operator closed.

    Attributes:
        id: ``b1``, ``b2``, ... in the order they were closed.
        kind: ``segment``, ``point`` or ``polygon``.
        what: the segment or point id, or the polygon's vertices.
        closed: the points and segments it shuts.
        reason: why (as the operator gave it).
        by: who asked.
        since: when, seconds of the fleet's clock.
    """

    id: str
    kind: ClosureKind
    what: str | tuple[XY, ...]
    closed: Closed
    reason: str = ""
    by: str = ""
    since: float = 0.0


class FloorBlocks:
    """The blocks in force on one fleet's floor.

    Args:
        layout: the floor plan.
        agvs: the fleet's AGV components by id, in this process (a live mapping: AGVs
            built later are given the open ways by the fleet, from :attr:`ways`).
        on_change: told the open ways on every change (a fleet of AGV processes
            publishes them: :mod:`agv_app.fleet.closed_listener`).
    """

    def __init__(
        self,
        layout: Layout,
        agvs: Mapping[str, Routed] | None = None,
        *,
        on_change: Callable[[OpenWays | None], None] | None = None,
    ) -> None:
        self.layout = layout
        self._agvs: Mapping[str, Routed] = {} if agvs is None else agvs
        self._on_change = on_change
        self._blocks: dict[str, Block] = {}
        self._count = 0
        self.ways: OpenWays | None = None
        """The open ways (None while nothing is closed)."""

    def blocks(self) -> list[Block]:
        """The blocks in force, oldest first."""
        return list(self._blocks.values())

    def _ways_with(self, blocks: Sequence[Block]) -> OpenWays | None:
        closed = Closed()
        for block in blocks:
            closed |= block.closed
        return None if closed.empty else OpenWays(self.layout, closed)

    def close(
        self,
        kind: ClosureKind,
        what: str | Sequence[XY],
        *,
        force: bool = False,
        reason: str = "",
        by: str = "",
        now: float = 0.0,
    ) -> Block:
        """Close a segment, a point or a polygon.

        Raises:
            UnknownElement: an unknown segment or point (it names the known ones).
            LayoutError: a polygon that is no area or touches nothing.
            CutsOff: without ``force``, the block would cut stations off that the
                blocks in force leave reachable.
        """
        closed = closed_by(self.layout, kind, what)
        target = what if isinstance(what, str) else tuple((float(x), float(y)) for x, y in what)
        block = Block(f"b{self._count + 1}", kind, target, closed, reason, by, now)
        ways = self._ways_with([*self._blocks.values(), block])
        if not force and ways is not None:
            before = set() if self.ways is None else set(cut_off_stations(self.ways))
            cut = [s for s in cut_off_stations(ways) if s not in before]
            if cut:
                raise CutsOff(cut)
        self._count += 1
        self._blocks[block.id] = block
        self._apply(ways)
        return block

    def reopen(self, block_id: str) -> Block:
        """Reopen a block.

        Raises:
            UnknownBlock: no block in force has that id.
        """
        block = self._blocks.get(block_id)
        if block is None:
            raise UnknownBlock(block_id, sorted(self._blocks))
        del self._blocks[block_id]
        self._apply(self._ways_with(list(self._blocks.values())))
        return block

    def _apply(self, ways: OpenWays | None) -> None:
        self.ways = ways
        for agv in self._agvs.values():
            agv.ways = ways
        if self._on_change is not None:
            self._on_change(ways)

    def waits(self, pick: str, drop: str) -> str | None:
        """Why an order from station ``pick`` to station ``drop`` waits for a closed part
        of the floor (e.g. ``waits: path P closed``), or None when it need not."""
        ways = self.ways
        if ways is None:
            return None
        layout = self.layout
        for sid in (pick, drop):
            if ways.is_closed(layout.station(sid).point):
                return f"waits: station {sid} closed"
        a, b = layout.station(pick).point, layout.station(drop).point
        if ways.distance(a, b) < float("inf"):
            return None
        named = ways.blocking(a, b)
        if not named:
            return f"waits: no open way from {pick} to {drop}"
        return f"waits: {known_list(named, 3)} closed"


def parse_closure(text: str) -> tuple[ClosureKind, str | list[XY]]:
    """``segment:ID``, ``point:ID`` or ``polygon:X,Y;X,Y;X,Y`` as ``(kind, what)``.

    Raises:
        ValueError: none of these.
    """
    kind, _, what = text.partition(":")
    for known in CLOSURE_KINDS:
        if kind == known and what:
            if known != "polygon":
                return known, what
            try:
                return known, [_vertex(v) for v in what.split(";")]
            except ValueError:
                break
    raise ValueError(f"expected segment:ID, point:ID or polygon:X,Y;X,Y;X,Y, got {text!r}")


def _vertex(text: str) -> XY:
    x, y = text.split(",")
    return (float(x), float(y))
