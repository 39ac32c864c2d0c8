"""Compile (or load from numba's disk cache) every kernel a plan calls, once per process, on a
tiny built-in map, so that a plan's stage times are planning and not compiling.

The map holds one obstacle of every kind (circle, rectangle, no-fly zone, polygon with a hole)
and four sensors; the whole default pipeline runs on it at a budget of `BUDGET` evaluations
with a population of `MIN_POPULATION`, which touches every compiled kernel (the DE's, the
model's, the overlap kernels, the LP's, the graph's and the tour's). Its wall time is what
`plan` reports as `timings["compile"]`; a process that already warmed up a configurator skips
it. Cost: ~0.1-0.5 s with the cache on disk; 50-90 s on the first run after install (2 CPUs,
2026-12-06), which `make setup` and `make demo` therefore pay as their last install step
(`python -m planner_core.pipeline.warmup`).
"""

from __future__ import annotations

import time
from typing import Any

__all__ = ["BUDGET", "WARMUP_MAP", "warm_kernels", "warm_up", "warmed"]

#: a 1.5 km map with one obstacle of every kind and four sensors
WARMUP_MAP: dict[str, Any] = {
    "name": "warm-up",
    "area": {"width": 1500, "height": 1500},
    "start": [50.0, 50.0],
    "end": [1450.0, 1400.0],
    "sensors": [
        {"id": "a", "x": 400.0, "y": 250.0},
        {"id": "b", "x": 800.0, "y": 700.0},
        {"id": "c", "x": 950.0, "y": 600.0},
        {"id": "d", "x": 1150.0, "y": 1150.0},
    ],
    "obstacles": {
        "circles": [{"x": 900.0, "y": 950.0, "radius": 60.0}],
        "rectangles": [{"x": 550.0, "y": 500.0, "length": 120.0, "width": 80.0,
                        "angle_deg": 30.0}],
        "no_fly_zones": [{"vertices": [[1100.0, 250.0], [1350.0, 300.0], [1300.0, 500.0],
                                       [1120.0, 450.0]]}],
        "polygons": [{"vertices": [[250.0, 700.0], [450.0, 700.0], [450.0, 900.0],
                                   [250.0, 900.0]],
                      "holes": [[[320.0, 770.0], [380.0, 770.0], [380.0, 830.0],
                                 [320.0, 830.0]]]}],
    },
    "uav": {"max_hover_points": 5},
}
#: evaluations of the warm-up run
BUDGET = 120

_WARM: set[str] = set()


def warmed(configurator: Any) -> bool:
    """Whether this process already warmed up for a configurator.

    Args:
        configurator: a registry name or a configurator object (keyed by its class name).

    Returns:
        True after a `warm_up` with it in this process.
    """
    return _key(configurator) in _WARM


def _key(configurator: Any) -> str:
    return configurator if isinstance(configurator, str) else type(configurator).__name__


