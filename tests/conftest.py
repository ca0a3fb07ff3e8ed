"""Suite-wide test settings."""

from __future__ import annotations

import os

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
