"""Who may connect how (``link.py``), the access list (``acl.py``), the broker's
configuration and command (``broker.py``), and a plain broker on loopback when asked."""

from __future__ import annotations

import asyncio
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from agv_app.vda5050.acl import access_list
from agv_app.vda5050.bridge import BridgeCounters, run_bridge
from agv_app.vda5050.broker import BROKER_ID, LocalBroker, broker_config, find_mosquitto
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.link import BrokerError, VdaCredentials, mqtt_link, probe_broker
from agv_app.vda5050.topics import BrokerAddress, VehicleTopics
from objectplaces.core.errors import LocalProtocolError
from objectplaces.security import CredentialError, Issued, TemporaryPki
from tests.vda5050.harness import OneVehicle
from tests.vda5050.probe import probe

needs_mosquitto = pytest.mark.skipif(
    find_mosquitto() is None, reason="mosquitto is not installed (make mosquitto)"
)


def member(node_id: str, role: str, *, revoked: str | None = None) -> Issued:
    return Issued(node_id, role, 1, "2030-01-01T00:00:00+00:00", revoked)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_the_access_list_gives_each_certificate_its_own_topics() -> None:
    text = access_list(
        [
            member("agv-01", "agv"),
            member("m1", "master"),
            member("old", "master", revoked="2026-01-01T00:00:00+00:00"),
            member("observer", "control"),
            member("broker", "router"),
            member("n1", "node"),
        ]
    )
    lines = [line for line in text.splitlines() if line and not line.startswith("#")]
    own = "uagv/v3/ObjectPlaces/%u"
    assert lines == [
        f"pattern read {own}/order",
        f"pattern read {own}/instantActions",
        f"pattern write {own}/state",
        f"pattern write {own}/visualization",
        f"pattern write {own}/connection",
        f"pattern write {own}/factsheet",
        "user m1",
        "topic read uagv/v3/+/+/#",
        "topic write uagv/v3/+/+/order",
        "topic write uagv/v3/+/+/instantActions",
        "user observer",
        "topic read uagv/v3/+/+/#",
    ]
    pair = [member("observer", "control"), member("m1", "master")]
    assert access_list(pair) == access_list(reversed(pair)), "the same for the same members"


def test_a_link_is_mutual_tls_unless_plain_is_asked_for_by_name_on_loopback(
    pki: TemporaryPki,
) -> None:
    agv = pki.identity("agv-01", role="agv")
    link = mqtt_link("mqtts://127.0.0.1:8883", tls=agv, client_id="agv-01", roles=("agv",))
    assert link.client_id == "agv-01"
    context = link.tls_context()
    assert context is not None
    assert context.check_hostname
    plain = mqtt_link("mqtt://127.0.0.1:1883", insecure=True)
    assert plain.identity is None
    assert plain.tls_context() is None
    refusals: list[tuple[dict[str, object], type[Exception], str]] = [
        ({"broker": "mqtts://127.0.0.1:8883"}, LocalProtocolError, "--pki DIR"),
        ({"broker": "mqtts://127.0.0.1:8883", "tls": agv, "insecure": True}, LocalProtocolError,
         "not --insecure"),
        ({"broker": "mqtt://127.0.0.1:1883"}, LocalProtocolError, "--insecure"),
        ({"broker": "mqtt://127.0.0.1:1883", "tls": agv}, LocalProtocolError, "plain link"),
        ({"broker": "mqtt://10.0.0.5:1883", "insecure": True}, LocalProtocolError,
         "loopback only"),
        ({"broker": "mqtts://127.0.0.1", "tls": agv, "client_id": "agv-02"}, CredentialError,
         "names 'agv-01', not 'agv-02'"),
        ({"broker": "mqtts://127.0.0.1", "tls": agv, "roles": ("master",)}, CredentialError,
         "role 'agv'"),
        ({"broker": "ws://127.0.0.1"}, ValueError, "mqtts://HOST:PORT"),
    ]  # fmt: skip
    for kwargs, error, said in refusals:
        broker = kwargs.pop("broker")
        assert isinstance(broker, str)
        with pytest.raises(error, match=said):
            mqtt_link(broker, **kwargs)  # type: ignore[arg-type]


def test_credentials_come_from_a_pki_folder_or_are_plain_by_name(pki: TemporaryPki) -> None:
    with pytest.raises(LocalProtocolError, match="--pki DIR"):
        VdaCredentials()
    with pytest.raises(LocalProtocolError, match="not both"):
        VdaCredentials(pki.directory, insecure=True)
    folder = VdaCredentials(pki.directory)
    assert folder.directory == pki.directory
    with pytest.raises(CredentialError, match=r"agv-07\.pem"):
        folder.link("mqtts://127.0.0.1:8883", "agv-07", roles=("agv",))
    with pytest.raises(CredentialError, match="role 'master'"):
        folder.link("mqtts://127.0.0.1:8883", "master", roles=("agv",))
    issuing = VdaCredentials(pki)
    made = issuing.link("mqtts://127.0.0.1:8883", "agv-07", roles=("agv",))
    assert made.identity is not None
    assert made.identity.role == "agv"
    assert VdaCredentials(insecure=True).identity("agv-01", role="agv") is None


