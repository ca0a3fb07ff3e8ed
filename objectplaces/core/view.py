"""The property view: what one node knows of the others (docs/protocol.md §2, §5, §6).

Four concerns share one set of keys (the other nodes' ids), which is why they live in
one part and are forgotten together:

* **values**: per node, per property, the value with the highest sequence number seen.
  Updates are unreliable and may arrive reordered or twice; "newest wins" per property
  (not per frame) because a republication carries every property while a delta carries
  only some, and an old full frame must not undo a newer delta.
* **liveness**: when each node was last heard, by any frame (property, beat or
  channel), and which rest it may take (``RestGrants``). The machine asks for the
  silent nodes and decides what departure means. A beat also says which publication
  was the sender's latest: holding an older one, the view asks for a snapshot. A node
  heard by its channels alone for a whole failure timeout (no property, no beat) is
  alive, but its properties no longer reach us: it moved out of our cells and the
  publication that said so was lost. The machine asks for those too (``stale``), and
  the snapshot that answers shows where it went.
* **the index** (§6, ``ViewIndex``): grids and maxima over the values, so that
  resolving a group costs about O(neighbours) instead of O(view).
* **the scope** (§5): under scoped dissemination the node hears only the cells it
  subscribes to. A node seen moving out of those cells is forgotten at once, because
  no later update would ever correct its stale position.
* **completeness** (§5): a node heard only in deltas may be missing properties that
  did not change lately (its hull length, say: then ``circles_overlap`` takes it for a
  point and misses a true member). Until a snapshot of it arrives, the view asks it
  for one, at most once per ``SNAPSHOT_RETRY``; with or without a heartbeat, a node
  newly heard is complete within one round trip.

The view hands out read-only mappings (``mapping``): callers may keep and read them.

Group definitions are application code: the view runs them, but one that raises is
logged, counted (``definition_errors``) and treated as "no match", so a bad definition
costs its own session, never the node.

A property check (``set_check``, application code too) may refuse a peer's value that
cannot be true: it is not taken, and counted per peer like a bad frame. A check that
raises lets the value through (counted): refusing would blind the node.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from types import MappingProxyType
from typing import Any, Final

from objectplaces.core import codec
from objectplaces.core.groups import DefinitionLike
from objectplaces.core.messages import PropertyRequest, PropertyUpdate
from objectplaces.core.observers import Observers
from objectplaces.core.plumbing import Plumbing
from objectplaces.core.rest import RestGrants
from objectplaces.core.spatial import footprint_bounds
from objectplaces.core.values import POSITION, RADIUS
from objectplaces.core.view_index import ViewIndex

__all__ = ["SNAPSHOT_RETRY", "Cell", "PropertyCheck", "PropertyView", "Refuse"]

log = logging.getLogger("objectplaces")

Cell = tuple[int, int]
PropertyCheck = Callable[[str, str, Any, float], bool]
"""``check(node_id, name, value, now)``: whether a peer's new value may be true."""
Refuse = Callable[[str, str, str, float], None]
"""``refuse(node_id, reason, detail, now)``: count and log a refused value."""

_REQUEST: Final = codec.encode(PropertyRequest())

SNAPSHOT_RETRY: Final = 1.0
"""Seconds before an incomplete node is asked for a snapshot again (the first ask, and
the answer, cost one round trip; a lost one is repaired by the next delta after this)."""


