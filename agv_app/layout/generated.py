"""A generated large warehouse, sized for a given number of AGVs.

The demo warehouse holds about 200 AGVs. This one holds any number: it stacks ``bands``
of the demo's pattern on top of each other and makes each band as wide as the fleet
needs. One band, south to north (x east, y north, metres, ``y0`` the band's base)::

    y0+39   P-row north spurs (parking, some charging)
    y0+36.5 P lane, one-way westbound  <------------------------------ P@E
    y0+34   P-row south spurs (parking)                                 ^
    y0+31.5 N-row north spurs (parking, some charging)                  |
    y0+29   W@N --> N lane, one-way eastbound -----------------------> N@E
     |      aisles, alternately north- and southbound, each with        ^ E column
     |      3 station spurs to the east (pick / pickdrop / drop)        | (one-way
     v      (W column, one-way southbound)                              |  north)
    y0+9    M@W <-- M lane, one-way westbound  <---------------------- M@E
    y0+6.5  S-row north spurs (parking)                                 ^
    y0+4    S@W --> S lane, one-way eastbound -----------------------> S@E
    y0+1.5  S-row south spurs (parking, docks: inbound "pick", outbound "drop")

Bands are ``BAND_HEIGHT`` apart. The E column runs on north from one band's P@E to the
next band's S@E, the W column on south from one band's S@W to the band below's P@W:
one-way loops stay one-way loops, and every point reaches every other (north by the E
column, south by the W column). Clearances are the demo's (a 2 m x 1 m vehicle): spurs
2.5 m long and 1.25 m apart, and 2.5 m between the P-row spur ends of one band and the
S-row spur ends of the next.
"""

from __future__ import annotations

import math

from agv_app.layout.builder import LayoutBuilder
from agv_app.layout.elements import StationKind
from agv_app.layout.graph import Layout

__all__ = ["BAND_HEIGHT", "GENERATED_PREFIX", "generated_warehouse", "parse_generated"]

BAND_HEIGHT = 40.0
"""Metres from one band's base to the next."""

GENERATED_PREFIX = "generated:"
"""A layout argument ``generated:N`` names the generated warehouse for N AGVs."""

_SPUR = 2.5
_PITCH = 1.25
_AISLE_PITCH = 6.25
_X_WEST = 2.0
_Y_S, _Y_M, _Y_N, _Y_P = 4.0, 9.0, 29.0, 36.5
_AISLE_STATION_YS = (14.0, 19.0, 24.0)
_AISLE_KINDS: tuple[StationKind, ...] = ("pick", "pickdrop", "drop")
_SPARE = 1.15  # parking places per AGV: some room for relocation
_MIN_ROW = 16  # positions on a row: room for at least two aisles


def _parking_per_band(row: int) -> int:
    """Parking places of a band with ``row`` positions on its S and P rows."""
    docks = len(range(5, row, 10))
    n_row = row - 4
    n_charging = len(range(3, n_row, 8))
    p_charging = len(range(4, row, 8))
    return 4 * row - docks - p_charging + n_row - n_charging


def _size_for(agvs: int) -> tuple[int, int]:
    """``(bands, row positions)`` for a roughly square floor with room for ``agvs``."""
    need = math.ceil(agvs * _SPARE)
    bands = 1
    while True:
        row = _MIN_ROW
        while _parking_per_band(row) * bands < need:
            row += 1
        # Wider than tall by more than a band's height: one more band is squarer.
        if row * _PITCH <= (bands + 1) * BAND_HEIGHT:
            return bands, row
        bands += 1


