"""Peers that know only a chain of endpoints become a full mesh (Zenoh peers do not
forward for one another): one dialer per pair, gossip to the next hop only. 14 real
peer processes form and the two ends of the chain hold a session."""

from __future__ import annotations

import json

import pytest

from objectplaces.transport.zenoh_config import (
    PEER_SCOUTING,
    ZenohOptions,
    ZenohSecurity,
    zenoh_config,
)
from tests.mesh.procs import Cluster
from tests.zenoh.test_processes import ZENOH, cluster, secret_file

__all__ = ["cluster", "secret_file"]

CHAIN = 14


def test_a_peer_dials_only_greater_ids_and_gossips_one_hop() -> None:
    config = json.loads(str(zenoh_config(ZenohOptions(), ZenohSecurity())))
    gossip = config["scouting"]["gossip"]
    assert gossip["multihop"] is False
    assert gossip["autoconnect_strategy"] == {
        "peer": {"to_router": "always", "to_peer": "greater-zid"}
    }
    assert PEER_SCOUTING["scouting/gossip/multihop"] is False


@pytest.mark.processes
@pytest.mark.slow
def test_peers_on_a_chain_of_endpoints_form_a_full_mesh(cluster: Cluster) -> None:
    head = cluster.start(
        "p0", *ZENOH, "--role", "collector", "--group", "within:5", "--property", "position=[0,0]"
    )
    echo = ["--role", "echo", "--tick", "0.05", "--property", "position=[100,100]", *ZENOH]
    nodes = [head]
    for i in range(1, CHAIN):
        nodes.append(cluster.start(f"p{i}", *echo, "--connect", nodes[-1].address))
    for node in nodes:
        node.wait_peers(CHAIN - 1, timeout=60)
    far = nodes[-2:]  # the other end of the chain: reached only by a link of its own
    for node in far:
        node.send(cmd="move", x=1, y=0)
    for node in far:
        head.wait_event("in_group", peer=node.node_id, timeout=30)
        head.wait_event("receive", peer=node.node_id, timeout=30)
