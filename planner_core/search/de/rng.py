"""The DE's random streams: generation g of a run draws from the root PCG64 of the run's seed
advanced by g * 2^64, so every generation's randomness is a pure function of (seed, g)."""

from __future__ import annotations

import numpy as np

from planner_core.search.de.types import DEState

__all__ = ["GENERATION_STRIDE", "Streams", "generation_rng"]


#: PCG64 steps between the random streams of consecutive generations (a generation draws a few
#: thousand words, so streams never overlap)
GENERATION_STRIDE = 1 << 64


class Streams:
    """The random streams of one seed: generation g's generator is the root PCG64 of
    ``SeedSequence(seed)`` advanced by ``g * GENERATION_STRIDE``.

    Keeps the root state and one reusable bit generator, so a generator costs a state copy and
    an advance instead of building a SeedSequence and a PCG64 (most of a generation's fixed
    cost). A generator from :meth:`rng` is valid until the next call.
    """

    def __init__(self, seed: int) -> None:
        self.seed = int(seed)
        self._root = np.random.PCG64(np.random.SeedSequence(self.seed)).state
        self._bits = np.random.PCG64(0)

    def rng(self, generation: int) -> np.random.Generator:
        """Generation g's generator (valid until the next call: its bit generator is shared).

        Args:
            generation: g, >= 0.

        Returns:
            A Generator over the root PCG64 advanced by g * `GENERATION_STRIDE`.
        """
        self._bits.state = self._root
        self._bits.advance(int(generation) * GENERATION_STRIDE)
        return np.random.Generator(self._bits)


def generation_rng(state: DEState) -> np.random.Generator:
    """The Generator of generation ``state.generation``: pure in (seed, generation).

    Args:
        state: its `seed` and `generation` read.

    Returns:
        A fresh Generator (its own `Streams`).
    """
    return Streams(state.seed).rng(state.generation)
