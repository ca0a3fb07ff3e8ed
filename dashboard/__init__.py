"""The live dashboard: a FastAPI app with a REST API and a WebSocket event feed.

``create_app(source)`` builds the app around any running fleet that satisfies
``FleetSource``; ``docs/dashboard.md`` documents the endpoints and the feed.
"""

from __future__ import annotations

from dashboard.source import FleetSource

__all__ = ["FleetSource"]
