"""The optional parts of the install, and the error a missing one raises.

``pip install objectplaces`` brings the middleware alone: the simulator, the WebSocket
mesh, mutual TLS. The rest comes with extras:

=============  ==========================================  =================================
extra          brings                                      for
=============  ==========================================  =================================
``zenoh``      eclipse-zenoh                               ``transport="zenoh"``, the router
``fleet``      shapely, jsonschema, rich, aiomqtt          the AGV fleet (``agv_app``), its
                                                           commands, VDA 5050 over MQTT
``vda5050``    what ``fleet`` brings                       the same, by the standard's name
``dashboard``  ``fleet``, fastapi, uvicorn, pydantic       the dashboard, ``objectplaces
                                                           demo`` and ``control``
``all``        every extra above                           the whole demo
=============  ==========================================  =================================

An import that needs a missing extra fails with an ``ImportError`` that names it:
``pip install 'objectplaces[zenoh]'``.
"""

from __future__ import annotations

import importlib.util

__all__ = ["EXTRAS", "MODULES", "missing_extra", "require"]

EXTRAS: dict[str, tuple[str, ...]] = {
    "zenoh": ("zenoh",),
    "fleet": ("shapely", "jsonschema", "rich", "aiomqtt"),
    "vda5050": ("shapely", "jsonschema", "rich", "aiomqtt"),
    "dashboard": ("fastapi", "fastapi_offline", "uvicorn", "pydantic"),
}
"""Extra -> the top-level modules it brings (the ones our code imports)."""

MODULES: dict[str, str] = {
    "zenoh": "zenoh",
    "shapely": "fleet",
    "jsonschema": "fleet",
    "rich": "fleet",
    "aiomqtt": "fleet",
    "fastapi": "dashboard",
    "fastapi_offline": "dashboard",
    "starlette": "dashboard",
    "uvicorn": "dashboard",
    "pydantic": "dashboard",
    "pydantic_core": "dashboard",
}
"""Top-level module -> the extra that brings it."""


def missing_extra(error: ModuleNotFoundError, needed_by: str) -> ImportError:
    """The error to raise when ``needed_by`` could not import a module of an extra.

    Args:
        error: the import's error (its ``name`` is the missing module).
        needed_by: what needed it, for the message ("the Zenoh transport").

    Returns:
        An ``ImportError`` naming the module and the extra to install (``all`` for a
        module no extra names); raise it ``from error``.
    """
    module = (error.name or "").partition(".")[0]
    extra = MODULES.get(module, "all")
    return ImportError(
        f"{needed_by} needs {module or 'a module'!r}, which is not installed: "
        f"pip install 'objectplaces[{extra}]'",
        name=module or None,
    )


def require(extra: str, needed_by: str) -> None:
    """Check that every module of ``extra`` can be imported, without importing any.

    Raises:
        ImportError: one is missing; the message names the extra to install.
        KeyError: ``extra`` is no extra of ours.
    """
    for module in EXTRAS[extra]:
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):  # a finder refused it, or a None in sys.modules
            found = False
        if not found:
            raise missing_extra(ModuleNotFoundError(name=module), needed_by)
