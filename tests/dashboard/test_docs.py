"""``/docs`` and ``/redoc`` load every asset from the server itself."""

from __future__ import annotations

import re

from tests.dashboard.conftest import TestClient


def asset_urls(html: str) -> list[str]:
    return re.findall(r"""(?:src|href)=["']([^"']+)["']""", html) + re.findall(
        r"""url: ?["']([^"']+)["']""", html
    )


def test_swagger_ui_page_names_only_local_assets(client: TestClient) -> None:
    r = client.get("/docs")
    assert r.status_code == 200
    urls = asset_urls(r.text)
    assert any(u.endswith("swagger-ui-bundle.js") for u in urls), urls
    for url in urls:
        assert url.startswith("/"), f"/docs loads {url} from elsewhere"
        assert client.get(url).status_code == 200, url


def test_redoc_page_names_only_local_assets(client: TestClient) -> None:
    r = client.get("/redoc")
    assert r.status_code == 200
    assert "fonts.googleapis" not in r.text
    urls = asset_urls(r.text)
    assert any(u.endswith("redoc.standalone.js") for u in urls), urls
    for url in urls:
        assert url.startswith("/"), f"/redoc loads {url} from elsewhere"
        assert client.get(url).status_code == 200, url


def test_docs_pages_stay_out_of_the_schema_and_unknown_assets_are_404(
    client: TestClient,
) -> None:
    paths = set(client.get("/openapi.json").json()["paths"])
    assert not {"/docs", "/redoc", "/docs/oauth2-redirect"} & paths
    assert client.get("/docs-assets/nothing.js").status_code == 404
    assert client.get("/docs-assets/../pyproject.toml").status_code == 404
