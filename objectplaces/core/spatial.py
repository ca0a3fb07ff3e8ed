"""A uniform-grid index of node positions, a running maximum of a numeric property, and
the cells a node publishes in (its home, §5).

The engine keeps one grid per position property that declarative definitions use. A
query for the nodes within ``r`` of a point visits only the cells that square touches,
so resolving or re-checking a group costs about O(neighbours). When the square would
span more cells than there are nodes, the query scans the nodes instead.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

__all__ = [
    "MAX_HOME_CELLS",
    "MAX_SCOPE_CELLS",
    "GridIndex",
    "RunningMax",
    "footprint_bounds",
    "footprint_cells",
    "home_cells",
]

Cell = tuple[int, int]


class GridIndex:
    """Node positions bucketed in square cells of side ``cell_size``."""

    def __init__(self, cell_size: float) -> None:
        if not cell_size > 0:
            raise ValueError(f"cell_size must be > 0, got {cell_size!r}")
        self.cell_size = cell_size
        self._cells: dict[Cell, set[str]] = {}
        self._where: dict[str, tuple[float, float, Cell]] = {}

    def __len__(self) -> int:
        return len(self._where)

    def cell_of(self, x: float, y: float) -> Cell:
        """The cell holding point (x, y)."""
        return (math.floor(x / self.cell_size), math.floor(y / self.cell_size))

    def place(self, node: str, x: float, y: float) -> None:
        """Record (or move) ``node`` at (x, y)."""
        cell = self.cell_of(x, y)
        old = self._where.get(node)
        if old is not None and old[2] != cell:
            self._discard_from(old[2], node)
        if old is None or old[2] != cell:
            self._cells.setdefault(cell, set()).add(node)
        self._where[node] = (x, y, cell)

    def remove(self, node: str) -> None:
        """Forget ``node`` (no error if unknown)."""
        old = self._where.pop(node, None)
        if old is not None:
            self._discard_from(old[2], node)

    def _discard_from(self, cell: Cell, node: str) -> None:
        bucket = self._cells[cell]
        bucket.discard(node)
        if not bucket:
            del self._cells[cell]

    def near(self, x: float, y: float, radius: float) -> Iterator[str]:
        """Every node whose cell the square of half-side ``radius`` around (x, y) touches.

        A superset of the nodes within ``radius``: callers still test the definition.
        """
        if not math.isfinite(radius):
            yield from self._where
            return
        # A hair wider than asked, so float rounding at a cell border never hides a node.
        radius = radius * (1.0 + 1e-9) + 1e-9
        x0, y0 = self.cell_of(x - radius, y - radius)
        x1, y1 = self.cell_of(x + radius, y + radius)
        if (x1 - x0 + 1) * (y1 - y0 + 1) > len(self._cells):
            for cell, bucket in self._cells.items():
                if x0 <= cell[0] <= x1 and y0 <= cell[1] <= y1:
                    yield from bucket
            return
        cells = self._cells
        for cx in range(x0, x1 + 1):
            for cy in range(y0, y1 + 1):
                found = cells.get((cx, cy))
                if found:
                    yield from found


class RunningMax:
    """The maximum of one numeric value per node, recomputed only when it may have fallen."""

    def __init__(self) -> None:
        self._values: dict[str, float] = {}
        self._max = 0.0
        self._stale = False

    def set(self, node: str, value: float) -> None:
        """Record ``node``'s value."""
        old = self._values.get(node)
        self._values[node] = value
        if value >= self._max:
            self._max = value
        elif old is not None and old >= self._max:
            self._stale = True

    def remove(self, node: str) -> None:
        """Forget ``node``'s value."""
        old = self._values.pop(node, None)
        if old is not None and old >= self._max:
            self._stale = True

    @property
    def value(self) -> float:
        """The current maximum (0.0 with no values)."""
        if self._stale:
            self._max = max(self._values.values(), default=0.0)
            self._stale = False
        return self._max


def home_cells(
    position: tuple[float, float], radius: Any, margin: float | None, cell_size: float
) -> tuple[Cell, ...]:
    """Where a node at ``position`` publishes: its own cell (``margin`` None), or every
    cell of the square of half-side ``radius + margin`` around it (its footprint), in
    row order. A radius that is not a number counts as 0.

    Senders and receivers compute it alike: a receiver tells from a sender's properties
    whether the sender still publishes where it listens (``PropertyView.in_scope``).
    """
    x, y = position
    if margin is None:
        return ((math.floor(x / cell_size), math.floor(y / cell_size)),)
    x0, y0, x1, y1 = footprint_bounds(position, radius, margin, cell_size)
    return tuple((cx, cy) for cx in range(x0, x1 + 1) for cy in range(y0, y1 + 1))


MAX_HOME_CELLS = 4096
"""The most cells a footprint may cover: a node's own radius is refused beyond it."""

MAX_SCOPE_CELLS = 65536
"""The most cells an interest square may cover (a node with a larger one is refused)."""


def footprint_cells(radius: float, margin: float, cell_size: float) -> int:
    """How many cells a footprint of ``radius`` plus ``margin`` covers at most."""
    side = math.floor(2 * (radius + margin) / cell_size) + 2
    return side * side


def footprint_bounds(
    position: tuple[float, float], radius: Any, margin: float, cell_size: float
) -> tuple[int, int, int, int]:
    """The first and last cell columns and rows of a footprint (``home_cells``)."""
    x, y = position
    half = margin + (float(radius) if isinstance(radius, int | float) else 0.0)
    return (
        math.floor((x - half) / cell_size),
        math.floor((y - half) / cell_size),
        math.floor((x + half) / cell_size),
        math.floor((y + half) / cell_size),
    )
