"""Cell routing, shared by every transport: who hears a publication in which cells.

Nodes declare what they want to hear (``Subscribe``): a set of grid cells, or everything
(``None``). A ``Publish`` names the cells it concerns (the publisher's home: its cell or
its footprint; then the cells it just left, so their subscribers learn it moved away);
it reaches every full subscriber and every subscriber of one of those cells, once, the
publisher excepted.

The router also remembers the home each node last published in, so that a new
subscriber of a cell can be sent the properties of the nodes publishing there at once,
instead of waiting one republication interval. The in-memory network keeps one router
for the whole network (it plays a content router's part); a mesh node keeps one for its
peers' subscriptions and its own publications (a mesh has no router).

Sans-I/O: plain data in, plain data out. Every table shrinks when a node is forgotten,
and a cell's entry goes with its last subscriber, so memory follows the live nodes.
Orders are insertion orders (never set order), so simulations replay exactly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["Cell", "CellRouter", "Subscribed"]

Cell = tuple[int, int]


@dataclass(frozen=True, slots=True)
class Subscribed:
    """What a new subscription asks of the publishers.

    Attributes:
        became_full: the node now hears everything and did not before; every node
            should send it its properties.
        publishers: nodes that last published in a cell the subscription newly covers;
            each should send the subscriber its properties (in this order).
    """

    became_full: bool
    publishers: tuple[str, ...]


class CellRouter:
    """Subscriptions per node and the home (cells) each node last published in."""

    __slots__ = ("_cell_subs", "_homes", "_publishers_in", "_subscriptions", "_wildcard")

    def __init__(self) -> None:
        self._subscriptions: dict[str, frozenset[Cell] | None] = {}
        self._wildcard: dict[str, None] = {}
        self._cell_subs: dict[Cell, dict[str, None]] = {}
        self._homes: dict[str, tuple[Cell, ...]] = {}
        self._publishers_in: dict[Cell, dict[str, None]] = {}

    def subscribe(self, node: str, cells: frozenset[Cell] | None) -> Subscribed:
        """Replace ``node``'s subscription with ``cells`` (None: everything).

        Returns:
            Who should send ``node`` its properties now.
        """
        known = node in self._subscriptions
        old = self._subscriptions.get(node)
        self._subscriptions[node] = cells
        if cells is None:
            self._set_cells(node, old, frozenset())
            self._wildcard[node] = None
            return Subscribed(not known or old is not None, ())
        self._wildcard.pop(node, None)
        self._set_cells(node, old, cells)
        found: dict[str, None] = {}
        for cell in sorted(cells - old) if old else sorted(cells):
            publishers = self._publishers_in.get(cell)
            if publishers:
                found.update(publishers)
        found.pop(node, None)
        return Subscribed(False, tuple(found))

    def unsubscribe(self, node: str) -> None:
        """Forget ``node``'s subscription (it hears nothing until it subscribes again)."""
        self._drop_subscription(node)

    def forget(self, node: str) -> None:
        """Forget ``node`` entirely: its subscription and where it last published."""
        self._drop_subscription(node)
        for cell in self._homes.pop(node, ()):
            self._drop_publisher(node, cell)

    def publish(self, node: str, cells: Sequence[Cell], home: int = 1) -> dict[str, None]:
        """Route one publication of ``node`` concerning ``cells``, the first ``home`` of
        them the cells it publishes in now (``Publish.home``).

        Returns:
            The subscribers to deliver it to, in a reproducible order, ``node`` excluded.
        """
        if cells:
            self._published_in(node, tuple(cells[:home]))
        targets = dict(self._wildcard)
        cell_subs = self._cell_subs
        for cell in cells:
            subs = cell_subs.get(cell)
            if subs:
                targets.update(subs)
        targets.pop(node, None)
        return targets

    def publish_split(
        self, node: str, cells: Sequence[Cell], home: int = 1
    ) -> tuple[dict[str, None], dict[str, None]]:
        """Route a publication whose home grew (``Publish.snapshot``), split in two.

        Returns:
            The subscribers that heard ``node``'s last home (full subscribers included)
            and the others, each in a reproducible order, ``node`` excluded.
        """
        before = set(self._wildcard)
        cell_subs = self._cell_subs
        for cell in self._homes.get(node, ()):
            subs = cell_subs.get(cell)
            if subs:
                before.update(subs)
        heard: dict[str, None] = {}
        fresh: dict[str, None] = {}
        for target in self.publish(node, cells, home):
            (heard if target in before else fresh)[target] = None
        return heard, fresh

    def home(self, node: str) -> tuple[Cell, ...]:
        """The cells ``node`` last published in (empty: it has not published in one)."""
        return self._homes.get(node, ())

    def __len__(self) -> int:
        """How many nodes the router holds any state for."""
        return len(self._subscriptions.keys() | self._homes.keys())

    def _published_in(self, node: str, home: tuple[Cell, ...]) -> None:
        old = self._homes.get(node, ())
        if old == home:
            return
        for cell in old:
            if cell not in home:
                self._drop_publisher(node, cell)
        self._homes[node] = home
        publishers_in = self._publishers_in
        for cell in home:
            publishers = publishers_in.get(cell)
            if publishers is None:
                publishers = publishers_in[cell] = {}
            publishers[node] = None

    def _drop_publisher(self, node: str, cell: Cell) -> None:
        publishers = self._publishers_in[cell]
        publishers.pop(node, None)
        if not publishers:
            del self._publishers_in[cell]

    def _drop_subscription(self, node: str) -> None:
        self._set_cells(node, self._subscriptions.pop(node, None), frozenset())
        self._wildcard.pop(node, None)

    def _set_cells(self, node: str, old: frozenset[Cell] | None, cells: frozenset[Cell]) -> None:
        """Move ``node`` from the cells of ``old`` to ``cells``.

        Only the difference is touched: a node staying in a cell keeps its place among
        that cell's subscribers, so delivery order (and a seeded run) does not change.
        """
        cell_subs = self._cell_subs
        if old:
            for cell in old - cells:
                leaving = cell_subs[cell]
                leaving.pop(node, None)
                if not leaving:
                    del cell_subs[cell]
        for cell in sorted(cells - old) if old else sorted(cells):
            subs = cell_subs.get(cell)
            if subs is None:
                subs = cell_subs[cell] = {}
            subs[node] = None
