"""Thirty drones in the simulator at 5 % loss: a drone low on battery asks the drones
within 40 m whose battery is above 50 % to take over its patrol, takes their offers,
and hands the patrol to the nearest one.

Run it: ``python examples/drone_relay.py`` (the middleware alone; about a second).
"""

from __future__ import annotations

import math
import random
from typing import Any

from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef, groups
from objectplaces.sim import SimulatedNetwork

__all__ = ["Relay", "Volunteer", "main"]


class Volunteer(Participant):
    """On every drone that may take over: offers its distance, waits to be chosen."""

    def in_group_of(self, initiator: InitiatorRef) -> None:
        here = self.space.rdp(("position", float, float))
        assert here is not None
        self.send({"offer": list(here[1:])})

    def receive(self, message: Any) -> None:
        if message.get("take_over"):
            self.space.out(("patrol", message["take_over"]))


class Relay(Initiator):
    """On the drone that must land: collects the offers."""

    def __init__(self) -> None:
        self.offers: dict[ParticipantRef, tuple[float, float]] = {}

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        x, y = message["offer"]
        self.offers[participant] = (x, y)

    def out_group(self, participant: ParticipantRef) -> None:
        self.offers.pop(participant, None)  # it left: its offer no longer stands


def main(seed: int = 1) -> str:
    """Run the relay once; returns the id of the drone that took over the patrol."""
    net = SimulatedNetwork(seed=seed, delay=0.01, jitter=0.005, loss=0.05)
    draw = random.Random(seed)
    drones = {}
    for i in range(30):
        drone = net.add_node(f"drone-{i:02d}")
        x, y = draw.uniform(0, 150), draw.uniform(0, 150)
        battery = 20 if i == 0 else draw.randint(10, 100)
        drone.update_node_property("position", (x, y))
        drone.update_node_property("battery", battery)
        drone.space.out(("position", x, y))
        drone.set_participant_factory("volunteer", Volunteer)
        drones[drone.node_id] = drone
    net.run_for(2.0)  # the properties spread, over the lossy links too

    low = drones["drone-00"]
    able = groups.within(40.0) & groups.property_above("battery", 50)
    relay = Relay()
    session = low.start_interaction(relay, able, "volunteer")
    net.run_for(2.0)
    assert relay.offers, "no drone within 40 m with battery above 50 %"
    assert {p.node_id for p in relay.offers} == low.view_group(able)

    mx, my = low.properties["position"]
    best = min(relay.offers, key=lambda p: math.dist((mx, my), relay.offers[p]))
    offers = len(relay.offers)
    relay.send(best, {"take_over": "patrol-A"})
    net.run_for(1.0)
    low.stop_interaction(session)
    net.run_for(1.0)
    assert drones[best.node_id].space.rdp(("patrol", str)) == ("patrol", "patrol-A")
    assert not low.sessions()
    print(f"{offers} offers; {best.node_id} takes over patrol-A")
    return best.node_id


if __name__ == "__main__":
    main()
