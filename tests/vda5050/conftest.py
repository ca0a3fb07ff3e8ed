"""A fleet PKI made for each test, and a mosquitto on 127.0.0.1 that requires its
certificates (the broker the demo starts), stopped after."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from agv_app.vda5050.broker import BROKER_ID, LocalBroker, find_mosquitto
from agv_app.vda5050.demo import MASTER_ID
from agv_app.vda5050.link import MqttLink, VdaCredentials, mqtt_link
from agv_app.vda5050.monitor import MONITOR_ID
from agv_app.vda5050.topics import BrokerAddress
from objectplaces.security import TemporaryPki

AGV_IDS = ("agv-01", "agv-02")
HOST = "127.0.0.1"


@pytest.fixture
def pki() -> Iterator[TemporaryPki]:
    """A fleet CA with the broker, a master control, the monitor and two vehicles."""
    with TemporaryPki(fleet="vda5050-tests") as made:
        made.identity(BROKER_ID, role="router", addresses=(HOST,))
        made.identity(MASTER_ID, role="master")
        made.identity(MONITOR_ID, role="control")
        for agv_id in AGV_IDS:
            made.identity(agv_id, role="agv")
        yield made


@pytest.fixture
def local_broker(pki: TemporaryPki) -> Iterator[LocalBroker]:
    """A fresh broker for one test (no retained messages from another)."""
    if find_mosquitto() is None:
        pytest.skip("mosquitto is not installed (make mosquitto)")
    broker = LocalBroker(pki.identity(BROKER_ID, role="router"))
    broker.start()
    try:
        yield broker
    finally:
        broker.stop()


@pytest.fixture
def broker(local_broker: LocalBroker) -> BrokerAddress:
    """Where the test's broker listens (``mqtts``)."""
    assert local_broker.address is not None
    return local_broker.address


@pytest.fixture
def credentials(pki: TemporaryPki) -> VdaCredentials:
    """The fleet's certificates, for the vehicles and the monitor."""
    return VdaCredentials(pki)


@pytest.fixture
def master(pki: TemporaryPki, broker: BrokerAddress) -> MqttLink:
    """The test's master control: its certificate, to the test's broker."""
    return mqtt_link(broker, tls=pki.identity(MASTER_ID, role="master"))
