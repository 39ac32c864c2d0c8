"""The first population of the peers that search the unit box (L-SRTDE, CMOCSO)."""

from __future__ import annotations

from typing import Any

import numpy as np


def unit_initial_population(problem: Any, rng: np.random.Generator, n: int,
                            d: int) -> np.ndarray:
    """n starting points in the unit box [0, 1]^d: the problem's `initial_population(rng, n)`
    hook (the seeded protocol) mapped from its bounds and clipped, else uniform draws (the
    paper's protocol).

    Args:
        problem: the problem; `lower`, `upper` (d,) bounds when it has the hook.
        rng: the run's generator (the hook and the uniform draws both use it).
        n: points; d: dimension.

    Returns:
        (n, d) points in [0, 1].
    """
    sampler = getattr(problem, "initial_population", None)
    if sampler is not None:
        X = np.asarray(sampler(rng, n), dtype=float)
        lo, hi = problem.lower, problem.upper
        return np.clip((X - lo) / (hi - lo), 0.0, 1.0)
    return rng.random((n, d))
