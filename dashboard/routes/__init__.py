"""The REST API and the feed, one router per concern; ``ROUTERS`` lists them all."""

from __future__ import annotations

from fastapi import APIRouter

from dashboard.routes import (
    access,
    blocks,
    docs,
    events,
    fleet,
    groups,
    log,
    membership,
    nodes,
    operate,
    page,
    sessions,
    sim,
    space,
    tasks,
    vehicle_detail,
    vehicles,
)

__all__ = ["ROUTERS"]

ROUTERS: tuple[APIRouter, ...] = (
    space.router,
    nodes.router,
    sessions.router,
    membership.router,
    groups.router,
    fleet.router,
    vehicles.router,
    vehicle_detail.router,
    operate.router,
    blocks.router,
    tasks.router,
    sim.router,
    log.router,
    events.router,
    page.router,
    docs.router,
    access.router,
)
"""Every router of the app, in the order the OpenAPI lists them."""
