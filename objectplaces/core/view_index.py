"""The view's index for group resolution (docs/protocol.md §6).

A uniform grid per position property that a declarative group definition names, and a
running maximum per radius property, so that resolving a group costs about
O(neighbours) instead of O(view). Each is built the first time a definition asks for
it, from the properties held then, and kept up to date by the view from then on.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from typing import Any

from objectplaces.core.groups import DefinitionLike, GroupDefinition
from objectplaces.core.spatial import GridIndex, RunningMax

__all__ = ["ViewIndex"]

log = logging.getLogger("objectplaces")


class ViewIndex:
    """The grids and maxima over one view's properties.

    Args:
        props: the view's node -> properties (read when an index is built).
        cell_size: the grids' cell side.
    """

    __slots__ = ("_cell_size", "_props", "indexes", "maxima")

    def __init__(self, props: Mapping[str, Mapping[str, Any]], cell_size: float) -> None:
        self._props = props
        self._cell_size = cell_size
        #: Position property -> its grid (read by the view on every update).
        self.indexes: dict[str, GridIndex] = {}
        #: Radius property -> its running maximum (read by the view on every update).
        self.maxima: dict[str, RunningMax] = {}

    def __len__(self) -> int:
        return sum(len(index) for index in self.indexes.values())

    def set(self, node: str, name: str, value: Any) -> None:
        """``node``'s property ``name`` is now ``value`` (for a name that is indexed)."""
        index = self.indexes.get(name)
        if index is not None:
            if isinstance(value, tuple | list) and len(value) == 2:
                index.place(node, float(value[0]), float(value[1]))
            else:
                index.remove(node)
        maximum = self.maxima.get(name)
        if maximum is not None:
            maximum.set(node, float(value) if isinstance(value, int | float) else 0.0)

    def remove(self, node: str) -> None:
        """``node`` left the view."""
        for index in self.indexes.values():
            index.remove(node)
        for maximum in self.maxima.values():
            maximum.remove(node)

    def candidates(self, definition: DefinitionLike, own: Mapping[str, Any]) -> Iterable[str]:
        """Nodes that may satisfy ``definition``: the index's neighbours, or everyone.

        Only a declarative definition states its reach; any other callable is opaque
        and must be tried on every node in the view, and so is a definition whose
        reach fails (a subclass's bug must cost speed, never the node: logged).
        """
        if isinstance(definition, GroupDefinition):
            try:
                reach = definition.reach(own, self._max_of)
            except Exception:
                log.exception("group definition %r: reach failed; trying every node", definition)
                return self._props.keys()
            if reach is not None:
                position = own.get(reach.position) if reach.centre is None else reach.centre
                if not isinstance(position, tuple | list) or len(position) != 2:
                    return ()
                index = self._index_for(reach.position)
                return index.near(float(position[0]), float(position[1]), reach.radius)
        return self._props.keys()

    def _index_for(self, position: str) -> GridIndex:
        index = self.indexes.get(position)
        if index is None:
            index = self.indexes[position] = GridIndex(self._cell_size)
            for node, props in self._props.items():
                value = props.get(position)
                if isinstance(value, tuple | list) and len(value) == 2:
                    index.place(node, float(value[0]), float(value[1]))
        return index

    def _max_of(self, name: str) -> float:
        maximum = self.maxima.get(name)
        if maximum is None:
            maximum = self.maxima[name] = RunningMax()
            for node, props in self._props.items():
                value = props.get(name)
                maximum.set(node, float(value) if isinstance(value, int | float) else 0.0)
        return maximum.value
