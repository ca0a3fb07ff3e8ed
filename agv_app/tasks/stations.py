"""Which stations of a floor take part in tasks, and the node that runs them.

A task is picked up at a pick station (``pick`` or ``pickdrop``) and dropped at a drop
station (``drop`` or ``pickdrop``), both among the stations that reach each other
(``Layout.usable_stations``). Both fleets run every pick station's task assignment on
one transport base, :data:`BASE_ID` (:class:`~agv_app.tasks.desk.TaskDesk`).
"""

from __future__ import annotations

from collections.abc import Iterable

from agv_app.layout.graph import Layout

__all__ = ["BASE_ID", "drop_stations", "pick_stations", "require_task_stations"]


BASE_ID = "base"
"""Node id of a fleet's transport base.

One node for the stations, not one per station: every node hears every AGV it may
auction a task to (all of them, once the range widens) and every winner until its task
is done, so each station node heard every AGV, and at 50 AGVs on the demo warehouse the
18 stations were more than a quarter of the listeners of every AGV's moves and beats
(docs/fleet.md, "The transport base")."""


def pick_stations(layout: Layout) -> list[str]:
    """Ids of the usable stations where loads are picked up (``pick``, ``pickdrop``)."""
    return [s for s in layout.usable_stations() if layout.station(s).kind in ("pick", "pickdrop")]


def drop_stations(layout: Layout) -> list[str]:
    """Ids of the usable stations where loads are dropped (``drop``, ``pickdrop``)."""
    return [s for s in layout.usable_stations() if layout.station(s).kind in ("drop", "pickdrop")]


def require_task_stations(layout: Layout) -> None:
    """Check that tasks can be made on ``layout``: a pick station and a drop station
    apart from it, both among the stations that reach each other.

    Raises:
        ValueError: there are none; the message names the usable stations and the ones
            that cannot reach them.
    """
    picks, drops = pick_stations(layout), drop_stations(layout)
    if any(d != p for p in picks for d in drops):
        return

    def named(ids: Iterable[str]) -> str:
        return ", ".join(f"{s!r} ({layout.station(s).kind})" for s in ids) or "none"

    cut_off = layout.unreachable_stations()
    raise ValueError(
        f"layout {layout.name!r} cannot host a fleet: a task needs a pick station and "
        "another drop station that reach each other; the largest group of stations that "
        f"reach each other is {named(layout.usable_stations())}"
        + (f", cut off from it: {named(cut_off)}" if cut_off else "")
    )