class PropertyView:
    """The latest known properties of every other node this node hears.

    Args:
        plumbing: the node's id (for log lines), cell size (of the index and the
            scope), and the outbox counters and snapshot requests go to.
        observers: told of every changed property.
    """

    __slots__ = (
        "_asked",
        "_cell_size",
        "_check",
        "_complete",
        "_footprint_margin",
        "_fresh",
        "_heard",
        "_index",
        "_node_id",
        "_observers",
        "_outbox",
        "_props",
        "_proxies",
        "_readonly",
        "_refuse",
        "_resting",
        "_scope",
        "_scope_bounds",
        "_seqs",
        "_tops",
        "scoped",
    )

    def __init__(self, plumbing: Plumbing, *, observers: Observers) -> None:
        self._node_id = plumbing.node_id
        self._cell_size = plumbing.config.cell_size
        self._footprint_margin = plumbing.config.footprint_margin
        self._outbox = plumbing.outbox
        self._observers = observers
        self._props: dict[str, dict[str, Any]] = {}
        # One read-only proxy per node, made once: handing out the view costs O(1).
        self._proxies: dict[str, Mapping[str, Any]] = {}
        self._readonly: Mapping[str, Mapping[str, Any]] = MappingProxyType(self._proxies)
        # Per node, per property, the seq it was last set at; a bare int: every property
        # of the node at that seq (after a heartbeat that changed nothing: no dict to make).
        self._seqs: dict[str, dict[str, int] | int] = {}
        self._tops: dict[str, int] = {}  # per node, the highest seq it has in ``_seqs``
        self._heard: dict[str, float] = {}
        self._fresh: dict[str, float] = {}  # when each node's properties or beats came
        self._resting = RestGrants(plumbing.config)  # nodes at rest (§2)
        self._index = ViewIndex(self._props, self._cell_size)
        self._scope: frozenset[Cell] | None = None
        self._scope_bounds = (0, 0, -1, -1)  # first and last column and row of the scope
        self._complete: set[str] = set()  # nodes heard in a snapshot since they came in
        self._asked: dict[str, float] = {}  # when each incomplete node was last asked
        #: Whether this node hears only some cells (a plain attribute: read per update).
        self.scoped = False
        self._check: PropertyCheck | None = None
        self._refuse: Refuse | None = None

    def set_check(self, check: PropertyCheck | None, refuse: Refuse) -> None:
        """Check each changed value of a peer first (None: none); refused ones go to ``refuse``."""
        self._check = check
        self._refuse = refuse

    # ------------------------------------------------------------------ reading

    @property
    def mapping(self) -> Mapping[str, Mapping[str, Any]]:
        """Node id -> its properties; read-only, and live (copy it to keep a snapshot)."""
        return self._readonly

    def __contains__(self, node: object) -> bool:
        return node in self._props

    def footprint(self) -> dict[str, int]:
        """Sizes of the per-node tables (bounded by the nodes heard, and failure detection)."""
        return {
            "view": len(self._props),
            "heard": len(self._heard),
            "resting": len(self._resting),
            "asked": len(self._asked),
            "indexed": len(self._index),
        }

    def props_of(self, node: str) -> Mapping[str, Any] | None:
        """``node``'s properties (read-only), or None when it is not in the view."""
        return self._proxies.get(node)

    def last_heard(self, node: str) -> float | None:
        """When ``node`` was last heard, by any frame (None: not at all, or forgotten)."""
        return self._heard.get(node)

    def knows(self, node: str) -> bool:
        """Whether ``node`` is in the view or was heard from at all."""
        return node in self._props or node in self._heard

    def silent_since(self, cutoff: float, *, stale: bool = False) -> list[str]:
        """Nodes last heard at or before ``cutoff``, sorted (never in set order); a node
        at rest only once it is silent for as much longer as its rest allows. With
        ``stale``: nodes whose last property or beat came by then (heard since, if at
        all, by their channels alone)."""
        resting, times = self._resting, self._fresh if stale else self._heard
        return sorted(
            n
            for n, heard in times.items()
            if heard <= cutoff and (not resting or heard + resting.extra(n) <= cutoff)
        )

    # ------------------------------------------------------------------ updating

    def heard(self, node: str, now: float) -> None:
        """``node`` sent something at ``now``: it is alive."""
        self._heard[node] = now

    def beat(self, source: str, seq: int, now: float, rest: float | None = None) -> None:
        """Take a beat from ``source`` at ``now``: its latest publication was ``seq``;
        ``rest``: it is at rest and beats that often, or (0) its rest ended; None: no
        news of its rest (§2).

        A node in the view is heard; one whose latest publication we missed (we hold
        only older numbers), or that we do not hold whole, is asked for a snapshot, at
        most once per ``SNAPSHOT_RETRY``. A node not in the view is asked each time and
        nothing of it is kept (§8: no frame makes state appear; its beats come once an
        interval). A beat never adds a node to the view or to the liveness table: only
        its properties do.
        """
        if source not in self._props:
            self._outbox.send(source, _REQUEST, "property")
            return
        self._heard[source] = self._fresh[source] = now
        if rest is not None:
            self._resting.beat(source, rest)
        if seq > self._tops.get(source, -1) or source not in self._complete:
            self.ask_snapshot(source, now)

    def apply(self, source: str, update: PropertyUpdate, now: float) -> bool:
        """Take a property update from ``source`` at ``now`` (so it is heard, too); tell
        the property observers of each change; return whether anything changed.

        The hottest path of a large network: every delivered update comes through here,
        so locals are bound once and nothing is allocated for an unchanged value.
        """
        self._heard[source] = self._fresh[source] = now
        if self._resting and not update.full:  # a change: usual beats follow (§2)
            self._resting.ended(source)
        props = self._props.get(source)
        if props is None:
            props = self._props[source] = {}
            self._proxies[source] = MappingProxyType(props)
            self._seqs[source] = {}
        seq = update.seq
        tops = self._tops
        top = tops.get(source, -1)
        complete = self._complete
        if update.full:
            if source not in complete:
                complete.add(source)
                self._asked.pop(source, None)
        else:
            if seq > top + 1 and source in complete:
                # Publications are numbered without gaps (own.py): one was lost, and
                # what it changed may never be sent again. Held, but no longer whole.
                complete.discard(source)
                self._outbox.count("publications_missed")
            if source not in complete:
                self.ask_snapshot(source, now)
        values = update.values
        if seq > top:
            tops[source] = seq
            if props == values:
                # Newer than every property held and equal to them all (a heartbeat of a
                # node standing still): only the sequence numbers move, set in one pass.
                self._seqs[source] = seq
                return False
        seqs = self._seqs[source]
        if isinstance(seqs, int):
            # Every property was set at that one seq (``props`` and ``_seqs`` hold the
            # same names): spell it out before some change and others do not.
            seqs = self._seqs[source] = dict.fromkeys(props, seqs)
        changed = False
        index, observers = self._index, self._observers
        indexes, maxima = index.indexes, index.maxima
        check = self._check
        for name, value in values.items():
            if seq <= seqs.get(name, -1):
                continue
            seqs[name] = seq
            if name in props and props[name] == value:
                continue
            if check is not None and not self._passes(check, source, name, value, now):
                continue
            props[name] = value
            changed = True
            if name in indexes or name in maxima:
                index.set(source, name, value)
            if observers.watching_properties:
                observers.property_changed(source, name, value)
        return changed

    def _passes(self, check: PropertyCheck, source: str, name: str, value: Any, now: float) -> bool:
        try:
            if check(source, name, value, now):
                return True
        except Exception:
            log.exception(
                "node %s: the property check failed on %s of %s", self._node_id, name, source
            )
            self._outbox.count("property_check_errors")
            return True
        if self._refuse is not None:
            self._refuse(source, "refused_implausible", f"{name}={value!r}", now)
        return False

    def ask_snapshot(self, node: str, now: float) -> None:
        """Ask ``node`` for a snapshot: it is heard only in deltas, so some of its
        properties may be missing (§5), or by its channels alone (stale). Not again
        within ``SNAPSHOT_RETRY``: the answer may simply still be on its way."""
        asked = self._asked.get(node)
        if asked is None or now - asked >= SNAPSHOT_RETRY:
            self._asked[node] = now
            self._outbox.send(node, _REQUEST, "property")

    def forget(self, node: str, *, keep_liveness: bool = False) -> Mapping[str, Any] | None:
        """Drop what is known of ``node`` (but when it was last heard, with
        ``keep_liveness``); return its last properties (None if unknown)."""
        last = self._props.pop(node, None)
        self._proxies.pop(node, None)
        self._seqs.pop(node, None)
        self._tops.pop(node, None)
        if not keep_liveness:
            self._heard.pop(node, None)
            self._resting.ended(node)
        self._fresh.pop(node, None)
        self._complete.discard(node)
        self._asked.pop(node, None)
        self._index.remove(node)
        return last

    # ------------------------------------------------------------------ scope (§5)

    def set_scope(self, cells: frozenset[Cell]) -> list[str]:
        """Hear only ``cells`` from now on (a rectangle of cells, as a subscription is);
        return the nodes now out of scope, sorted."""
        self._scope = cells
        self._scope_bounds = (
            (
                min(c[0] for c in cells),
                min(c[1] for c in cells),
                max(c[0] for c in cells),
                max(c[1] for c in cells),
            )
            if cells
            else (0, 0, -1, -1)
        )
        self.scoped = True
        return sorted(n for n in self._props if not self.in_scope(n))

    def in_scope(self, node: str) -> bool:
        """Whether ``node`` still publishes where this node hears: its cell (or, with
        footprints, a cell of its footprint) lies in the scope, judged from its last
        properties as it judged them itself (``own.home_cells``).

        A node without a position stays in scope: nothing says it is elsewhere.
        """
        if self._scope is None:
            return True
        props = self._props[node]
        position = props.get(POSITION)
        if not isinstance(position, tuple):
            return True
        size = self._cell_size
        margin = self._footprint_margin
        if margin is None:
            return (math.floor(position[0] / size), math.floor(position[1] / size)) in self._scope
        x0, y0, x1, y1 = footprint_bounds(position, props.get(RADIUS), margin, size)
        sx0, sy0, sx1, sy1 = self._scope_bounds
        return x0 <= sx1 and sx0 <= x1 and y0 <= sy1 and sy0 <= y1

    # ------------------------------------------------------------------ groups (§6)

    def candidates(self, definition: DefinitionLike, own: Mapping[str, Any]) -> Iterable[str]:
        """Nodes that may satisfy ``definition``: the index's neighbours, or everyone."""
        return self._index.candidates(definition, own)

    def matches(
        self, definition: DefinitionLike, own: Mapping[str, Any], node: str, sid: str = ""
    ) -> bool:
        """Whether ``node`` satisfies ``definition`` now (False when it is not in view).

        Definitions get the view's own dicts (typed ``Mapping``), not read-only proxies:
        a proxy costs every property lookup of every evaluation, a measurable share of a
        large network's CPU (bench/groups.py). A definition is a predicate; the type
        already says it must not write.
        """
        props = self._props.get(node)
        if props is None:
            return False
        try:
            return bool(definition(own, props))
        except Exception:
            log.exception("node %s: group definition of session %r raised", self._node_id, sid)
            self._outbox.count("definition_errors")
            return False

    def matching(
        self,
        definition: DefinitionLike,
        own: Mapping[str, Any],
        nodes: Sequence[str],
        sid: str = "",
    ) -> set[str]:
        """The nodes of ``nodes`` that satisfy ``definition`` now: ``matches`` for each,
        in one pass (a session that opens tries every node near it)."""
        props = self._props
        try:
            return {n for n in nodes if (p := props.get(n)) is not None and definition(own, p)}
        except Exception:
            # One of them raised: again one by one, each error logged and counted.
            return {n for n in nodes if self.matches(definition, own, n, sid)}

    def group(self, definition: DefinitionLike, own: Mapping[str, Any]) -> frozenset[str]:
        """Every node that satisfies ``definition`` now, from the view alone."""
        return frozenset(
            n for n in self.candidates(definition, own) if self.matches(definition, own, n)
        )
