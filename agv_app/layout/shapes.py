"""Floors a plant engineer draws by hand: a crossing of two-way lanes, a lane between two
dead-end areas, halls joined by a door, a lane with a lay-by.

Each is a small layout in one shape, with its stations and parking spots where a plant
puts them: at the ends of the arms, in the areas, along the halls' lanes. The
benchmark of hard layouts (``bench/hard_layouts.py``) names one of each; the property
tests and the floor runner draw them at random sizes. Spurs are two-way and end in a
dead end; every station and parking spot is at the end of one.
"""

from __future__ import annotations

from collections.abc import Sequence

from agv_app.layout.builder import LayoutBuilder
from agv_app.layout.elements import Segment
from agv_app.layout.graph import Layout

__all__ = ["crossing", "halls", "lane_between_areas", "lay_by"]

_ARMS = (("n", 0.0, 1.0), ("e", 1.0, 0.0), ("s", 0.0, -1.0), ("w", -1.0, 0.0))


def crossing(
    arms: Sequence[float] = (15.0, 15.0, 15.0, 15.0),
    *,
    spur_m: float = 3.0,
    further_m: float = 4.0,
    parking: int = 2,
    name: str = "crossing",
) -> Layout:
    """Two-way lanes that cross at one point: arms north, east, south and west of the
    given lengths (three arms: a T). At each arm's end a station spur to its left, and
    the lane goes on ``further_m`` to ``parking`` parking spurs (one: to the left, two:
    both sides).

    Raises:
        ValueError: fewer than two or more than four arms, or ``parking`` not 0, 1 or 2.
    """
    if not 2 <= len(arms) <= 4:
        raise ValueError(f"a crossing has 2 to 4 arms, got {len(arms)}")
    if parking not in (0, 1, 2):
        raise ValueError(f"parking per arm is 0, 1 or 2, got {parking!r}")
    b = LayoutBuilder()
    b.point("c", 0.0, 0.0)
    for (arm, dx, dy), length in zip(_ARMS, arms, strict=False):
        left = (-dy, dx)
        end = b.point(arm, dx * length, dy * length)
        b.chain(["c", end], bidirectional=True)
        station = b.point(
            f"{arm}-st", dx * length + left[0] * spur_m, dy * length + left[1] * spur_m
        )
        b.spur(end, station, f"station-{arm}", "pickdrop")
        if not parking:
            continue
        far = b.point(f"{arm}2", dx * (length + further_m), dy * (length + further_m))
        b.chain([end, far], bidirectional=True)
        for side, sign in (("l", 1.0), ("r", -1.0))[:parking]:
            spot = b.point(
                f"{arm}-p{side}",
                dx * (length + further_m) + sign * left[0] * spur_m,
                dy * (length + further_m) + sign * left[1] * spur_m,
            )
            b.spur(far, spot, f"park-{arm}{side}", "parking")
    return Layout(b.points, b.segments, b.stations, name=name)


def lane_between_areas(
    lane_m: float = 40.0,
    *,
    spur_m: float = 4.0,
    stations: tuple[int, int] = (1, 1),
    parking: tuple[int, int] = (2, 2),
    name: str = "lane-between-areas",
) -> Layout:
    """One two-way lane of ``lane_m`` between two dead-end areas, west and east. Each
    area is the lane's end, with spurs straight on, up and down: its stations take the
    first ones, its parking spots the rest.

    Raises:
        ValueError: an area with more than three spurs, or none.
    """
    b = LayoutBuilder()
    for area, x, out, count in (("a", 0.0, -1.0, 0), ("b", lane_m, 1.0, 1)):
        n_st, n_pk = stations[count], parking[count]
        if not 1 <= n_st + n_pk <= 3:
            raise ValueError(f"area {area!r} has room for 1 to 3 spurs, got {n_st + n_pk}")
        b.point(area, x, 0.0)
        ends = [(x + out * spur_m, 0.0), (x, spur_m), (x, -spur_m)]
        for k, (ex, ey) in enumerate(ends[: n_st + n_pk]):
            spot = b.point(f"{area}{k}", ex, ey)
            if k < n_st:
                b.spur(area, spot, f"station-{area}{k}", "pickdrop")
            else:
                b.spur(area, spot, f"park-{area}{k}", "parking")
    b.chain(["a", "b"], bidirectional=True)
    return Layout(b.points, b.segments, b.stations, name=name)


