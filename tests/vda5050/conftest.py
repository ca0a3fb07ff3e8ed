"""A mosquitto broker on 127.0.0.1 and a free port (set_tcp_nodelay true), stopped after."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from agv_app.vda5050.broker import LocalBroker, find_mosquitto
from agv_app.vda5050.topics import BrokerAddress


@pytest.fixture
def broker() -> Iterator[BrokerAddress]:
    """A fresh broker for one test (no retained messages from another)."""
    if find_mosquitto() is None:
        pytest.skip("mosquitto is not installed (make mosquitto)")
    with LocalBroker() as address:
        yield address
