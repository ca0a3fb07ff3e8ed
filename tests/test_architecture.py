"""The import arrows point one way, and the core stays free of I/O.

dashboard -> agv_app -> objectplaces -> tuplespace; nothing imports dashboard;
objectplaces.core imports only the standard library, msgpack, and itself.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ["tuplespace", "objectplaces", "agv_app", "dashboard"]
ALLOWED = {
    "tuplespace": set(),
    "objectplaces": {"tuplespace"},
    "agv_app": {"objectplaces", "tuplespace"},
    "dashboard": {"agv_app", "objectplaces", "tuplespace"},
}
CORE_FORBIDDEN = {"asyncio", "time", "random", "socket", "websockets", "threading", "uuid"}


def imports_of(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
    return found


def modules(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("package", PACKAGES)
def test_imports_point_one_way(package: str) -> None:
    ours = set(PACKAGES)
    for path in modules(package):
        for name in imports_of(path):
            top = name.split(".")[0]
            if top in ours and top != package:
                assert top in ALLOWED[package], f"{path.relative_to(ROOT)} imports {name}"


def test_core_is_sans_io() -> None:
    stdlib = set(sys.stdlib_module_names)
    for path in modules("objectplaces/core"):
        for name in imports_of(path):
            top = name.split(".")[0]
            assert top not in CORE_FORBIDDEN, f"{path.relative_to(ROOT)} imports {name}"
            assert top in stdlib or top == "msgpack" or name.startswith("objectplaces.core"), (
                f"{path.relative_to(ROOT)} imports {name}"
            )