def lay_by(
    lane_m: float = 60.0,
    *,
    bay_m: float = 14.0,
    offset_m: float = 3.0,
    spur_m: float = 4.0,
    stations: tuple[int, int] = (1, 1),
    parking: tuple[int, int] = (2, 2),
    name: str = "lay-by",
) -> Layout:
    """A two-way lane of ``lane_m`` between two dead-end areas (as
    :func:`lane_between_areas`) with a lay-by halfway: for ``bay_m`` the lane is two
    one-way tracks, the eastbound one on the lane and the westbound one ``offset_m``
    to the north, so AGVs going opposite ways pass there and may wait there.

    Raises:
        ValueError: the bay does not fit in the lane.
    """
    if not 0 < bay_m < lane_m:
        raise ValueError(f"the lay-by must be shorter than the lane: {bay_m!r} of {lane_m!r}")
    base = lane_between_areas(lane_m, spur_m=spur_m, stations=stations, parking=parking, name=name)
    b = LayoutBuilder()
    b.points = list(base.points.values())
    b.segments = [s for s in base.segments.values() if s.id != "a>b"]
    b.stations = list(base.stations.values())
    west, east = (lane_m - bay_m) / 2, (lane_m + bay_m) / 2
    b.point("bay-w", west, 0.0)
    b.point("bay-e", east, 0.0)
    b.chain(["a", "bay-w"], bidirectional=True)
    b.chain(["bay-e", "b"], bidirectional=True)
    b.chain(["bay-w", "bay-e"])
    ramp = min(offset_m, bay_m / 4)
    via = ((east - ramp, offset_m), (west + ramp, offset_m))
    b.segments.append(Segment("bay-e>bay-w", "bay-e", "bay-w", via=via))
    return Layout(b.points, b.segments, b.stations, name=name)


def halls(
    width_m: float = 20.0,
    *,
    height_m: float = 10.0,
    door_m: float = 20.0,
    spur_m: float = 3.0,
    stations: tuple[int, int] = (2, 2),
    parking: tuple[int, int] = (3, 3),
    name: str = "halls",
) -> Layout:
    """Two halls, each a counter-clockwise one-way ring ``width_m`` by ``height_m``,
    joined by a two-way door of ``door_m`` from the middle of the west hall's east side
    to the middle of the east hall's west side. Station spurs leave the north lanes
    northwards, parking spurs the south lanes southwards, evenly spaced.

    Raises:
        ValueError: a hall with no station or no parking spot.
    """
    b = LayoutBuilder()
    for hall, x0, n_st, n_pk in (
        ("w", 0.0, stations[0], parking[0]),
        ("e", width_m + door_m, stations[1], parking[1]),
    ):
        if n_st < 1 or n_pk < 1:
            raise ValueError(f"hall {hall!r} needs a station and a parking spot")
        x1 = x0 + width_m
        south = [b.point(f"{hall}-sw", x0, 0.0)]
        for k in range(1, n_pk + 1):
            x = x0 + width_m * k / (n_pk + 1)
            south.append(b.point(f"{hall}-s{k}", x, 0.0))
            b.spur(south[-1], b.point(f"{hall}-p{k}", x, -spur_m), f"park-{hall}{k}", "parking")
        south.append(b.point(f"{hall}-se", x1, 0.0))
        north = [b.point(f"{hall}-ne", x1, height_m)]
        for k in range(n_st, 0, -1):
            x = x0 + width_m * k / (n_st + 1)
            north.append(b.point(f"{hall}-n{k}", x, height_m))
            spot = b.point(f"{hall}-st{k}", x, height_m + spur_m)
            b.spur(north[-1], spot, f"station-{hall}{k}", "pickdrop")
        north.append(b.point(f"{hall}-nw", x0, height_m))
        door = b.point(f"{hall}-door", x1 if hall == "w" else x0, height_m / 2)
        b.chain(south)  # eastwards
        b.chain(north)  # westwards
        if hall == "w":
            b.chain([f"{hall}-se", door, f"{hall}-ne"])  # the east side, north
            b.chain([f"{hall}-nw", f"{hall}-sw"])  # the west side, south
        else:
            b.chain([f"{hall}-se", f"{hall}-ne"])
            b.chain([f"{hall}-nw", door, f"{hall}-sw"])
    b.chain(["w-door", "e-door"], bidirectional=True)
    return Layout(b.points, b.segments, b.stations, name=name)
