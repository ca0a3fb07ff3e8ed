"""A seeded fleet replays exactly, whatever order Python's string hashing gives sets.

Each run is a process of its own with its own ``PYTHONHASHSEED``: a role that iterated a
set of node ids (the requester's ``end`` messages did) sends in an order that changes
from process to process, and under loss every later random draw moves with it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]

_RUN = """
import json
from agv_app.fleet import Fleet, FleetConfig
fleet = Fleet(None, FleetConfig(agvs=20, seed=4, load=0.9, delay=0.05, jitter=0.025, loss=0.1))
fleet.run(60.0)
summary = fleet.summary()
keys = ("messages", "bytes", "locks_granted", "tasks_completed")
print(json.dumps({k: summary[k] for k in keys}))
"""


def _run(hash_seed: str) -> dict[str, float]:
    env = {**os.environ, "PYTHONHASHSEED": hash_seed, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-c", _RUN], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    figures: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    return figures


@pytest.mark.slow
def test_a_lossy_fleet_gives_the_same_figures_under_two_hash_seeds() -> None:
    first, second = _run("1"), _run("2")
    assert first["messages"] > 0
    assert first == second
