"""``GET /``: the dashboard page (its files are mounted under ``/static``)."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import FileResponse

__all__ = ["router"]

router = APIRouter()


@router.get("/", include_in_schema=False)
async def index(request: Request) -> FileResponse:
    """The page."""
    return FileResponse(request.app.state.static_dir / "index.html")
