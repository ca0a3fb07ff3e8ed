"""The built-in demo warehouse: one-way loops, aisles, docks and 200+ parking spots.

Plan (x east, y north, metres; about 60 x 40)::

    y=39   P-row north spurs (parking, some charging)
    y=36.5 P lane, one-way westbound <----------------------------- P@E
    y=34   P-row south spurs (parking)                              ^
    y=31.5 N-row north spurs (parking, some charging)               |
    y=29   W@N --> N lane, one-way eastbound (x=8..55.5) ------->  N@E
     |     8 aisles, alternately north- and southbound, each with   ^ E column
     |     3 station spurs to the east (pick / pickdrop / drop)     | (x=58,
     v     (W column, x=2, one-way southbound from P@W)             |  one-way
    y=9    M@W <-- main lane M, one-way westbound <------------- M@E  north)
    y=6.5  S-row north spurs (parking)                              ^
    y=4    S@W --> S lane, one-way eastbound -----------------> S@E
    y=1.5  S-row south spurs (parking, 4 docks: inbound "pick", outbound "drop")

Every lane is one-way, so no two AGVs ever meet head-on on one and an AGV may wait on
a lane anywhere but in a keep-clear box (below). Traffic flows in counter-clockwise
loops. The lower loop (S lane east, E column north, M lane west, W column south) joins
the docks and the S row to the aisles; the upper loop (N lane east, E column north,
P lane west, W column south) the N and P rows; between M and N, each northbound aisle
with any southbound aisle east of it makes a loop (N east, down the southbound aisle,
M west, up the northbound one), so an AGV gets from any aisle to any other within
about 130 m.

Every merge (a southbound aisle into the M lane, a northbound one into the N lane, the
M lane into the W column, the N lane into the E column) ends in a keep-clear box: its
last 1.5 m are marked two-way, although no route drives them the other way (from the
junction the box leads nowhere). The traffic rules let no AGV rest on a two-way
stretch, so one that merges waits with its hull clear of the lane it joins and
crosses the junction, turn included, on one lock. Without the box it may stop on the
junction still facing the way it came, a vehicle on the lane pulls up behind it into
the room its turn needs, and each waits for the other for ever.

Every station sits at the end of its own short two-way spur, off the lanes, so a
vehicle can stop there without blocking a lane; its end is a dead end, a passing
place, and leaving it is a merge the spur itself keeps clear. Spurs are 2.5 m long and
1.25 m apart: a 2 m x 1 m vehicle parked at a spur end keeps at least 0.25 m from its
neighbours and 1 m from vehicles passing (or turning) on the lane; lanes are far enough
apart that hulls on them never touch.
"""

from __future__ import annotations

from agv_app.layout.builder import LayoutBuilder
from agv_app.layout.elements import StationKind
from agv_app.layout.graph import Layout

__all__ = ["DEMO_VEHICLE_LENGTH_M", "DEMO_VEHICLE_WIDTH_M", "demo_warehouse"]

DEMO_VEHICLE_LENGTH_M = 2.0
"""Vehicle length the demo's clearances are designed for."""

DEMO_VEHICLE_WIDTH_M = 1.0
"""Vehicle width the demo's clearances are designed for."""

_SPUR = 2.5
_PITCH = 1.25
_X_WEST, _X_EAST = 2.0, 58.0
_Y_S, _Y_M, _Y_N, _Y_P = 4.0, 9.0, 29.0, 36.5
_ROW_XS = [3.5 + _PITCH * k for k in range(43)]  # S and P rows: 3.5 .. 56.0
_N_XS = [8.0 + _PITCH * k for k in range(39)]  # N row: 8.0 .. 55.5
_AISLE_XS = [8.0 + 6.25 * j for j in range(8)]  # 8.0 .. 51.75, on the N grid
_AISLE_STATION_YS = (14.0, 19.0, 24.0)
_AISLE_KINDS: tuple[StationKind, ...] = ("pick", "pickdrop", "drop")
_BOX = 1.5  # keep-clear box before a merge: a hull there is clear of the lane it joins


