"""How the API answers errors: always ``{"detail": "<what was wrong>"}``.

A body or parameter that fails validation is 422 (400 when the JSON itself is
malformed), with each problem as ``<field>: <message>``; an ``HTTPException`` keeps its
status. ``ERROR_RESPONSES`` documents the 4xx answers in the OpenAPI.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from dashboard.schemas import ErrorOut

__all__ = ["ERROR_RESPONSES", "describe", "install_error_handlers", "validation_message"]

ERROR_RESPONSES: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorOut} for code in (400, 401, 403, 404, 409, 413, 415, 422, 429)
}
"""The error answers every route may give, for the OpenAPI."""


def describe(errors: Sequence[Any], *, where: str = "body") -> str:
    """Validation errors in words: ``<field path>: <message>`` joined by ``; ``.

    Args:
        errors: pydantic's error dicts.
        where: the name for an error that concerns the whole input.
    """
    parts: list[str] = []
    for err in errors:
        path = ".".join(str(p) for p in err.get("loc", ()) if p != "body") or where
        parts.append(f"{path}: {err.get('msg')}")
    return "; ".join(parts) or "invalid request"


def validation_message(exc: RequestValidationError) -> tuple[int, str]:
    """The status and the message for a request that failed validation.

    Returns:
        400 with the parser's complaint for malformed JSON; otherwise 422 with every
        problem ``describe``d.
    """
    for err in exc.errors():
        if err.get("type") == "json_invalid":
            ctx = err.get("ctx") or {}
            return 400, f"malformed JSON body: {ctx.get('error', err.get('msg'))}"
    return 422, describe(exc.errors())


async def _on_invalid(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, RequestValidationError)
    status, message = validation_message(exc)
    return JSONResponse({"detail": message}, status_code=status)


async def _on_http(request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, StarletteHTTPException)
    detail = exc.detail if isinstance(exc.detail, str) else json.dumps(exc.detail)
    return JSONResponse({"detail": detail}, status_code=exc.status_code, headers=exc.headers)


def install_error_handlers(app: FastAPI) -> None:
    """Make ``app`` answer validation and HTTP errors as ``{"detail": ...}``."""
    app.add_exception_handler(RequestValidationError, _on_invalid)
    app.add_exception_handler(StarletteHTTPException, _on_http)
