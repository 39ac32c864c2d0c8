"""The two start modes of a run (DESIGN.md "Two start modes everywhere a run starts").

* ``"seeded"`` (the product's default): the problem's own ``initial_population(rng, n)`` hook,
  when it has one (the UAV problem's sensor-aware starts, :mod:`planner_core.model.seeding`).
* ``"uniform"`` (the paper's protocol, as every optimiser of its Table 2, Sec. 5.1): the initial
  population uniform in the box, whatever the problem offers.

Used by ``plan(..., init=...)``, meta-training and the benchmark (``bench --init``); the mode
names and the default live in the defaults table.
"""

from __future__ import annotations

from typing import Any

from planner_core.defaults import INIT_MODES

__all__ = ["INIT_MODES", "UniformStart", "with_init"]


class UniformStart:
    """A problem seen without its ``initial_population`` hook: every optimiser that asks for
    the hook (our DE, CMA-ES's first point, scipy's DE) starts uniform in the box instead.
    Every other attribute (``lower``, ``upper``, ``evaluate``, ``breakdown``, ...) is the wrapped
    problem's, which is also ``problem``."""

    def __init__(self, problem: Any) -> None:
        self.problem = problem

    def __getattr__(self, name: str) -> Any:
        if name in ("initial_population", "problem"):  # "problem": safe before __init__ ran
            raise AttributeError(name)
        return getattr(self.problem, name)


def with_init(problem: Any, init: str) -> Any:
    """``problem`` as an optimiser should see it in start mode ``init``.

    Args:
        problem: the problem.
        init: the start mode, one of INIT_MODES ("seeded", "uniform").

    Returns:
        ``problem`` itself ("seeded") or a `UniformStart` around it ("uniform").

    Raises:
        ValueError: any other mode (naming the valid ones).
    """
    if init == "seeded":
        return problem
    if init == "uniform":
        return UniformStart(problem)
    raise ValueError(f"init: unknown start mode {init!r}, choose one of {', '.join(INIT_MODES)}")
