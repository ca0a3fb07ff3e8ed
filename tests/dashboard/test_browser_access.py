"""Access in real headless chromium: the login URL, and a page of another local origin
that tries what such a page could do to a dashboard with no token."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.conftest import NetworkSource
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS

ATTACK = """
<!doctype html><meta charset="utf-8"><title>another local page</title>
<script type="module">
const target = "%(target)s";
const outcome = { posts: [], feed: { opened: false, messages: 0, chars: 0, closed: false } };
window.__attack = outcome;

async function attempt(name, init) {
  const pause = `${target}/api/sim/pause`;
  try {
    const r = await fetch(pause, { method: "POST", credentials: "include", ...init });
    outcome.posts.push([name, r.type === "opaque" ? "opaque" : r.status]);
  } catch (err) {
    outcome.posts.push([name, "blocked"]);
  }
}

// A JSON body: the browser asks first (CORS), and the dashboard does not answer yes.
await attempt("json", { headers: { "Content-Type": "application/json" }, body: "{}" });
// A "simple" request, sent without asking: it reaches the server with the login cookie.
await attempt("text", { mode: "no-cors", headers: { "Content-Type": "text/plain" }, body: "{}" });
await attempt("form", { mode: "no-cors", body: new URLSearchParams({ reason: "x" }) });

// The feed: a WebSocket is no subject of CORS at all, and carries the cookie.
const socket = new WebSocket(target.replace("http", "ws") + "/ws/events");
socket.onopen = () => { outcome.feed.opened = true; };
socket.onmessage = (event) => { outcome.feed.messages++; outcome.feed.chars += event.data.length; };
socket.onclose = () => { outcome.feed.closed = true; };
</script>
"""


class AttackerSite:
    """A web server on another loopback port: the other local origin."""

    def __init__(self, target: str) -> None:
        page = (ATTACK % {"target": target}).encode()

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                self.send_response(200)
                self.send_header("Content-Type", "text/html; charset=utf-8")
                self.send_header("Content-Length", str(len(page)))
                self.end_headers()
                self.wfile.write(page)

            def log_message(self, format: str, *args: Any) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/"
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)

    def __enter__(self) -> AttackerSite:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.shutdown()
        self.thread.join(timeout=10)
        self.server.server_close()


@pytest.fixture
def served(source: NetworkSource) -> Iterator[Served]:
    with Served(source) as s:
        yield s


def test_the_login_url_leaves_the_token_out_of_the_address_bar(served: Served) -> None:
    with chromium_page() as (page, problems):
        load_dashboard(page, served)
        token = served.tokens.operator
        assert page.url == served.url + "/"
        assert page.evaluate("document.cookie") == ""  # HttpOnly: no script reads it
        (cookie,) = page.context.cookies()
        assert (cookie["httpOnly"], cookie["sameSite"]) == (True, "Strict")
        assert token not in cookie["value"]
        page.wait_for_function(
            "document.querySelector('#access-role').textContent === 'operator'", timeout=5_000
        )
        while page.go_back() is not None:  # no entry of the history holds it either
            assert token not in page.url
    assert problems == [], problems


def test_a_page_of_another_local_origin_can_neither_pause_nor_read_the_feed(
    served: Served,
) -> None:
    with AttackerSite(served.url) as attacker, chromium_page() as (page, _):
        load_dashboard(page, served)  # the victim is logged in as the operator
        page.goto(attacker.url)  # ... and opens another local page
        page.wait_for_function(
            "window.__attack && window.__attack.posts.length === 3 && window.__attack.feed.closed",
            timeout=10_000,
        )
        outcome = page.evaluate("window.__attack")
        assert outcome["posts"] == [["json", "blocked"], ["text", "opaque"], ["form", "opaque"]]
        assert outcome["feed"] == {"opened": False, "messages": 0, "chars": 0, "closed": True}
        assert not served.source.paused
        # The same request from the dashboard's own page works: the origin made the difference.
        page.goto(served.url + "/")
        page.evaluate(
            """async () => {
                const r = await fetch("/api/sim/pause", { method: "POST",
                    headers: { "Content-Type": "application/json" }, body: "{}" });
                return r.status;
            }"""
        )
        assert served.source.paused


def test_a_viewer_is_told_changes_need_the_operator_and_logs_out(served: Served) -> None:
    with chromium_page() as (page, problems):
        load_dashboard(page, served, "viewer")
        page.wait_for_function(
            "document.querySelector('#access-role').textContent === 'viewer'", timeout=5_000
        )
        page.click("#btn-pause")
        page.wait_for_function(
            "document.querySelector('#control-status').textContent.includes('operator')",
            timeout=5_000,
        )
        assert not served.source.paused
        page.click("#btn-logout")
        page.wait_for_url(served.url + "/login", timeout=5_000)
        assert page.context.cookies() == []
        page.fill("#login-token", "x" * 43)
        page.click("#login-button")
        page.wait_for_function(
            "document.querySelector('#login-status').textContent.includes('not a token')",
            timeout=5_000,
        )
        # A login URL opened over the login page changes only the fragment: it logs in too.
        load_dashboard(page, served, "operator")
        page.wait_for_function(
            "document.querySelector('#access-role').textContent === 'operator'", timeout=5_000
        )
    # Chromium logs the refused change (403) and the refused token (401) as failed resources.
    assert [p for p in problems if "403" not in p and "401" not in p] == [], problems
