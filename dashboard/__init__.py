"""The live dashboard: a FastAPI app with a REST API and a WebSocket event feed.

``create_app(source)`` builds the app around any running fleet that satisfies
``FleetSource``; ``docs/dashboard.md`` documents the endpoints and the feed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from dashboard.source import FleetSource

if TYPE_CHECKING:
    from dashboard.app import create_app

__all__ = ["FleetSource", "create_app"]


def __getattr__(name: str) -> Any:
    # The web stack loads only when an app is built, so `objectplaces --help` (which
    # imports dashboard.cli) stays quick.
    if name == "create_app":
        from dashboard.app import create_app

        return create_app
    raise AttributeError(f"module 'dashboard' has no attribute {name!r}")