def test_the_broker_configuration_requires_certificates(pki: TemporaryPki) -> None:
    tls = pki.identity(BROKER_ID, role="router")
    text = broker_config(host="127.0.0.1", port=8883, tls=tls, acl_file=Path("/x/acl"))
    for line in (
        "allow_anonymous false",
        "acl_file /x/acl",
        "listener 8883 127.0.0.1",
        f"cafile {tls.ca}",
        f"certfile {tls.cert}",
        f"keyfile {tls.key}",
        f"crlfile {tls.crl}",
        "require_certificate true",
        "use_identity_as_username true",
        "use_username_as_clientid true",
        "tls_version tlsv1.3",
    ):
        assert line in text.splitlines()
    plain = broker_config(host="127.0.0.1", port=1883, tls=None, acl_file=None)
    assert "allow_anonymous true" in plain.splitlines()
    assert "cafile" not in plain


def test_a_broker_needs_a_certificate_naming_its_address(pki: TemporaryPki) -> None:
    with pytest.raises(LocalProtocolError, match="not both"):
        LocalBroker()
    with pytest.raises(LocalProtocolError, match="loopback only"):
        LocalBroker(insecure=True, host="10.0.0.5")
    unnamed = pki.identity("broker-2", role="router")
    with pytest.raises(CredentialError, match=r"does not name 127\.0\.0\.1.*--address"):
        LocalBroker(unnamed)
    named = pki.identity("broker-3", role="router", addresses=("10.0.0.5", "broker.local"))
    LocalBroker(named, host="10.0.0.5")
    LocalBroker(named, host="broker.local")


async def test_a_bridge_refuses_a_certificate_of_another_vehicle(pki: TemporaryPki) -> None:
    one = OneVehicle()
    link = mqtt_link("mqtts://127.0.0.1:1", tls=pki.identity("agv-02", role="agv"))
    with pytest.raises(CredentialError, match="serial number is 'agv-01'"):
        await run_bridge(one.endpoint, link)


def test_an_unreachable_broker_is_named() -> None:
    url = f"mqtt://127.0.0.1:{free_port()}"
    with pytest.raises(BrokerError, match=f"broker {url} is unreachable"):
        probe_broker(mqtt_link(url, insecure=True))


@needs_mosquitto
async def test_a_plain_broker_on_loopback_carries_a_vehicle_when_asked_for_by_name() -> None:
    with LocalBroker(insecure=True) as address:
        assert address.url.startswith("mqtt://127.0.0.1:")
        link = mqtt_link(address, insecure=True)
        probe_broker(link)
        one = OneVehicle()
        counters = BridgeCounters()
        async with probe(link) as p:
            task = asyncio.get_running_loop().create_task(
                run_bridge(VdaEndpoint(one.agv, VehicleTopics("ObjectPlaces", "agv-01")), link,
                           counters=counters)
            )  # fmt: skip
            try:
                await p.wait_for(lambda: bool(p.of("agv-01", "state")), within=60, why="a state")
            finally:
                task.cancel()
                with pytest.raises(asyncio.CancelledError):
                    await task


@needs_mosquitto
@pytest.mark.processes
def test_the_broker_command_runs_until_sigterm_and_refuses_a_missing_pki(
    pki: TemporaryPki, tmp_path: Path
) -> None:
    command = [sys.executable, "-m", "agv_app.vda5050.broker"]
    missing = subprocess.run(
        [*command, "--pki", str(tmp_path / "none")], capture_output=True, text=True, timeout=60
    )
    assert missing.returncode == 2
    assert "not a folder" in missing.stderr
    assert "Traceback" not in missing.stderr
    port = free_port()
    with subprocess.Popen(
        [*command, "--pki", str(pki.directory), "--listen", f"127.0.0.1:{port}"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    ) as proc:
        try:
            assert proc.stdout is not None
            line = proc.stdout.readline()
            assert line.strip() == f"VDA 5050 broker at mqtts://127.0.0.1:{port}"
            master = pki.identity("master", role="master")
            probe_broker(mqtt_link(BrokerAddress("127.0.0.1", port), tls=master))
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(timeout=60) == 0
        finally:
            if proc.poll() is None:
                proc.kill()
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection(("127.0.0.1", port), 2).close()
