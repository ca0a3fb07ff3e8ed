"""A request inside the circle in force is asked without a new publication.

The others have had that circle since it went out, so the request's safe time counts
from then (docs/traffic.md, "A request inside the published circle"); one that reaches
beyond it publishes a new circle first.
"""

from __future__ import annotations

import pytest

from agv_app.fleet import Fleet
from agv_app.vehicle import AgvController
from tests.agv_app.vehicle.test_next_task import one_agv


def _drive_one_task(fleet: Fleet, agv: AgvController) -> tuple[int, int, int]:
    """Run a task to its end, checking at every step that the circle in force covers
    the AGV's locks, request and claims; (requests, covered requests, publications)."""
    published: list[float] = []
    publish = agv.publish

    def counting_publish() -> None:
        published.append(fleet.now)
        publish()

    agv.publish = counting_publish  # type: ignore[method-assign]
    fleet.create_task("pick-A1-1", "drop-A5-3")
    requests = covered = 0
    seen = -1
    end = fleet.now + 600.0
    while agv.last_done is None:
        assert fleet.now < end, "timed out"
        fleet.step()
        circle = agv._circle
        assert circle is not None
        assert agv.publication.reach_from(circle.x, circle.y) <= circle.radius + 1e-9
        entry = agv.book.request()
        if entry is not None and entry.key != seen:
            seen = entry.key
            requests += 1
            announced = agv._announced
            assert announced is not None
            if announced[0] < fleet.now - 1e-9:
                covered += 1
                assert announced[0] <= circle.since < fleet.now  # nothing published
            else:
                assert circle.since == fleet.now
    return requests, covered, len(published)


@pytest.mark.source_only("replaces AgvController.publish")
def test_every_request_lies_in_the_circle_in_force_and_not_every_one_publishes() -> None:
    # With 5 m requests some lie inside the circle of the one before; with the default
    # 3 m each reaches beyond it on this route.
    fleet, agv = one_agv(advance_m=5.0)
    requests, covered, published = _drive_one_task(fleet, agv)
    assert requests >= 10
    assert covered >= 2
    assert published >= requests - covered


def test_a_request_beyond_the_circle_publishes_a_new_one_around_the_agv() -> None:
    fleet, agv = one_agv()
    old = agv._circle
    assert old is not None
    fleet.create_task("pick-A1-1", "drop-A5-3")
    while agv.book.request() is None:
        fleet.step()
    circle = agv._circle
    assert circle is not None
    assert circle != old
    pose = agv.vehicle.pose()
    assert (circle.x, circle.y) == (pose.x, pose.y)
    assert circle.since == fleet.now
    assert agv.node.properties["hull_length"] == circle.radius
    assert agv.publication.covered_since() == fleet.now
