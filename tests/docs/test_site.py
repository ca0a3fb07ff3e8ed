"""The documentation site: ``mkdocs build --strict`` (what ``make docs`` runs) builds it
offline, and every name a public module exports has its entry in the API reference."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from mkdocs.config import load_config

ROOT = Path(__file__).resolve().parents[2]
MKDOCS = Path(sys.executable).parent / "mkdocs"

PUBLIC_MODULES = [
    "objectplaces",
    "objectplaces.groups",
    "objectplaces.sim",
    "objectplaces.mesh",
    "objectplaces.zenoh_node",
    "objectplaces.security",
    "objectplaces.extras",
    "tuplespace",
]
"""The modules ``docs/api.md`` documents: everything importable a reader may rely on."""


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site, built once for this module's tests."""
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    done = subprocess.run(
        [str(MKDOCS), "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def _nav_pages(entries: object) -> set[str]:
    if isinstance(entries, str):
        return {entries}
    if isinstance(entries, list):
        return set().union(*(_nav_pages(entry) for entry in entries))
    if isinstance(entries, dict):
        return set().union(*(_nav_pages(entry) for entry in entries.values()))
    return set()


def test_the_site_builds_with_every_page_in_its_navigation(site: Path) -> None:
    nav = _nav_pages(load_config(str(ROOT / "mkdocs.yml"))["nav"])
    for page in sorted((ROOT / "docs").glob("*.md")):
        assert page.name in nav, f"{page.name} is not in mkdocs.yml's nav"
        built = site / "index.html" if page.stem == "index" else site / page.stem / "index.html"
        assert built.is_file(), f"{page.name} is not on the site"


@pytest.mark.parametrize("module", PUBLIC_MODULES)
def test_every_public_name_is_in_the_reference(site: Path, module: str) -> None:
    html = (site / "api" / "index.html").read_text()
    entries = set(re.findall(r'id="([A-Za-z_][\w.]*)"', html))
    exported = importlib.import_module(module).__all__
    missing = [name for name in exported if f"{module}.{name}" not in entries]
    assert not missing, f"{module}: no entry in docs/api.md for {missing} (a docstring?)"


WORDS_OUTSIDE_REFERENCE = 20_000
"""The most words the pages outside the reference may hold together."""
WORDS_PER_PAGE = 4_000
"""The most words one page may hold."""


def test_the_docs_stay_short_enough_to_read() -> None:
    nav = load_config(str(ROOT / "mkdocs.yml"))["nav"]
    reference = next(entry["Reference"] for entry in nav if "Reference" in entry)
    words = {page.name: len(page.read_text().split()) for page in (ROOT / "docs").glob("*.md")}
    long_pages = {name: n for name, n in words.items() if n > WORDS_PER_PAGE}
    assert not long_pages, f"pages over {WORDS_PER_PAGE} words: {long_pages}"
    outside = sum(n for name, n in words.items() if name not in _nav_pages(reference))
    assert outside <= WORDS_OUTSIDE_REFERENCE, (
        f"{outside} words outside the reference, more than {WORDS_OUTSIDE_REFERENCE}: "
        f"condense a page or move what it looks up into the reference ({sorted(words.items())})"
    )
