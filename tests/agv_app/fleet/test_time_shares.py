"""bench/fleet.py's time shares: where the AGVs' time goes."""

from __future__ import annotations

import pytest

from bench.fleet import time_shares


def test_time_shares_cover_every_step_and_name_the_phases() -> None:
    shares = time_shares(agvs=3, minutes=1.0, seed=1, load=0.7)
    assert sum(shares.values()) == pytest.approx(1.0)
    assert list(shares.values()) == sorted(shares.values(), reverse=True)
    assert any(name.startswith("to_pick: ") for name in shares)
    phases = {"home", "to_home", "to_home+task", "to_pick", "at_pick", "to_drop", "at_drop"}
    assert {name.split(":")[0] for name in shares} <= phases
