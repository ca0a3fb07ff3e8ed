"""The install is embeddable: the middleware imports and runs without any extra, and
whatever needs a missing extra says which one to install."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

from objectplaces.extras import EXTRAS, MODULES

ROOT = Path(__file__).resolve().parent.parent
EVERY_EXTRA_MODULE = sorted(MODULES)

BLOCK = """
import importlib.abc, sys
BLOCKED = set({blocked!r})
class Blocker(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
sys.meta_path.insert(0, Blocker())
"""


def run(code: str, blocked: list[str]) -> subprocess.CompletedProcess[str]:
    script = BLOCK.format(blocked=blocked) + textwrap.dedent(code)
    return subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=ROOT
    )


def test_the_core_dependencies_are_the_middlewares_only() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = {d.split(">")[0].split("[")[0] for d in project["dependencies"]}
    assert names == {"msgpack", "websockets", "cryptography", "mypy-extensions"}
    extras = project["optional-dependencies"]
    assert set(EXTRAS) <= set(extras)
    assert "objectplaces[all,docs]" in extras["dev"]  # make demo and make test: everything


def test_the_middleware_imports_and_runs_without_any_extra() -> None:
    done = run(
        """
        import objectplaces, objectplaces.cli, objectplaces.mesh, objectplaces.node_cli
        import objectplaces.pki_cli, objectplaces.security, tuplespace
        from objectplaces import Initiator, Participant, groups
        from objectplaces.sim import SimulatedNetwork

        net = SimulatedNetwork(seed=1)
        a, b = net.add_node("a"), net.add_node("b")
        for node, x in ((a, 0.0), (b, 1.0)):
            node.update_node_property("position", (x, 0.0))
        b.set_participant_factory("p", Participant)
        role = Initiator()
        a.start_interaction(role, groups.within(5) & groups.property_below("x", 1), "p")
        net.run_for(1.0)
        assert [m.node_id for m in role.members] == [], role.members
        print("ran", sorted(m for m in sys.modules if m.partition(".")[0] in BLOCKED))
        """,
        EVERY_EXTRA_MODULE,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ran []"


@pytest.mark.parametrize(
    ("module", "blocked", "extra"),
    [
        ("objectplaces.zenoh_node", ["zenoh"], "zenoh"),
        ("objectplaces.zenoh_router", ["zenoh"], "zenoh"),
        ("agv_app", ["shapely"], "fleet"),
        ("agv_app", ["aiomqtt"], "fleet"),
    ],
)
def test_an_import_that_needs_a_missing_extra_names_it(
    module: str, blocked: list[str], extra: str
) -> None:
    done = run(f"import {module}", blocked)
    assert done.returncode == 1
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: ")
    assert f"pip install 'objectplaces[{extra}]'" in last


def test_a_command_whose_extra_is_missing_says_what_to_install() -> None:
    code = """
    from objectplaces.cli import main
    sys.exit(main(sys.argv[1:]))
    """
    listed = run(code + "\n", EVERY_EXTRA_MODULE)
    assert listed.returncode == 2  # no command given: the help, then 2
    for name, extra in (("sim", "fleet"), ("demo", "dashboard"), ("router", "zenoh")):
        script = BLOCK.format(blocked=EVERY_EXTRA_MODULE) + textwrap.dedent(code)
        done = subprocess.run(
            [sys.executable, "-c", script, name, "--agvs", "3"],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=ROOT,
        )
        assert done.returncode == 2
        assert f"pip install 'objectplaces[{extra}]'" in done.stderr
