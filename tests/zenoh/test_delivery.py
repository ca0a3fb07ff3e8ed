"""The frames Zenoh delivered together reach the node machine in one call, in arrival
order with the other inputs, and a frame that fails costs only itself."""

from __future__ import annotations

import asyncio
import logging

import pytest

from objectplaces.core import codec
from objectplaces.core.messages import PropertyUpdate
from objectplaces.core.node import NodeMachine
from objectplaces.transport.zenoh_config import ZenohOptions
from objectplaces.transport.zenoh_transport import ZenohTransport
from objectplaces.zenoh_node import ZenohRunner


class Recorder:
    """A driver that writes down what it is handed."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, object]] = []

    def deliver_frames(self, frames: list[tuple[str, bytes]]) -> int:
        self.calls.append(("frames", list(frames)))
        return 1 if any(data == b"bad" for _, data in frames) else 0

    def send_properties_to(self, node: str) -> None:
        self.calls.append(("snapshot for", node))

    def __getattr__(self, name: str) -> object:
        raise AssertionError(f"unexpected call {name}")


def test_frames_go_together_and_in_order_with_other_inputs() -> None:
    transport = ZenohTransport("me", options=ZenohOptions(), incarnation=1)
    driver = Recorder()
    transport.attach(driver)  # type: ignore[arg-type]
    transport._on_items(
        [
            ("frame", "a", b"1", None),
            ("frame", "b", b"bad", None),
            ("query", "asker", None),
            ("frame", "c", b"3", None),
        ]
    )
    assert driver.calls == [
        ("frames", [("a", b"1"), ("b", b"bad")]),
        ("snapshot for", "asker"),
        ("frames", [("c", b"3")]),
    ]
    assert transport.counters["frames_in"] == 3
    assert transport.counters["bytes_in"] == 5
    assert transport.counters["driver_errors"] == 1


async def test_a_failing_frame_costs_only_itself(caplog: pytest.LogCaptureFixture) -> None:
    loop = asyncio.get_running_loop()
    machine = NodeMachine("me", now=loop.time())
    runner = ZenohRunner(machine, lambda output: 0)
    heard: list[str] = []
    receive = machine.receive

    def receive_or_fail(source: str, data: bytes, now: float) -> None:
        if source == "bad":
            raise RuntimeError("boom")
        heard.append(source)
        receive(source, data, now)

    machine.receive = receive_or_fail  # type: ignore[method-assign]
    frame = codec.encode(PropertyUpdate(1, {"position": (1.0, 2.0)}))
    with caplog.at_level(logging.ERROR, logger="objectplaces.zenoh"):
        failed = runner.deliver_frames([("a", frame), ("bad", frame), ("c", frame)])
    assert failed == 1
    assert heard == ["a", "c"]
    assert "a frame from bad failed" in caplog.text
    runner.close()
