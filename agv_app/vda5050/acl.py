"""The broker's access list: each certificate may use the topics its id and role give it.

The broker (``agv_app.vda5050.broker``) takes a client's user name and client id from
the common name of its certificate, the member's id (``use_identity_as_username``,
``use_username_as_clientid``), and checks every subscription, delivery and publication
against this list, in mosquitto's ``acl_file`` format:

- every member, as the vehicle whose serial number is its id (``pattern`` lines; ``%u``
  is the user name): reads its own ``order`` and ``instantActions``, writes its own
  ``state``, ``visualization``, ``connection`` and ``factsheet``, and nothing else;
- a master control (role ``master``): reads every vehicle's topics and writes every
  vehicle's ``order`` and ``instantActions``;
- an observer (role ``control``: the dashboard's broker monitor): reads every
  vehicle's topics, writes nothing.

Masters and observers are listed by id from the PKI's ``members.json``, revoked ones
left out; the broker re-reads the list when that file changes. Anything not granted is
refused: an anonymous client never gets this far (certificates are required).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Final

from agv_app.vda5050.topics import INTERFACE, MAJOR_VERSION, MANUFACTURER, TO_MASTER, TO_VEHICLE
from objectplaces.security import Issued

__all__ = ["OBSERVER_ROLES", "access_list"]

OBSERVER_ROLES: Final = ("control",)
"""Roles that may read every vehicle's topics (and write none)."""

_MASTER_ROLES: Final = ("master",)


def _section(node_id: str, read: str, writes: Iterable[str]) -> list[str]:
    return [f"user {node_id}", f"topic read {read}", *(f"topic write {w}" for w in writes), ""]


def access_list(members: Iterable[Issued], *, manufacturer: str = MANUFACTURER) -> str:
    """The access list for the PKI members ``members`` (``objectplaces.security.issued``).

    Args:
        members: every certificate the fleet CA issued (revoked ones are left out).
        manufacturer: the manufacturer level of the vehicles' topics.

    Returns:
        The text of a mosquitto ``acl_file``, the same for the same members.
    """
    own = f"{INTERFACE}/{MAJOR_VERSION}/{manufacturer}/%u"
    every = f"{INTERFACE}/{MAJOR_VERSION}/+/+"
    lines = [
        "# Every member, as the vehicle its id names: its own commands in, its own reports out.",
        *(f"pattern read {own}/{s}" for s in TO_VEHICLE),
        *(f"pattern write {own}/{s}" for s in TO_MASTER),
        "",
    ]
    current = sorted({(m.node_id, m.role) for m in members if m.revoked is None})
    for node_id, role in current:
        if role in _MASTER_ROLES:
            lines.append(f"# master control {node_id}: reads every vehicle, commands every vehicle")
            lines += _section(node_id, f"{every}/#", (f"{every}/{s}" for s in TO_VEHICLE))
        elif role in OBSERVER_ROLES:
            lines.append(f"# observer {node_id}: reads every vehicle")
            lines += _section(node_id, f"{every}/#", ())
    return "\n".join(lines)
