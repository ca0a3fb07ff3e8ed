"""Suite-wide test settings."""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, settings

# Hypothesis's derandomized profile for CI: the same examples on every run, no
# per-example deadline and no complaint about slow generation (shared CI machines
# stall). Locally, examples stay random.
settings.register_profile(
    "ci",
    derandomize=True,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
if os.environ.get("CI"):
    settings.load_profile("ci")


def pytest_sessionstart(session: object) -> None:
    """On the compiled build (tests.compiled_suite), every compiled module must load
    from it: a run that quietly fell back to the source would prove nothing."""
    from objectplaces.compiled import ACTIVE_ENV, loaded_compiled

    if not os.environ.get(ACTIVE_ENV):
        return
    import importlib

    from agv_app.fleet.compiled import SIM_MODULES

    for name in SIM_MODULES:
        importlib.import_module(name)
    missing = sorted(set(SIM_MODULES) - set(loaded_compiled(SIM_MODULES)))
    if missing:
        raise pytest.UsageError(f"not loaded from the compiled build: {', '.join(missing)}")