def warm_up(configurator: Any = "adaptive") -> float:
    """Run the default pipeline once on `WARMUP_MAP` with `configurator`. Deterministic and
    side-effect free (nothing but numba's cache and this module's set of warmed
    configurators).

    Args:
        configurator: a registry name or a configurator object (`PlanConfig.configurator`).

    Returns:
        Its wall time (s), 0.0 when this process already did.

    Raises:
        ValueError: an unknown configurator name (`PlanConfig`).
    """
    if warmed(configurator):
        return 0.0
    from planner_core.defaults import MIN_POPULATION
    from planner_core.model.problem import Problem
    from planner_core.pipeline.config import PlanConfig
    from planner_core.pipeline.pipeline import run_pipeline

    t0 = time.perf_counter()
    problem = Problem(WARMUP_MAP)
    cfg = PlanConfig(budget=BUDGET, population=MIN_POPULATION, configurator=configurator,
                     start_candidates=4, starts=2, descents=1, descent_trials=4,
                     restructure_trials=8, kick_trials=8, other_trials=8)
    run_pipeline(problem, cfg)
    # the repair's merge (`refine._merge_places`) runs only when a route outgrows I_max, which
    # the tiny map's plans never do: one merge of three points compiles it
    from planner_core.search.refine import _merge_pair

    _merge_pair(problem, problem.model.sensors[:3])
    _merge_pair(problem, problem.model.sensors[:3].copy())  # a plan's points are writable
    # the tiny map's site sets are too small for the open-path solver's full search and its
    # legs too clear for the visibility graph's Dijkstra: both compiled here, not in a plan's
    # constructive stage (6 s of a first plan's "planning" on the demo map, 2026-12-06)
    import numpy as np

    from planner_core.model.routing import open_path
    from planner_core.search.construct import LegTimes

    pts = np.array([[100.0, 100.0], [800.0, 950.0], [1000.0, 950.0], [1400.0, 1300.0],
                    [300.0, 1200.0], [1200.0, 200.0], [700.0, 400.0], [600.0, 1350.0]])
    # (800, 950) -> (1000, 950) crosses the circle at (900, 950): a routed leg
    open_path(LegTimes(problem).matrix(pts))
    # k-means on a window's sensors (writable, where the constructive stage's are the map's
    # read-only array): the rebuilds of maps beyond the paper's I_max, never the tiny map's
    from planner_core.search.construct import _kmeans

    _kmeans(problem.model.sensors.copy(), 2, np.random.default_rng(0))
    # the hover LP's simplex (`hoverlp._rest_simplex`) solves blocks of more points than its
    # vertex enumeration takes, which the tiny map never forms (4 s of T16's first plan)
    from planner_core.model import hoverlp

    A = np.ascontiguousarray(np.array([[1.0, 0.5], [0.5, 1.0]]))
    hoverlp._rest_simplex(A, hoverlp._TARGET, 300.0, np.empty(2), np.zeros(2))
    # scheduled access's LP components (`hoverlp.link_components`): maps with
    # radio.access "scheduled" only
    hoverlp.link_components(np.array([0, 1]), np.array([0, 0]), 2, 1)
    # the rebuild's snap to the nearest candidate site (maps beyond the paper's I_max)
    from planner_core.search.rebuild import _nearest_scan

    _nearest_scan(np.zeros((2, 2)), np.ones((1, 2)))
    _WARM.add(_key(configurator))
    return time.perf_counter() - t0


def warm_kernels(configurator: str | None = None) -> float:
    """Compile (or load) the kernels a run needs before it is timed, once per process: the
    benchmark's warm-up (`planner_core.bench.runner.execute`), so a worker's first run is not
    charged the compile (19-27 s a run on an empty numba cache, 2 CPUs, 2026-12-07).

    Every configurator's `warm_up` compiles the kernels all runs share (the model's, the
    seeding's, the LP's, the DE's trial kernels); a configurator with kernels of its own
    (adaptive's) needs its own. So a run of our DE (`configurator` its name) warms up with its
    configurator, and any other run (None) with whichever configurator this process already
    warmed up, or the default one.

    Args:
        configurator: the registry name of the DE configurator the run uses, or None for a run
            that does not use our DE.

    Returns:
        The warm-up's wall time (s): 0.0 when this process already did it; else ~0.1-0.5 s with
        numba's cache on disk, 50-90 s on an empty cache (2 CPUs).

    Raises:
        ValueError: an unknown configurator name.
    """
    if configurator is None:
        if _WARM:
            return 0.0
        from planner_core.defaults import CONFIGURATOR

        configurator = CONFIGURATOR
    return 0.0 if warmed(configurator) else warm_up(configurator)


if __name__ == "__main__":  # `python -m planner_core.pipeline.warmup`: `make setup`'s last step
    # a fresh install compiles the kernels here (tens of seconds, once), so that neither the
    # first `plan` nor the first test pays for it; with numba's disk cache in place, ~0.5 s
    print(f"planner kernels compiled or loaded in {warm_up():.1f} s")
