"""The snapshot a node sends each peer is encoded once per state, and is always the
bytes a fresh encoding of its values at its latest publication's number would be."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from objectplaces.core import codec
from objectplaces.core.config import NodeConfig
from objectplaces.core.events import Publish, Send
from objectplaces.core.messages import PropertyUpdate
from objectplaces.core.own import OwnProperties

STEPS = st.lists(
    st.one_of(
        st.tuples(
            st.just("set"), st.sampled_from(["status", "task", "position"]), st.integers(0, 3)
        ),
        st.tuples(st.just("publish"), st.none(), st.none()),
        st.tuples(st.just("republish"), st.none(), st.none()),
        st.tuples(st.just("snapshot"), st.none(), st.none()),
    ),
    max_size=30,
)


def plain_snapshot(own: OwnProperties, seq: int) -> bytes:
    """What the snapshot was before it was kept: encoded anew for every peer."""
    return codec.encode(PropertyUpdate(seq, dict(own.values), full=True))


@given(steps=STEPS, scoped=st.booleans())
def test_every_snapshot_is_the_fresh_encoding_of_the_values_now(
    steps: list[tuple[str, str | None, int | None]], scoped: bool
) -> None:
    config = NodeConfig(interest_radius=20.0) if scoped else NodeConfig()
    own = OwnProperties(config)
    seq = 0
    for what, name, value in steps:
        if what == "set":
            assert name is not None
            own.set(name, (25.0 * (value or 0), 0.0) if name == "position" else value)
        elif what in ("publish", "republish"):
            out = own.take_update() if what == "publish" else own.republish()
            if out is not None:
                seq += 1
                if isinstance(out, Publish) and out.snapshot is not None:
                    assert out.snapshot == plain_snapshot(own, seq)
        else:
            sent = own.full_update_for("peer")
            if own.values:
                assert isinstance(sent, Send)
                assert sent.data == plain_snapshot(own, seq)
            else:
                assert sent is None


def test_peers_asking_in_one_state_get_one_encoding() -> None:
    own = OwnProperties(NodeConfig())
    own.set("status", "idle")
    first, second = own.full_update_for("a"), own.full_update_for("b")
    assert isinstance(first, Send)
    assert isinstance(second, Send)
    assert first.data is second.data
    own.set("status", "busy")
    third = own.full_update_for("c")
    assert isinstance(third, Send)
    assert third.data is not first.data
    assert codec.decode(third.data) == PropertyUpdate(0, {"status": "busy"}, full=True)
