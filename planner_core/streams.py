"""The planner's random streams, in one table: each stochastic step of a run draws from its own
stream, derived from the run's seed and the step's tag (and, where a step runs several times,
its index) by numpy's `SeedSequence`, which hashes the whole key into the generator's state
(O'Neill's entropy pooling; numpy, "Parallel random number generation"). So a step's draws
do not depend on how many any other step made, and the same seed gives the same plan whatever
the budget lets the other steps do.

Read a stream with `stream_rng(seed, "kicks", round)`, or a derived seed for a sub-run (a DE
block, a window's pipeline, a fleet's sortie) with `stream_seed(seed, "window", step, t)`.
A new stochastic step adds its name here with a tag no other step uses (tests hold the tags
distinct; the pipeline's golden plans hold each stream to the bytes it gave before this
table). The benchmark's peers (`planner_core.bench.baselines`) and the landscape module keep
their own keys: they are other algorithms' seeds, not the planner's steps.
"""

from __future__ import annotations

import numpy as np

__all__ = ["STREAMS", "stream_rng", "stream_seed"]

#: stream name -> its tag, the second word of every key ([seed, tag, *indices])
STREAMS: dict[str, int] = {
    "kmeans": 14,  # construct.site_sets: the k-means inits of the constructive sweep
    "site-slide": 15,  # construct.candidate_plans: each site set's slide directions (index: set)
    "seeder-plans": 16,  # construct.seeder_plans
    "kicks": 17,  # structure.kicks (index: the improving round, none for the final stage's)
    "fresh": 31,  # schedule's fresh sweep (index: the sweep); the engineering peer's rounds
    "fleet": 33,  # fleet.search: the sortie planner's sub-runs and tour moves
    "repair": 37,  # stages.Repair: the DE again from the final population, memetic repair
    "de-block": 41,  # schedule's DE blocks (index: the step)
    "rebuild": 43,  # rebuild.rebuild (index: the improving round)
    "window": 47,  # schedule's windows (indices: the step, the try)
}


def _key(seed: int, name: str, more: tuple[int, ...]) -> list[int]:
    if name not in STREAMS:
        raise ValueError(f"stream: must be one of {', '.join(STREAMS)}, got {name!r}")
    return [int(seed), STREAMS[name], *(int(k) for k in more)]


def stream_rng(seed: int, name: str, *more: int) -> np.random.Generator:
    """The generator of stream `name` of a run with `seed`.

    Args:
        seed: the run's seed (an integer >= 0).
        name: a key of `STREAMS`.
        *more: the step's indices (integers >= 0), where it runs several times.

    Returns:
        ``np.random.default_rng(np.random.SeedSequence([seed, STREAMS[name], *more]))``.

    Raises:
        ValueError: an unknown name.
    """
    return np.random.default_rng(np.random.SeedSequence(_key(seed, name, more)))


def stream_seed(seed: int, name: str, *more: int) -> int:
    """A seed derived for a sub-run of stream `name`: the first 32-bit word of the state of
    ``SeedSequence([seed, STREAMS[name], *more])`` (0 .. 2**32 - 1; callers that need a signed
    32-bit seed shift it right by one).

    Args:
        seed: the run's seed (an integer >= 0).
        name: a key of `STREAMS`.
        *more: the step's indices (integers >= 0), where it runs several times.

    Returns:
        The derived seed, an int in 0 .. 2**32 - 1.

    Raises:
        ValueError: an unknown name.
    """
    return int(np.random.SeedSequence(_key(seed, name, more)).generate_state(1)[0])
