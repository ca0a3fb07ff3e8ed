"""The layout as a LIF file, and orders built from it."""

from __future__ import annotations

import itertools
import json

from agv_app.layout.elements import Point, Segment, Station
from agv_app.layout.graph import Layout
from agv_app.vda5050.actions import ActionBook
from agv_app.vda5050.charging import ConstantRateBattery
from agv_app.vda5050.handling import LoadHandling
from agv_app.vda5050.lif import VEHICLE_TYPE_ID, layout_to_lif, main
from agv_app.vda5050.order import OrderBook
from agv_app.vda5050.topics import MANUFACTURER
from tests.vda5050.harness import header


def small_layout() -> Layout:
    return Layout(
        [Point("A", 0, 0), Point("B", 10, 0), Point("C", 10, 10)],
        [
            Segment("A-B", "A", "B", bidirectional=True),
            Segment("B-C", "B", "C", via=((14.0, 5.0),)),
        ],
        [Station("dock", "C", "drop"), Station("src", "A", "pick")],
        name="small",
        require_connected_stations=False,
    )


def test_every_point_segment_direction_and_station_is_exported() -> None:
    layout = small_layout()
    lif = layout_to_lif(layout)
    assert lif["metaInformation"]["lifVersion"] == "1.0.0"
    (plan,) = lif["layouts"]
    assert [n["nodeId"] for n in plan["nodes"]] == ["A", "B", "C"]
    assert plan["nodes"][1]["nodePosition"] == {"x": 10, "y": 0}
    edges = {(e["startNodeId"], e["endNodeId"]): e for e in plan["edges"]}
    assert sorted(edges) == [("A", "B"), ("B", "A"), ("B", "C")]
    assert len({e["edgeId"] for e in plan["edges"]}) == 3, "edge ids are unique"
    curve = edges[("B", "C")]["vehicleTypeEdgeProperties"][0]
    assert curve["vehicleTypeId"] == VEHICLE_TYPE_ID
    trajectory = curve["trajectory"]
    assert [(p["x"], p["y"]) for p in trajectory["controlPoints"]] == [(10, 0), (14, 5), (10, 10)]
    knots = trajectory["knotVector"]
    assert len(knots) == len(trajectory["controlPoints"]) + trajectory["degree"] + 1
    assert knots == sorted(knots)
    assert knots[2] == 0.5
    assert "trajectory" not in edges[("A", "B")]["vehicleTypeEdgeProperties"][0]
    stations = {s["stationId"]: s["interactionNodeIds"] for s in plan["stations"]}
    assert stations == {"dock": ["C"], "src": ["A"]}


def test_an_order_made_from_the_lif_edges_is_accepted() -> None:
    layout = small_layout()
    (plan,) = layout_to_lif(layout)["layouts"]
    edges = {(e["startNodeId"], e["endNodeId"]): e["edgeId"] for e in plan["edges"]}
    for path in (["B", "A"], ["A", "B", "C"]):
        effects = LoadHandling(
            layout, ConstantRateBattery(), handling_s=5.0, standing_at=lambda: None
        )
        book = OrderBook(
            layout, MANUFACTURER, "agv-01", actions=ActionBook(effects), last_node_id=path[0]
        )
        order = {
            **header("agv-01"),
            "orderId": "o",
            "orderUpdateId": 0,
            "nodes": [
                {"nodeId": p, "sequenceId": 2 * i, "released": True, "actions": []}
                for i, p in enumerate(path)
            ],
            "edges": [
                {
                    "edgeId": edges[(a, b)],
                    "sequenceId": 2 * i + 1,
                    "released": True,
                    "actions": [],
                }
                for i, (a, b) in enumerate(itertools.pairwise(path))
            ],
        }
        assert book.receive(order, at_rest=True, now=0.0) == "accepted"


def test_the_module_prints_the_demo_warehouse(capsys) -> None:
    assert main([]) == 0
    lif = json.loads(capsys.readouterr().out)
    assert lif["layouts"][0]["layoutId"] == "demo-warehouse"
    assert len(lif["layouts"][0]["nodes"]) > 100
