"""A vehicle of a master control sent home: refused while it drives an order; standing
where the order left it, it drives home and takes desk tasks again. Virtual time."""

from __future__ import annotations

import json

import pytest

from agv_app.vehicle.service import send_home
from tests.vda5050.harness import OneVehicle, make_order
from tests.vda5050.test_order_driving import far_point


def test_sent_home_while_driving_an_order_is_refused_and_after_it_drives_home() -> None:
    v = OneVehicle()
    path = far_point(v)
    v.endpoint.handle("order", json.dumps(make_order(v.layout, "agv-01", path)).encode())
    v.run(1.0)
    with pytest.raises(ValueError, match="drives an order of its master control"):
        send_home(v.agv)
    assert not v.agv.sent_home
    v.run_until(lambda: not v.agv.book_of_orders.active, within=600)
    assert v.agv.point == path[-1] != v.home, "it stands where the order left it"
    send_home(v.agv)
    v.run_until(lambda: v.agv.point == v.home and v.agv.at_rest, within=600)
    assert not v.agv.sent_home, "home: it takes desk tasks again"
