"""``/docs`` and ``/redoc``: the OpenAPI documentation, served with no internet.

FastAPI's own pages load Swagger UI and ReDoc from a CDN; these serve the copies that
ship in the ``fastapi_offline`` package (mounted at :data:`DOCS_ASSETS_URL` by
``create_app``), so the documentation works on a floor network that reaches nothing
outside.
"""

from __future__ import annotations

from pathlib import Path

import fastapi_offline
from fastapi import APIRouter, Request
from fastapi.openapi.docs import (
    get_redoc_html,
    get_swagger_ui_html,
    get_swagger_ui_oauth2_redirect_html,
)
from fastapi.responses import HTMLResponse

__all__ = ["DOCS_ASSETS_DIR", "DOCS_ASSETS_URL", "router"]

DOCS_ASSETS_DIR = Path(fastapi_offline.__file__).resolve().parent / "static"
"""Swagger UI's and ReDoc's script, style sheet and icon, from the installed package."""

DOCS_ASSETS_URL = "/docs-assets"
"""Where ``create_app`` mounts :data:`DOCS_ASSETS_DIR`."""

router = APIRouter(include_in_schema=False)


@router.get("/docs")
async def swagger_ui(request: Request) -> HTMLResponse:
    """Swagger UI over ``/openapi.json``, every asset from this server."""
    root = request.scope.get("root_path", "")
    return get_swagger_ui_html(
        openapi_url=f"{root}{request.app.openapi_url}",
        title=f"{request.app.title} - Swagger UI",
        oauth2_redirect_url=f"{root}/docs/oauth2-redirect",
        swagger_js_url=f"{root}{DOCS_ASSETS_URL}/swagger-ui-bundle.js",
        swagger_css_url=f"{root}{DOCS_ASSETS_URL}/swagger-ui.css",
        swagger_favicon_url=f"{root}{DOCS_ASSETS_URL}/favicon.png",
    )


@router.get("/docs/oauth2-redirect")
async def swagger_ui_redirect() -> HTMLResponse:
    """Swagger UI's OAuth2 redirect page."""
    return get_swagger_ui_oauth2_redirect_html()


@router.get("/redoc")
async def redoc(request: Request) -> HTMLResponse:
    """ReDoc over ``/openapi.json``, every asset from this server (no web fonts)."""
    root = request.scope.get("root_path", "")
    page = get_redoc_html(
        openapi_url=f"{root}{request.app.openapi_url}",
        title=f"{request.app.title} - ReDoc",
        redoc_js_url=f"{root}{DOCS_ASSETS_URL}/redoc.standalone.js",
        redoc_favicon_url=f"{root}{DOCS_ASSETS_URL}/favicon.png",
        with_google_fonts=False,
    )
    # ReDoc's sidebar shows its maker's logo from a CDN; images from elsewhere stay unloaded.
    page.headers["Content-Security-Policy"] = "img-src 'self' data: blob:"
    return page
