"""The two start modes of a DE run (DESIGN.md "Two start modes everywhere a run starts").

* ``"seeded"`` (the product's default): the problem's own ``initial_population(rng, n)`` hook,
  when it has one (the UAV problem's sensor-aware starts, :mod:`planner_core.seeding`).
* ``"uniform"`` (the paper's protocol, as every optimiser of its Table 2): the initial
  population uniform in the box, whatever the problem offers.
"""

from __future__ import annotations

from typing import Any

import numpy as np

INIT_MODES = ("seeded", "uniform")
DEFAULT_INIT = "seeded"


class UniformStart:
    """A problem seen without its ``initial_population`` hook (so the DE starts uniform).

    Exposes ``lower``, ``upper``, ``evaluate`` and the wrapped problem as ``problem``.
    """

    def __init__(self, problem: Any) -> None:
        self.problem = problem
        self.lower = problem.lower
        self.upper = problem.upper

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.problem.evaluate(X)


def with_init(problem: Any, init: str) -> Any:
    """``problem`` as the DE should see it for start mode ``init`` ("seeded" or "uniform").

    Raises ValueError for any other mode.
    """
    if init == "seeded":
        return problem
    if init == "uniform":
        return UniformStart(problem)
    raise ValueError(f"init: unknown start mode {init!r}, choose one of {', '.join(INIT_MODES)}")
