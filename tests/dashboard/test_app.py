"""The app's shape: one thread of control."""

from __future__ import annotations

import inspect
from collections.abc import Iterator, Sequence
from typing import Any

from fastapi.dependencies.models import Dependant
from fastapi.routing import APIRoute, APIWebSocketRoute
from starlette.routing import BaseRoute

from dashboard.app import create_app
from tests.dashboard.conftest import NetworkSource


def calls(dependant: Dependant) -> Iterator[Any]:
    """Every callable FastAPI runs for a route: the endpoint and its dependencies."""
    if dependant.call is not None:
        yield dependant.call
    for sub in dependant.dependencies:
        yield from calls(sub)


def api_routes(routes: Sequence[BaseRoute]) -> Iterator[APIRoute | APIWebSocketRoute]:
    """Every API route, including those of included routers."""
    for route in routes:
        if isinstance(route, APIRoute | APIWebSocketRoute):
            yield route
        included = getattr(route, "original_router", None)
        if included is not None:
            yield from api_routes(included.routes)


def test_every_route_and_dependency_runs_on_the_event_loop(source: NetworkSource) -> None:
    app = create_app(source)
    routes = list(api_routes(app.routes))
    assert len(routes) >= 15
    threaded = [
        f"{route.path}: {fn.__name__}"
        for route in routes
        for fn in calls(route.dependant)
        if not inspect.iscoroutinefunction(fn)
    ]
    # FastAPI sends a plain `def` to a worker thread, where it would race the driver.
    assert threaded == []
