"""This node's own properties and how they are published (docs/protocol.md §2, §5).

A node updates only its own properties. Updates made in the same instant are
*coalesced*: ``set`` only marks a name dirty, and the dirty names leave as one frame
when the driver next drains the machine (``take_update``). That is why a position and a
hull length set together cost one ~14-byte compact frame (§1), not two.

Publications are numbered 1, 2, 3 ... per node, without gaps; receivers keep per
property the highest number seen. A snapshot sent to one peer (``full_update_for``)
carries the number of the latest publication: its values are that publication's, plus
at most the changes about to leave in the next one, which carries them again. So a
receiver that holds publication n and then hears a delta numbered above n + 1 knows it
missed one, and asks for a snapshot (§2). A frame that carries every property is
marked a *snapshot*: a receiver holding a node from deltas only asks for one (§5).

A node that has published nothing for a beat interval sends a *beat* instead (§2): the
number of its latest publication, so a receiver that missed the last one (it holds an
older number) asks for a snapshot.

Where a frame goes depends on dissemination (§5). Without an interest radius it is
broadcast. With one, it is published to the node's *home*: the cell it is in, or, with
a footprint margin, every cell within its own radius plus that margin. When the home
has just changed the frame goes to the cells left too, so their subscribers see the
new position (or the smaller circle), drop the node from their scope, and do not keep
a stale position forever (the trap DESIGN.md warns of). The subscription itself is the
square of cells that covers the interest radius around the node's position; it is
recomputed on every move but re-announced only when the square's bounds change.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from objectplaces.core import codec
from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import InvalidValueError, LocalProtocolError
from objectplaces.core.events import Broadcast, Output, Publish, Send
from objectplaces.core.messages import Beat, PropertyUpdate
from objectplaces.core.spatial import MAX_HOME_CELLS, MAX_SCOPE_CELLS, footprint_cells, home_cells
from objectplaces.core.values import (
    MAX_VALUE_SIZE,
    POSITION,
    RADIUS,
    check_plain,
    checked_position,
    checked_radius,
)

__all__ = ["OwnProperties"]

Cell = tuple[int, int]


class OwnProperties:
    """The node's own property values, the pending changes, and their routing.

    Args:
        config: the node's tunables (interest radius, footprint margin and cell size
            matter here).

    Raises:
        LocalProtocolError: a footprint margin that is not a number >= 0, or whose
            footprint alone would cover more than ``MAX_HOME_CELLS`` cells; an interest
            radius whose square would cover more than ``MAX_SCOPE_CELLS``.
    """

    __slots__ = (
        "_bounds",
        "_config",
        "_dirty",
        "_published_home",
        "_readonly",
        "_seq",
        "_sizes",
        "_snapshot",
        "_values",
        "pending",
    )

    def __init__(self, config: NodeConfig) -> None:
        margin = config.footprint_margin
        if margin is not None and not (
            isinstance(margin, int | float)
            and 0 <= margin < math.inf
            and footprint_cells(0.0, margin, config.cell_size) <= MAX_HOME_CELLS
        ):
            raise LocalProtocolError(
                f"footprint_margin must be a number >= 0 whose footprint fits "
                f"{MAX_HOME_CELLS} cells of {config.cell_size:g} m, got {margin!r}"
            )
        radius = config.interest_radius
        if radius is not None and footprint_cells(radius, 0.0, config.cell_size) > MAX_SCOPE_CELLS:
            raise LocalProtocolError(
                f"interest_radius {radius:g} m would subscribe to more than {MAX_SCOPE_CELLS} "
                f"cells of {config.cell_size:g} m: a larger cell_size, or no radius"
            )
        self._config = config
        self._values: dict[str, Any] = {}
        self._sizes: dict[str, int] = {}  # encoded size of each generic property
        self._readonly: Mapping[str, Any] = MappingProxyType(self._values)
        self._dirty: dict[str, Any] = {}
        self._seq = 0  # the number of the latest publication
        # The encoded snapshot of the values at ``_seq``, made at the first asking and
        # dropped when a value or the sequence number changes: at start every node
        # sends one to every node it hears, the same bytes each time.
        self._snapshot: bytes | None = None
        self._published_home: tuple[Cell, ...] = ()  # where the last publication went
        self._bounds: tuple[int, int, int, int] | None = None
        #: Whether changes wait to be published (an attribute: the driver asks per drain).
        self.pending = False

    @property
    def values(self) -> Mapping[str, Any]:
        """The current values (read-only, live)."""
        return self._readonly

    @property
    def unwrapped(self) -> Mapping[str, Any]:
        """The current values without the read-only wrapper, for group definitions on
        the hot path (see ``PropertyView.matches``); never hand this to the application."""
        return self._values

    def set(self, name: str, value: Any) -> Any:
        """Record a new value; return it as peers will see it (rounded like the wire).

        Nothing is recorded when the value is refused (values.py has the rules).

        Raises:
            InvalidValueError: a name that is not a non-empty string; a position that is
                not two finite numbers; a hull length that is not a finite number >= 0,
                or whose footprint would cover too many cells (``MAX_HOME_CELLS``);
                a value nested too deep; a value (or all values together) too large.
            NotPlainDataError: a value that is not plain data.
        """
        if not isinstance(name, str) or not name:
            raise InvalidValueError(f"property name must be a non-empty string, got {name!r}")
        if name == POSITION:
            value = codec.normalise_property(name, checked_position(value))
        elif name == RADIUS:
            value = codec.normalise_property(name, checked_radius(value))
            self._check_footprint(value)
        else:
            check_plain(value, f"property {name!r}")
            size = len(codec.encode_value(value))
            if size > MAX_VALUE_SIZE:
                raise InvalidValueError(
                    f"property {name!r} takes {size} bytes, over the limit of {MAX_VALUE_SIZE}"
                )
            # Every republication carries every property: all together must fit a frame.
            total = sum(self._sizes.values()) - self._sizes.get(name, 0) + size
            if total > self._config.max_frame // 2:
                raise InvalidValueError(
                    f"property {name!r} would bring this node's properties to {total} bytes, "
                    f"over half the frame limit ({self._config.max_frame // 2})"
                )
            self._sizes[name] = size
        self._values[name] = value
        self._snapshot = None
        self._dirty[name] = value
        self.pending = True
        return value

    def _check_footprint(self, radius: float) -> None:
        """Refuse a radius whose footprint would cover more than ``MAX_HOME_CELLS``."""
        config = self._config
        margin = config.footprint_margin
        if margin is None or config.interest_radius is None:
            return
        cells = footprint_cells(radius, margin, config.cell_size)
        if cells > MAX_HOME_CELLS:
            raise InvalidValueError(
                f"{RADIUS!r} {radius:g} m would publish to {cells} cells of "
                f"{config.cell_size:g} m, over the limit of {MAX_HOME_CELLS}"
            )

    def take_update(self) -> Output | None:
        """The frame that publishes every pending change (None when nothing is pending).

        It is a snapshot (every value, marked full) when it carries everything anyway.
        When it goes to a cell this node was not publishing in, that cell's subscribers
        may never have heard of it and must not hold half of it (§5): they get it as a
        snapshot, the nodes that heard the last publication as a delta.
        """
        if not self._dirty:
            return None
        dirty, self._dirty = self._dirty, {}
        self.pending = False
        home = self._home()
        grows = self._home_grows(home)
        if len(dirty) == len(self._values) or (grows and not self._published_home):
            return self._publication(self._values, home, full=True)
        return self._publication(dirty, home, full=False, fresh=grows)

    def _home_grows(self, home: tuple[Cell, ...]) -> bool:
        """Whether a publication to ``home`` reaches a cell the last one did not."""
        if self._config.interest_radius is None:
            return False
        published = self._published_home
        return home != published and not set(home).issubset(published)

    def republish(self) -> Output | None:
        """The heartbeat: a snapshot of every value (pending changes included)."""
        self._dirty = {}
        self.pending = False
        return self._publication(self._values, self._home(), full=True) if self._values else None

    def beat(self, rest: float | None = None) -> Output | None:
        """The liveness beat: the number of the latest publication (and ``rest``, the
        beat interval of a node at rest), to where the publications go (None when this
        node has no properties: it publishes nothing, so it has never been heard of by
        its properties either)."""
        if not self._values:
            return None
        data = codec.encode(Beat(self._seq, rest))
        home = self._published_home or self._home()
        if self._config.interest_radius is None or not home:
            return Broadcast(data, "beat")
        return Publish(home, data, "beat", len(home))

    def beat_to(self, peer: str, rest: float) -> Send | None:
        """A beat of a node at rest for one peer (None when this node has no properties)."""
        if not self._values:
            return None
        return Send(peer, codec.encode(Beat(self._seq, rest)), "beat")

    def full_update_for(self, peer: str) -> Send | None:
        """A snapshot for one peer (a newcomer, a new subscriber of our cell, an asker)."""
        if not self._values:
            return None
        return Send(peer, self._snapshot_data(), "property")

    def _snapshot_data(self) -> bytes:
        """Every value at the latest publication's number, encoded (kept until changed)."""
        data = self._snapshot
        if data is None:
            update = PropertyUpdate(self._seq, dict(self._values), full=True)
            data = self._snapshot = codec.encode(update)
        return data

    def _publication(
        self, values: Mapping[str, Any], home: tuple[Cell, ...], *, full: bool, fresh: bool = False
    ) -> Output:
        """One publication to ``home`` (``_home()``); ``fresh``: the home grew, so it
        carries a snapshot too."""
        self._seq += 1
        data = codec.encode(PropertyUpdate(self._seq, dict(values), full))
        # A full publication of every value is that number's snapshot, byte for byte.
        self._snapshot = data if full and values is self._values else None
        if self._config.interest_radius is None or not home:
            return Broadcast(data, "property")
        old = self._published_home
        cells = home
        if old and old != home:
            kept = set(home)
            cells = home + tuple(c for c in old if c not in kept)
        self._published_home = home
        snapshot = None
        if fresh:
            snapshot = self._snapshot_data()
        return Publish(cells, data, "property", len(home), snapshot)

    def _position(self) -> tuple[float, float] | None:
        position = self._values.get(POSITION)
        return position if isinstance(position, tuple) else None

    def _home(self) -> tuple[Cell, ...]:
        """The cells this node publishes in now (none without a position)."""
        position = self._position()
        if position is None:
            return ()
        config = self._config
        return home_cells(
            position, self._values.get(RADIUS), config.footprint_margin, config.cell_size
        )

    def footprint(self) -> dict[str, int]:
        """Sizes of what this node keeps of its own properties."""
        return {"own": len(self._values), "pending": len(self._dirty)}

    def new_subscription(self) -> frozenset[Cell] | None:
        """The cells to subscribe to, when they changed since last asked (else None)."""
        radius = self._config.interest_radius
        position = self._position()
        if radius is None or position is None:
            return None
        size = self._config.cell_size
        x, y = position
        bounds = (
            math.floor((x - radius) / size),
            math.floor((y - radius) / size),
            math.floor((x + radius) / size),
            math.floor((y + radius) / size),
        )
        if bounds == self._bounds:
            return None
        self._bounds = bounds
        x0, y0, x1, y1 = bounds
        return frozenset((cx, cy) for cx in range(x0, x1 + 1) for cy in range(y0, y1 + 1))
