"""The generated large warehouse: room for the fleet asked for, one-way loops that
connect every band, the demo's clearances, and a fleet that runs on it."""

from __future__ import annotations

import itertools

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.parking import parking_capacity
from agv_app.layout.generated import BAND_HEIGHT, generated_warehouse, parse_generated


@pytest.mark.parametrize("agvs", [1, 20, 200, 1000])
def test_parking_holds_the_fleet_with_some_spare_on_a_roughly_square_floor(agvs: int) -> None:
    layout = generated_warehouse(agvs)
    assert layout.name == f"generated-{agvs}"
    assert parking_capacity(layout) >= agvs * 1.1
    x0, y0, x1, y1 = layout.bounds()
    bands = round((y1 - y0 + 2.5) / BAND_HEIGHT)
    assert (x1 - x0) <= (bands + 1) * BAND_HEIGHT
    assert layout.unreachable_stations() == ()


def test_the_same_size_gives_the_same_layout() -> None:
    a, b = generated_warehouse(300), generated_warehouse(300)
    assert list(a.points.values()) == list(b.points.values())
    assert list(a.segments.values()) == list(b.segments.values())
    assert list(a.stations.values()) == list(b.stations.values())


def test_lanes_are_one_way_and_every_band_reaches_every_other() -> None:
    layout = generated_warehouse(1000)
    spots = {st.point for st in layout.stations.values()}
    for seg in layout.segments.values():
        if seg.bidirectional:
            assert seg.end in spots, seg.id
            assert layout.neighbours(seg.end) == (seg.start,), seg.id
    bands = sorted({p.split("-", 1)[0] for p in layout.points})
    assert bands == ["b1", "b2", "b3"]
    corners = [f"{band}-A1-1e" for band in bands]
    for a, b in itertools.permutations(corners, 2):
        assert layout.distance(a, b) < float("inf")


def test_spur_ends_of_neighbouring_bands_keep_the_demo_clearance() -> None:
    layout = generated_warehouse(1000)
    top_of_band_1 = max(p.y for p in layout.points.values() if p.id.startswith("b1-"))
    bottom_of_band_2 = min(p.y for p in layout.points.values() if p.id.startswith("b2-"))
    assert bottom_of_band_2 - top_of_band_1 == pytest.approx(2.5)


def test_layout_argument() -> None:
    assert parse_generated("generated:1000") == 1000
    assert parse_generated("plant.xml") is None
    for bad in ("generated:", "generated:0", "generated:-3", "generated:ten"):
        with pytest.raises(ValueError, match="generated:N"):
            parse_generated(bad)
    with pytest.raises(ValueError, match="positive number of AGVs"):
        generated_warehouse(0)


def test_a_fleet_runs_on_it_without_a_violation() -> None:
    fleet = Fleet(generated_warehouse(20), FleetConfig(agvs=20, seed=2, load=0.5))
    fleet.run(20.0)
    summary = fleet.summary()
    assert summary["collisions"] == 0
    assert summary["lock_overlaps"] == 0
    assert summary["tasks_created"] > 0
