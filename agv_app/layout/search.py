"""Graph searches of a layout: shortest paths and strongly connected components.

Both run over the directed arcs of the routing graph and are deterministic: arcs are
visited in a fixed order, and Dijkstra settles equal distances in point-id order.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from agv_app.geometry import XY

__all__ = ["Arc", "shortest_paths", "strong_components"]


@dataclass(frozen=True, slots=True)
class Arc:
    """A directed, drivable edge of the routing graph."""

    segment: str
    target: str
    length: float
    coords: tuple[XY, ...] = field(repr=False)  # from source to target, inclusive


def shortest_paths(
    arcs: Mapping[str, Sequence[Arc]], source: str
) -> tuple[dict[str, float], dict[str, tuple[str, str]]]:
    """Dijkstra from ``source``: distance to every reachable point, and each point's
    predecessor ``(point, segment)`` on its shortest route."""
    dist: dict[str, float] = {source: 0.0}
    prev: dict[str, tuple[str, str]] = {}
    done: set[str] = set()
    heap: list[tuple[float, str]] = [(0.0, source)]
    while heap:
        d, u = heapq.heappop(heap)
        if u in done:
            continue
        done.add(u)
        for arc in arcs[u]:
            nd = d + arc.length
            old = dist.get(arc.target)
            # Strictly shorter wins; on an exact tie the predecessor settled first
            # (lowest distance, then lowest id) is kept, so routes are reproducible.
            if old is None or nd < old:
                dist[arc.target] = nd
                prev[arc.target] = (u, arc.segment)
                heapq.heappush(heap, (nd, arc.target))
    return dist, prev


def strong_components(points: Iterable[str], arcs: Mapping[str, Sequence[Arc]]) -> dict[str, int]:
    """Strongly connected component number of every point (Kosaraju, iterative)."""
    points_list = list(points)
    order: list[str] = []
    seen: set[str] = set()
    for root in points_list:
        if root in seen:
            continue
        seen.add(root)
        stack: list[tuple[str, int]] = [(root, 0)]
        while stack:
            u, i = stack.pop()
            out = arcs[u]
            if i < len(out):
                stack.append((u, i + 1))
                v = out[i].target
                if v not in seen:
                    seen.add(v)
                    stack.append((v, 0))
            else:
                order.append(u)
    reverse: dict[str, list[str]] = {pid: [] for pid in points_list}
    for u, out in arcs.items():
        for arc in out:
            reverse[arc.target].append(u)
    comp: dict[str, int] = {}
    n = -1
    for root in reversed(order):
        if root in comp:
            continue
        n += 1
        comp[root] = n
        todo = [root]
        while todo:
            u = todo.pop()
            for v in reverse[u]:
                if v not in comp:
                    comp[v] = n
                    todo.append(v)
    return comp