def demo_warehouse() -> Layout:
    """Return the demo warehouse (layout name ``"demo-warehouse"``).

    It has 8 aisles with 24 aisle stations, 4 docks, 10 charging spots and
    197 parking spots (each reachable on its own spur), all mutually reachable.
    """
    b = LayoutBuilder()
    # Lanes. Point ids name the lane and the x position in centimetres.
    s_lane = [b.point("S@W", _X_WEST, _Y_S)]
    s_lane += [b.point(f"S{round(x * 100):04d}", x, _Y_S) for x in _ROW_XS]
    s_lane.append(b.point("S@E", _X_EAST, _Y_S))
    p_lane = [b.point("P@E", _X_EAST, _Y_P)]
    p_lane += [b.point(f"P{round(x * 100):04d}", x, _Y_P) for x in reversed(_ROW_XS)]
    p_lane.append(b.point("P@W", _X_WEST, _Y_P))
    n_lane = [b.point(f"N{round(x * 100):04d}", x, _Y_N) for x in _N_XS]
    n_lane.append(b.point("N@E", _X_EAST, _Y_N))
    m_lane = [b.point("M@W", _X_WEST, _Y_M)]
    m_lane += [b.point(f"M{round(x * 100):04d}", x, _Y_M) for x in _AISLE_XS]
    m_lane.append(b.point("M@E", _X_EAST, _Y_M))
    w_n = b.point("W@N", _X_WEST, _Y_N)
    e_mid = b.point("E@mid", _X_EAST, (_Y_M + _Y_N) / 2)

    n_box = b.point("N@E-box", _X_EAST - _BOX, _Y_N)
    m_box = b.point("M@W-box", _X_WEST + _BOX, _Y_M)

    b.chain(s_lane)
    b.merge([w_n, *n_lane], n_box)  # joins the E column
    b.chain(p_lane)
    b.merge(m_lane[::-1], m_box)  # westbound, joins the W column
    b.chain(["S@E", "M@E", e_mid, "N@E", "P@E"])  # E column, northbound
    b.chain(["P@W", w_n, "M@W", "S@W"])  # W column, southbound

    # Aisles: even ones northbound (M -> N), odd ones southbound.
    for j, x in enumerate(_AISLE_XS):
        atag = round(x * 100)
        stops = [b.point(f"A{j + 1}-{k + 1}", x, y) for k, y in enumerate(_AISLE_STATION_YS)]
        ids = [f"M{atag:04d}", *stops, f"N{atag:04d}"]
        if j % 2 == 0:
            box = b.point(f"A{j + 1}-box", x, _Y_N - _BOX)
            b.merge(ids, box)
        else:
            box = b.point(f"A{j + 1}-box", x, _Y_M + _BOX)
            b.merge(ids[::-1], box)
        for k, (stop, y) in enumerate(zip(stops, _AISLE_STATION_YS, strict=True)):
            end = b.point(f"{stop}e", x + _SPUR, y)
            aisle_kind = _AISLE_KINDS[k]
            b.spur(stop, end, f"{aisle_kind}-A{j + 1}-{k + 1}", aisle_kind)

    # Parking rows.
    docks = 0
    for k, x in enumerate(_ROW_XS):
        tag = f"{round(x * 100):04d}"
        n_end = b.point(f"S{tag}n", x, _Y_S + _SPUR)
        b.spur(f"S{tag}", n_end, f"park-S{tag}n", "parking")
        s_end = b.point(f"S{tag}s", x, _Y_S - _SPUR)
        if k % 10 == 5:
            docks += 1
            dock_kind: StationKind = "pick" if docks % 2 else "drop"
            name = f"dock-{'in' if dock_kind == 'pick' else 'out'}-{(docks + 1) // 2}"
            b.spur(f"S{tag}", s_end, name, dock_kind)
        else:
            b.spur(f"S{tag}", s_end, f"park-S{tag}s", "parking")
        for side, dy in (("n", _SPUR), ("s", -_SPUR)):
            end = b.point(f"P{tag}{side}", x, _Y_P + dy)
            charging = side == "n" and k % 8 == 4
            b.spur(
                f"P{tag}",
                end,
                f"{'charge' if charging else 'park'}-P{tag}{side}",
                "charging" if charging else "parking",
            )
    for k, x in enumerate(_N_XS):
        tag = f"{round(x * 100):04d}"
        end = b.point(f"N{tag}n", x, _Y_N + _SPUR)
        charging = k % 8 == 3
        b.spur(
            f"N{tag}",
            end,
            f"{'charge' if charging else 'park'}-N{tag}n",
            "charging" if charging else "parking",
        )
    return Layout(b.points, b.segments, b.stations, name="demo-warehouse")
