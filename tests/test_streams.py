"""The planner's random streams (`planner_core.streams`): one table of tags, one derivation."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.streams import STREAMS, stream_rng, stream_seed


def test_every_step_has_its_own_tag() -> None:
    assert len(set(STREAMS.values())) == len(STREAMS)


@pytest.mark.parametrize("name", sorted(STREAMS))
def test_a_stream_is_the_seed_sequence_of_its_key(name: str) -> None:
    key = [7, STREAMS[name], 3, 1]
    want = np.random.default_rng(np.random.SeedSequence(key)).random(4)
    assert np.array_equal(stream_rng(7, name, 3, 1).random(4), want)
    assert stream_seed(7, name, 3, 1) == int(np.random.SeedSequence(key).generate_state(1)[0])


def test_streams_differ_by_name_and_index() -> None:
    draws = {(n, k): stream_rng(0, n, k).integers(2**62) for n in STREAMS for k in (0, 1)}
    assert len(set(draws.values())) == len(draws)


def test_an_unknown_stream_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match="^stream: must be one of kmeans"):
        stream_rng(0, "kick")
