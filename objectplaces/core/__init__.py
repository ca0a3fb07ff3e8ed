"""The sans-I/O core of ObjectPlaces: inputs in, outputs out; no clock, sockets or randomness.

Its modules, bottom up (each imports only lower ones; tests/test_architecture.py checks):

* ``errors``, ``ids``, ``spatial``: exceptions, identifiers, the uniform grid index;
* ``messages``, ``groups``, ``events``, ``values``: what travels, group definitions,
  what the machine asks its driver to do, what a value may be;
* ``codec``, ``outbox``, ``roles``: the wire format, the driver-bound queue, role classes;
* ``channel``, ``config``: one reliable channel with flow control; the tunables;
* ``timers``, ``observers``, ``intake``, ``rest``: typed timers, application
  observers, frames refused at the boundary, the longer wait granted a peer at rest;
* ``own``, ``channels``, ``plumbing``, ``liveness``: this node's properties; channel
  frames on the wire; what every part shares; the heartbeat and the liveness beat;
* ``view``: the others' properties, liveness, index, scope and completeness;
* ``sessions``, ``participations``: the initiator side and the participant side;
* ``bindings``, ``introspection``: the context a role is bound to; what the machine
  shows of itself;
* ``node``: ``NodeMachine``, the router that owns the order of operations.

docs/protocol.md says what the nodes say to each other, and why; its sections (§) are
cited throughout.
"""

__all__: list[str] = []
