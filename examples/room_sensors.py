"""Two processes on the WebSocket mesh, over mutual TLS: a thermostat asks the
temperature sensors of its room for readings and averages them. The sensor runs in a
process of its own; a fleet CA for the run is made in a temporary folder.

Run it: ``python examples/room_sensors.py`` (the middleware alone; a few seconds).
"""

from __future__ import annotations

import asyncio
import sys
from typing import Any

import objectplaces
from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef, groups
from objectplaces.security import Identity, TemporaryPki

__all__ = ["Sensor", "Thermostat", "main", "sensor"]

SAME_ROOM = groups.property_equals("room", "lab")
"""Who the thermostat asks: every node in the lab."""


class Sensor(Participant):
    """On a sensor: sends its reading when the thermostat asks."""

    def in_group_of(self, initiator: InitiatorRef) -> None:
        found = self.space.rdp(("celsius", float))
        assert found is not None
        self.send({"celsius": found[1]})


class Thermostat(Initiator):
    """On the thermostat: keeps each sensor's latest reading, in its node's space."""

    def __init__(self) -> None:
        self.readings: dict[ParticipantRef, float] = {}

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        self.readings[participant] = message["celsius"]
        self.space.out(("reading", participant.node_id, message["celsius"]))

    def out_group(self, participant: ParticipantRef) -> None:
        self.readings.pop(participant, None)


async def sensor(pki: str) -> None:
    """The sensor's process: prints its address, serves until told to stop on stdin."""
    node = await objectplaces.start_node(
        "sensor-1", listen="127.0.0.1:0", tls=Identity.from_pki(pki, "sensor-1")
    )
    node.update_node_property("position", (2.0, 1.0))
    node.update_node_property("room", "lab")
    node.space.out(("celsius", 21.5))
    node.set_participant_factory("sensor", Sensor)
    print(node.address, flush=True)
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
    await node.close()


async def main() -> float:
    """Start a sensor process, ask it from a thermostat; returns the average reading."""
    with TemporaryPki(fleet="building") as pki:
        pki.identity("sensor-1")
        thermostat_tls = pki.identity("thermostat")
        child = await asyncio.create_subprocess_exec(
            sys.executable,
            __file__,
            "--sensor",
            str(pki.directory),
            stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE,
        )
        assert child.stdin is not None
        assert child.stdout is not None
        try:
            address = (await child.stdout.readline()).decode().strip()
            node = await objectplaces.start_node(
                "thermostat", listen="127.0.0.1:0", join=[address], tls=thermostat_tls
            )
            node.update_node_property("position", (0.0, 0.0))
            node.update_node_property("room", "lab")
            async with asyncio.timeout(60):
                await node.wait_for_peers(1)
            thermostat = Thermostat()
            session = node.start_interaction(thermostat, SAME_ROOM, "sensor")
            _, sensor_id, celsius = await node.space.ain(("reading", str, float), timeout=60)
            average = sum(thermostat.readings.values()) / len(thermostat.readings)
            print(f"{sensor_id}: {celsius} °C; the lab's average {average} °C")
            node.stop_interaction(session)
            await node.close()
        finally:
            child.stdin.write(b"stop\n")
            await child.stdin.drain()
            async with asyncio.timeout(30):
                assert await child.wait() == 0
    return average


if __name__ == "__main__":
    if sys.argv[1:2] == ["--sensor"]:
        asyncio.run(sensor(sys.argv[2]))
    else:
        asyncio.run(main())
