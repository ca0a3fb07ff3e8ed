"""Every public module declares ``__all__``, and each name in it exists."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ["tuplespace", "objectplaces", "agv_app", "dashboard"]


def public_modules() -> list[str]:
    names = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if any(part.startswith("_") and part != "__init__" for part in parts):
                continue
            if parts[-1] == "__init__":
                parts = parts[:-1]
            names.append(".".join(parts))
    return names


@pytest.mark.parametrize("name", public_modules())
def test_module_declares_all_and_every_name_exists(name: str) -> None:
    module = importlib.import_module(name)
    exported = getattr(module, "__all__", None)
    assert exported is not None, f"{name} has no __all__"
    for symbol in exported:
        assert hasattr(module, symbol), f"{name}.__all__ names {symbol!r}, which does not exist"


def test_the_public_api_of_the_design_is_importable() -> None:
    from objectplaces import Initiator, Participant, RoleActivator, groups
    from objectplaces.sim import SimulatedNetwork

    assert all([Initiator, Participant, RoleActivator, SimulatedNetwork])
    for name in ("circles_overlap", "within", "property_equals", "definition_from_json"):
        assert callable(getattr(groups, name))
