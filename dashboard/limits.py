"""Size and nesting limits on what a client may send, checked before anything parses it.

Python's ``json`` parser recurses once per nesting level, so a body of a few thousand
``[`` exhausts the interpreter's stack, and a megabyte-long string costs memory and time
in every layer behind it. ``RequestLimits`` therefore reads at most ``max_bytes`` of a
request body (413 beyond) and measures its nesting with ``json_depth`` (a scan without
recursion; 422 beyond ``max_depth``) before FastAPI parses it. Query parameters that
carry JSON (``/api/groups/view?definition=``) go through ``json_depth`` in their route.
"""

from __future__ import annotations

import itertools
import json
import re

from starlette.types import ASGIApp, Message, Receive, Scope, Send

__all__ = [
    "MAX_BODY_BYTES",
    "MAX_JSON_DEPTH",
    "RequestLimits",
    "json_depth",
    "shown",
]

MAX_BODY_BYTES = 64 * 1024
"""Largest request body accepted, in bytes."""

MAX_JSON_DEPTH = 100
"""Deepest nesting of arrays and objects accepted in a JSON body or parameter (a group
definition of 32 levels, the deepest the API takes, nests 66 deep)."""

_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_NOT_BRACKET = bytes(b for b in range(256) if b not in b"[]{}")
_STEP = {ord("["): 1, ord("{"): 1, ord("]"): -1, ord("}"): -1}


def json_depth(text: bytes | str) -> int:
    """How deeply arrays and objects nest in ``text``: 0 for a scalar, 1 for ``[1]``.

    Brackets inside strings do not count. Malformed text gets a number too (it is the
    parser's job to reject it); an unterminated string counts its brackets, so the
    answer never falls short of what the parser would meet.
    """
    data = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else text
    brackets = _STRING.sub(b"", data).translate(None, _NOT_BRACKET)
    return max(itertools.accumulate(_STEP[b] for b in brackets), default=0)


def shown(value: object, *, limit: int = 80) -> str:
    """``repr(value)``, cut to about ``limit`` characters, for error messages.

    Messages name the value they refused, but never echo a megabyte back.
    """
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


class RequestLimits:
    """ASGI middleware: refuses request bodies that are too large or nest too deeply.

    A body over ``max_bytes`` is answered 413 (announced by ``Content-Length`` or found
    while reading); a JSON body nesting deeper than ``max_depth`` is answered 422. Both
    answers are ``{"detail": ...}`` like every other error. Anything else reaches the
    app with its body replayed unchanged; WebSockets and lifespan pass straight through.

    Args:
        app: the wrapped app.
        max_bytes: the largest body accepted.
        max_depth: the deepest JSON nesting accepted.
    """

    def __init__(
        self, app: ASGIApp, *, max_bytes: int = MAX_BODY_BYTES, max_depth: int = MAX_JSON_DEPTH
    ) -> None:
        self.app = app
        self.max_bytes = max_bytes
        self.max_depth = max_depth

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Check the body of an HTTP request, then hand the request on."""
        if scope["type"] != "http" or scope["method"] in ("GET", "HEAD", "OPTIONS"):
            await self.app(scope, receive, send)
            return
        too_large = f"request body over {self.max_bytes} bytes"
        declared = dict(scope["headers"]).get(b"content-length", b"")
        if declared.isdigit() and int(declared) > self.max_bytes:
            await _refuse(send, 413, too_large)
            return
        chunks: list[bytes] = []
        size = 0
        more = True
        while more:
            message = await receive()
            if message["type"] != "http.request":  # the client left
                return
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.max_bytes:
                await _refuse(send, 413, too_large)
                return
            chunks.append(chunk)
            more = message.get("more_body", False)
        body = b"".join(chunks)
        depth = json_depth(body)
        if depth > self.max_depth:
            await _refuse(
                send, 422, f"JSON body nests {depth} levels deep; at most {self.max_depth} allowed"
            )
            return
        await self.app(scope, _replay(body, receive), send)


def _replay(body: bytes, receive: Receive) -> Receive:
    sent = False

    async def replayed() -> Message:
        nonlocal sent
        if not sent:
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()  # after the body: wait for the disconnect as usual

    return replayed


async def _refuse(send: Send, status: int, detail: str) -> None:
    body = json.dumps({"detail": detail}).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})
