"""Reading another node's tuplespace with the roles of ``objectplaces.space_pages``: the
readers it serves get a page that fits one message, anyone else is refused, and an
impostor that publishes another node's id is never asked."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from objectplaces import RoleActivator
from objectplaces.groups import property_equals
from objectplaces.mesh import start_node
from objectplaces.security import TemporaryPki
from objectplaces.sim import SimulatedNetwork
from objectplaces.space_pages import (
    MAX_PAGE,
    SERVED_PROPERTY,
    SPACE_ROLE,
    SpacePageReader,
    SpacePageServer,
    SpaceUnreadable,
    read_space,
    serve_space,
)
from tests.waiting import until

FAST: dict[str, Any] = {"property_interval": 0.2, "failure_timeout": 30.0}


def _ask(net: SimulatedNetwork, reader: RoleActivator, target: str, **request: Any) -> list[Any]:
    """Answers heard from ``target`` for one request of ``reader`` (session stopped)."""
    heard: list[Any] = []
    role = SpacePageReader(target, request.get("offset", 0), request.get("limit", 10), heard.append)
    session = reader.start_interaction(role, property_equals(SERVED_PROPERTY, target), SPACE_ROLE)
    net.run_for(1.0)
    reader.stop_interaction(session)
    net.run_for(0.5)
    return heard


def _fleet() -> tuple[SimulatedNetwork, dict[str, RoleActivator]]:
    net = SimulatedNetwork(seed=3)
    nodes = {name: net.add_node(name) for name in ("control", "agv", "intruder")}
    serve_space(nodes["agv"], readers=["control"])
    for i in range(30):
        nodes["agv"].space.out(("lock", f"area-{i}", float(i), frozenset({"b", "a"})))
    nodes["agv"].space.out(("note",))
    net.run_for(1.0)
    return net, nodes


def test_a_reader_it_serves_reads_the_space_a_page_at_a_time() -> None:
    net, nodes = _fleet()
    [first] = _ask(net, nodes["control"], "agv", offset=0, limit=4)
    assert first["total"] == 31
    # By arity, then oldest first; each field in its plain JSON form (sets sorted).
    assert first["tuples"] == [
        ["note"],
        ["lock", "area-0", 0.0, ["a", "b"]],
        ["lock", "area-1", 1.0, ["a", "b"]],
        ["lock", "area-2", 2.0, ["a", "b"]],
    ]
    [last] = _ask(net, nodes["control"], "agv", offset=29, limit=10)
    assert last["tuples"] == [
        ["lock", "area-28", 28.0, ["a", "b"]],
        ["lock", "area-29", 29.0, ["a", "b"]],
    ]
    assert nodes["agv"].participations() == [], "each read leaves nothing behind"


def test_anyone_else_is_refused_and_bad_requests_are_answered_not_obeyed() -> None:
    net, nodes = _fleet()
    [refused] = _ask(net, nodes["intruder"], "agv")
    assert refused == {"refused": "agv serves its tuplespace to its control only"}
    for bad in ({"offset": -1}, {"limit": 0}, {"limit": MAX_PAGE + 1}, {"offset": True}):
        [answer] = _ask(net, nodes["control"], "agv", **bad)
        assert "refused" in answer, bad


def test_a_page_holds_what_fits_in_one_message_and_pages_on() -> None:
    net, nodes = _fleet()
    big = "x" * 4000
    for i in range(40):
        nodes["agv"].space.out(("blob", i, big))
    net.run_for(0.5)
    seen: list[Any] = []
    offset = 0
    while offset < 71:
        [answer] = _ask(net, nodes["control"], "agv", offset=offset, limit=MAX_PAGE)
        assert 0 < len(answer["tuples"]) < 71, "cut to fit, never empty"
        seen.extend(answer["tuples"])
        offset += len(answer["tuples"])
    assert len(seen) == 71
    assert sum(1 for t in seen if t[0] == "blob") == 40


def test_an_impostor_publishing_another_node_s_id_is_never_asked() -> None:
    net, nodes = _fleet()
    asked: list[Any] = []

    class Impostor(SpacePageServer):
        def receive(self, message: Any) -> None:
            asked.append(message)
            self.send({"total": 1, "tuples": [["forged"]]})

    nodes["intruder"].set_participant_factory(SPACE_ROLE, lambda: Impostor(frozenset()))
    nodes["intruder"].update_node_property(SERVED_PROPERTY, "agv")
    net.run_for(1.0)
    answers = _ask(net, nodes["control"], "agv", offset=0, limit=1)
    assert answers == [{"total": 31, "tuples": [["note"]]}]
    assert asked == []


async def test_read_space_over_the_mesh_and_what_it_refuses() -> None:
    with TemporaryPki(fleet="space-tests") as pki:
        control = await start_node("control", tls=pki.identity("control"), **FAST)
        agv = await start_node("agv", join=[control.address], tls=pki.identity("agv"), **FAST)
        other = await start_node("other", join=[control.address], tls=pki.identity("other"), **FAST)
        try:
            agv.space.out(("lock", "a1", 2.5))
            serve_space(agv, readers=["control"])
            serve_space(other, readers=[])
            await until(lambda: control.view().get("agv", {}).get(SERVED_PROPERTY) == "agv")
            await until(lambda: control.view().get("other", {}).get(SERVED_PROPERTY) == "other")
            async with asyncio.timeout(30):
                page = await read_space(control, "agv", offset=0, limit=10)
            assert page == (1, [["lock", "a1", 2.5]])
            with pytest.raises(SpaceUnreadable, match="other refused"):
                async with asyncio.timeout(30):
                    await read_space(control, "other", offset=0, limit=10)
            with pytest.raises(SpaceUnreadable, match="does not serve"):
                await read_space(control, "nobody", offset=0, limit=10)
            with pytest.raises(ValueError, match="limit"):
                await read_space(control, "agv", offset=0, limit=MAX_PAGE + 1)
            assert control.sessions() == []
        finally:
            for node in (other, agv, control):
                await node.close()
