"""A rider hails the free taxis within 500 m; each answers with where it is, the rider
books the nearest. When the booked taxi crashes on its way, the rider hears it leave
the group and books the next; a taxi that turns busy is in no rider's group.

Run it: ``python examples/taxi_dispatch.py`` (the middleware alone; about a second).
"""

from __future__ import annotations

import math
from typing import Any

from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef, groups
from objectplaces.sim import SimulatedNetwork

__all__ = ["Rider", "Taxi", "main"]

FREE_NEARBY = groups.within(500.0) & groups.property_equals("status", "free")
"""Who a rider hails: the taxis within 500 m that are free."""


class Taxi(Participant):
    """On every taxi: answers a hail with where it is; booked, it says so in its space."""

    def in_group_of(self, initiator: InitiatorRef) -> None:
        found = self.space.rdp(("position", float, float))  # the taxi's software keeps it
        assert found is not None
        self.send({"position": found[1:]})

    def receive(self, message: Any) -> None:
        if message.get("booked"):
            self.space.out(("booked", self.initiator.node_id))


class Rider(Initiator):
    """On the rider's phone: collects answers, books the nearest, rebooks on a loss."""

    def __init__(self, position: tuple[float, float]) -> None:
        self.position = position
        self.distances: dict[ParticipantRef, float] = {}
        self.booked: ParticipantRef | None = None
        self.log: list[str] = []

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        self.distances[participant] = math.dist(self.position, message["position"])

    def book_nearest(self) -> None:
        """Book the nearest taxi that answered, if any did."""
        if not self.distances:
            self.booked = None
            self.log.append("no taxi")
            return
        self.booked = min(self.distances, key=self.distances.__getitem__)
        self.send(self.booked, {"booked": True})
        self.log.append(f"booked {self.booked.node_id}")

    def out_group(self, participant: ParticipantRef) -> None:
        self.distances.pop(participant, None)
        if participant == self.booked:
            self.log.append(f"lost {participant.node_id}")
            self.book_nearest()


def main(seed: int = 1) -> list[str]:
    """Hail, book, crash the booked taxi, rebook; returns the rider's log."""
    net = SimulatedNetwork(seed=seed, delay=0.02, jitter=0.01, loss=0.02)
    taxis = {}
    for name, x, y, status in [
        ("taxi-1", 120.0, 40.0, "free"),
        ("taxi-2", 300.0, -80.0, "free"),
        ("taxi-3", 90.0, 20.0, "busy"),
        ("taxi-4", 900.0, 0.0, "free"),
    ]:
        taxi = net.add_node(name)
        taxi.update_node_property("position", (x, y))
        taxi.update_node_property("status", status)
        taxi.space.out(("position", x, y))
        taxi.set_participant_factory("taxi", Taxi)
        taxis[name] = taxi
    phone = net.add_node("rider")
    phone.update_node_property("position", (0.0, 0.0))
    net.run_for(1.0)

    rider = Rider(phone.properties["position"])
    hail = phone.start_interaction(rider, FREE_NEARBY, "taxi")
    net.run_for(1.0)
    assert sorted(p.node_id for p in rider.distances) == ["taxi-1", "taxi-2"]
    rider.book_nearest()
    net.run_for(1.0)
    assert taxis["taxi-1"].space.rdp(("booked", str)) == ("booked", "rider")

    net.remove_node("taxi-1")  # it crashes: it says nothing, its node falls silent
    net.run_for(5.0)  # failure detection: three silent seconds
    assert rider.booked is not None
    assert rider.booked.node_id == "taxi-2"
    net.run_for(1.0)
    assert taxis["taxi-2"].space.rdp(("booked", str)) == ("booked", "rider")
    phone.stop_interaction(hail)  # the ride is arranged
    taxis["taxi-2"].update_node_property("status", "busy")
    net.run_for(2.0)
    assert phone.view_group(FREE_NEARBY) == set()  # taxi-4 is free, but 900 m away
    print("; ".join(rider.log))
    return rider.log


if __name__ == "__main__":
    main()
