"""Transports: the in-memory simulated network, the WebSocket mesh and Zenoh.

They import only ``objectplaces.core`` and each other, never a runtime: what they need
from whoever drives a node is the ``NodeDriver`` (and, for the in-memory network, the
``Scheduler``) in ``base``. Modules:

- ``base``: those Protocols, ``Endpoint`` and the cell key scheme;
- ``routing``: ``CellRouter``, who hears a publication (both transports);
- ``memory``: the in-memory network of the simulation;
- ``mesh_frames``: the mesh's own frames (handshake, gossip, subscriptions, batches);
- ``handshake``, ``directory``, ``policing``: the mesh's sans-I/O parts;
- ``options``: the mesh's limits and timings;
- ``link``, ``connector``, ``websocket``: the mesh's asyncio shell;
- ``zenoh_keys``, ``zenoh_alive``, ``zenoh_acl`` (sans-I/O), ``zenoh_config``,
  ``zenoh_roster``, ``zenoh_inbox``, ``zenoh_publishers``, ``zenoh_membership``,
  ``zenoh_declared``, ``zenoh_transport``: the Zenoh transport (docs/zenoh.md).
"""

__all__: list[str] = []
