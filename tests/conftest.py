"""Suite-wide test settings."""

from __future__ import annotations

import os

from hypothesis import settings

# Hypothesis's derandomized profile for CI: the same examples on every run, no
# per-example deadline (shared CI machines stall). Locally, examples stay random.
settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