def _band(b: LayoutBuilder, band: int, row: int) -> None:
    """Lay out band ``band`` (lanes, aisles, stations, parking) with ``row`` positions."""
    y0 = band * BAND_HEIGHT
    tag = f"b{band + 1}-"
    row_xs = [3.5 + _PITCH * k for k in range(row)]
    x_east = row_xs[-1] + 2.0
    n_xs = [8.0 + _PITCH * k for k in range(row - 4)]
    aisle_xs = [8.0 + _AISLE_PITCH * j for j in range(int((n_xs[-1] - 8.0) // _AISLE_PITCH) + 1)]

    def pid(name: str) -> str:
        return f"{tag}{name}"

    def cm(x: float) -> str:
        return f"{round(x * 100):05d}"

    def at(name: str, x: float, y: float) -> str:
        return b.point(pid(name), x, y0 + y)

    s_lane = [at("S@W", _X_WEST, _Y_S), *(at(f"S{cm(x)}", x, _Y_S) for x in row_xs)]
    s_lane.append(at("S@E", x_east, _Y_S))
    p_lane = [at("P@E", x_east, _Y_P), *(at(f"P{cm(x)}", x, _Y_P) for x in reversed(row_xs))]
    p_lane.append(at("P@W", _X_WEST, _Y_P))
    n_lane = [at(f"N{cm(x)}", x, _Y_N) for x in n_xs]
    n_lane.append(at("N@E", x_east, _Y_N))
    m_lane = [at("M@W", _X_WEST, _Y_M), *(at(f"M{cm(x)}", x, _Y_M) for x in aisle_xs)]
    m_lane.append(at("M@E", x_east, _Y_M))
    w_n = at("W@N", _X_WEST, _Y_N)
    e_mid = at("E@mid", x_east, (_Y_M + _Y_N) / 2)

    b.chain(s_lane)
    b.chain([w_n, *n_lane])
    b.chain(p_lane)
    b.chain(m_lane[::-1])
    b.chain([pid("S@E"), pid("M@E"), e_mid, pid("N@E"), pid("P@E")])
    b.chain([pid("P@W"), w_n, pid("M@W"), pid("S@W")])

    for j, x in enumerate(aisle_xs):
        stops = [at(f"A{j + 1}-{k + 1}", x, y) for k, y in enumerate(_AISLE_STATION_YS)]
        ids = [pid(f"M{cm(x)}"), *stops, pid(f"N{cm(x)}")]
        b.chain(ids if j % 2 == 0 else ids[::-1])
        for k, (stop, y) in enumerate(zip(stops, _AISLE_STATION_YS, strict=True)):
            end = b.point(f"{stop}e", x + _SPUR, y0 + y)
            kind = _AISLE_KINDS[k]
            b.spur(stop, end, f"{tag}{kind}-A{j + 1}-{k + 1}", kind)

    docks = 0
    for k, x in enumerate(row_xs):
        s_base, p_base = pid(f"S{cm(x)}"), pid(f"P{cm(x)}")
        b.spur(s_base, at(f"S{cm(x)}n", x, _Y_S + _SPUR), f"{tag}park-S{cm(x)}n", "parking")
        s_end = at(f"S{cm(x)}s", x, _Y_S - _SPUR)
        if k % 10 == 5:
            docks += 1
            dock_kind: StationKind = "pick" if docks % 2 else "drop"
            name = f"{tag}dock-{'in' if dock_kind == 'pick' else 'out'}-{(docks + 1) // 2}"
            b.spur(s_base, s_end, name, dock_kind)
        else:
            b.spur(s_base, s_end, f"{tag}park-S{cm(x)}s", "parking")
        for side, dy in (("n", _SPUR), ("s", -_SPUR)):
            charging = side == "n" and k % 8 == 4
            b.spur(
                p_base,
                at(f"P{cm(x)}{side}", x, _Y_P + dy),
                f"{tag}{'charge' if charging else 'park'}-P{cm(x)}{side}",
                "charging" if charging else "parking",
            )
    for k, x in enumerate(n_xs):
        charging = k % 8 == 3
        b.spur(
            pid(f"N{cm(x)}"),
            at(f"N{cm(x)}n", x, _Y_N + _SPUR),
            f"{tag}{'charge' if charging else 'park'}-N{cm(x)}n",
            "charging" if charging else "parking",
        )


def generated_warehouse(agvs: int) -> Layout:
    """A warehouse of the demo's pattern with parking for ``agvs`` AGVs and some spare.

    Named ``generated-<agvs>``; the same ``agvs`` always gives the same layout.

    Raises:
        ValueError: ``agvs`` is not a positive whole number.
    """
    if isinstance(agvs, bool) or not isinstance(agvs, int) or agvs < 1:
        raise ValueError(f"a generated warehouse needs a positive number of AGVs, got {agvs!r}")
    bands, row = _size_for(agvs)
    b = LayoutBuilder()
    for band in range(bands):
        _band(b, band, row)
    for band in range(bands - 1):
        # The columns carry on between bands: north on the east side, south on the west.
        here, above = f"b{band + 1}-", f"b{band + 2}-"
        b.chain([f"{here}P@E", f"{above}S@E"])
        b.chain([f"{above}S@W", f"{here}P@W"])
    return Layout(b.points, b.segments, b.stations, name=f"generated-{agvs}")


def parse_generated(argument: str) -> int | None:
    """The AGV count in a layout argument ``generated:N``; None for any other argument.

    Raises:
        ValueError: it starts with ``generated:`` but N is not a positive whole number.
    """
    if not argument.startswith(GENERATED_PREFIX):
        return None
    count = argument.removeprefix(GENERATED_PREFIX)
    if not count.isdigit() or int(count) < 1:
        raise ValueError(f"{argument!r}: expected {GENERATED_PREFIX}N with N a positive number")
    return int(count)
