"""ObjectPlaces: roles and interaction sessions among mobile nodes.

The public API: ``RoleActivator`` (one per node), the role base classes ``Initiator``
and ``Participant``, the ``groups`` module of group definitions, ``SimulatedNetwork``
(in ``objectplaces.sim``) and, for real processes, ``start_node`` (in
``objectplaces.mesh``).
"""

from __future__ import annotations

from objectplaces import groups
from objectplaces.activator import NodeStats, ObserverHandle, RoleActivator, Session
from objectplaces.core.config import NodeConfig, ParticipationInfo, SessionInfo
from objectplaces.core.errors import (
    DecodeError,
    InvalidValueError,
    LocalProtocolError,
    NotPlainDataError,
    ObjectPlacesError,
    RemoteProtocolError,
)
from objectplaces.mesh import start_node
from objectplaces.roles import (
    Initiator,
    InitiatorRef,
    MemberSet,
    OutReason,
    Participant,
    ParticipantRef,
    TimerHandle,
)

__all__ = [
    "DecodeError",
    "Initiator",
    "InitiatorRef",
    "InvalidValueError",
    "LocalProtocolError",
    "MemberSet",
    "NodeConfig",
    "NodeStats",
    "NotPlainDataError",
    "ObjectPlacesError",
    "ObserverHandle",
    "OutReason",
    "Participant",
    "ParticipantRef",
    "ParticipationInfo",
    "RemoteProtocolError",
    "RoleActivator",
    "Session",
    "SessionInfo",
    "TimerHandle",
    "groups",
    "start_node",
]
