"""The ``zenoh`` package, for the modules of the Zenoh transport: imported here once,
so that a missing ``[zenoh]`` extra fails with a message that says how to install it."""

from __future__ import annotations

from objectplaces.extras import missing_extra

try:
    import zenoh
except ModuleNotFoundError as error:
    raise missing_extra(error, "the Zenoh transport (objectplaces.zenoh_node)") from error

__all__ = ["zenoh"]
