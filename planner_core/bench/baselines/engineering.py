"""The plain engineering pipeline (issue 14): what a UAV/WSN engineer builds without any DE.

A constructive peer: the plans of `planner_core.search.construct` (hover sites from greedy set
covers
and a k-means sweep of the sensors, a visiting order on obstacle-aware Eq. 1 flight times, the
seeder's slide and visibility-graph detours, hover times from the polish LP; the module
docstring there gives every step), with no search over the decision vector: evaluations are
spent only to score the candidate plans, and the best (Deb's rule: least violation phi, then
least f) is kept. `plan` starts its DE from the same plans (the same code).

The visiting order is the only choice here: `order="ortools"` (default; the `engineering`
entry) is Google OR-Tools' routing solver (`pywrapcp.RoutingModel`) on the open path start ->
sites -> end (one vehicle, start and end depots fixed), arc costs the Eq. 1 leg times of
`construct.LegTimes` in milliseconds, first solution by cheapest arc, then guided local search
for a fixed number of solutions (no time limit: the result depends on the inputs only);
`order="own"` (the `engineering-own-order` entry) is the planner's own open path
(`construct.order_sites`: nearest neighbour and cheapest insertion, 2-opt, Or-opt).

Candidates are scored in the order of `construct.candidate_plans` (greedy covers, then
k = 1, 2, ...); the run stops when the budget is spent, so it never exceeds it, and usually uses
far less (`spends_budget=False` in the registry); `optimise(time_limit=)` gives it a wall-clock
time instead, spent on further rounds of candidates from new seeds (issue 31's comparison at
the planner's wall time, `benchmarks/bench_large_peer.py`). It is the same in both start
modes (`--init seeded|uniform`): it never asks for the problem's initial population; the seed
only drives the k-means inits and the slide's directions. Needs the UAV problem
(`planner_core.model.problem.Problem`) and, for the OR-Tools order, the `baselines` extra.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from planner_core.bench.baselines import OptimiseResult
from planner_core.pipeline.evaluator import as_evaluator
from planner_core.search.construct import LegTimes, candidate_plans
from planner_core.streams import stream_seed

__all__ = ["ORDERS", "ROUTING_SOLUTIONS", "optimise", "ortools_order", "score_candidates"]

#: visiting orders of the site sets: OR-Tools' routing solver, or the planner's own open path
ORDERS = ("ortools", "own")
#: OR-Tools guided local search stops after this many solutions (deterministic, no clock)
ROUTING_SOLUTIONS = 30
#: arc costs are flight times in these units of a second (OR-Tools wants integers)
_COST_SCALE = 1000.0


def _base(problem: Any) -> Any:
    """The UAV problem under the budget and start-mode wrappers (each keeps it as `.problem`)."""
    p = problem
    while "problem" in getattr(p, "__dict__", {}):
        p = p.__dict__["problem"]
    if not all(hasattr(p, a) for a in ("model", "obstacles", "encode", "breakdown")):
        raise ValueError("engineering: needs the UAV problem (model, obstacles, encode); got "
                         f"{type(p).__name__}")
    return p


def ortools_order(problem: Any, sites: np.ndarray, legs: LegTimes) -> np.ndarray:
    """Visiting order of the sites on the open path start -> sites -> end, by OR-Tools' routing
    solver on the leg times of `legs` (module docstring).

    Args:
        problem: the UAV problem (its `start`, `end`, m).
        sites: (m, 2) hover sites, m.
        legs: the obstacle-aware Eq. 1 leg times (`construct.LegTimes`).

    Returns:
        (m,) int64 indices into `sites`, in visiting order (0 or 1 site: arange(m)).

    Raises:
        RuntimeError: OR-Tools finds no route.
    """
    from ortools.constraint_solver import pywrapcp, routing_enums_pb2

    sites = np.asarray(sites, dtype=float).reshape(-1, 2)
    m = len(sites)
    if m <= 1:
        return np.arange(m)
    nodes = np.vstack([problem.start, sites, problem.end])
    P = len(nodes)
    W = np.rint(legs.matrix(nodes) * _COST_SCALE).astype(np.int64)
    manager = pywrapcp.RoutingIndexManager(P, 1, [0], [P - 1])
    routing = pywrapcp.RoutingModel(manager)
    routing.SetArcCostEvaluatorOfAllVehicles(routing.RegisterTransitMatrix(W.tolist()))
    params = pywrapcp.DefaultRoutingSearchParameters()
    params.first_solution_strategy = routing_enums_pb2.FirstSolutionStrategy.PATH_CHEAPEST_ARC
    params.local_search_metaheuristic = (
        routing_enums_pb2.LocalSearchMetaheuristic.GUIDED_LOCAL_SEARCH)
    params.solution_limit = ROUTING_SOLUTIONS
    solution = routing.SolveWithParameters(params)
    if solution is None:
        raise RuntimeError("engineering: OR-Tools found no route through the hover sites")
    order: list[int] = []
    i = solution.Value(routing.NextVar(routing.Start(0)))
    while not routing.IsEnd(i):
        order.append(manager.IndexToNode(i) - 1)
        i = solution.Value(routing.NextVar(i))
    return np.asarray(order, dtype=np.int64)


def score_candidates(
    budgeted: Any, seed: int, order: str = "ortools", *, stop: Any = None,
    skip: set[bytes] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Build the pipeline's distinct candidate plans in order, as many as `budgeted` has
    evaluations left, and evaluate them through it.

    Args:
        budgeted: an `Evaluator` of the UAV problem.
        seed: drives the k-means inits and the slide's directions.
        order: one of `ORDERS`.
        stop: a callable (None: never), asked after each site set; True ends the list there
            (`candidate_plans`).
        skip: byte strings of decision vectors already scored, left out and extended with the
            new ones.

    Returns:
        (X (m, d), f (m,), phi (m,)) of the plans evaluated (m may be 0).

    Raises:
        ValueError: an unknown `order`, or a problem that is not the UAV problem.
    """
    if order not in ORDERS:
        raise ValueError(f"order: unknown '{order}', choose one of {', '.join(ORDERS)}")
    base = _base(budgeted)
    # with `skip`, room for every plan scored before to come again: `remaining` new ones fit
    limit = int(budgeted.remaining) + (len(skip) if skip is not None else 0)
    X, _ = candidate_plans(base, int(seed), limit,
                           order=ortools_order if order == "ortools" else None, stop=stop)
    if skip is not None and len(X):
        X = X[[i for i, x in enumerate(X) if x.tobytes() not in skip]][:budgeted.remaining]
        skip.update(x.tobytes() for x in X)
    if len(X) == 0:
        return X, np.zeros(0), np.zeros(0)
    f, phi = budgeted.evaluate(X)
    return X, np.asarray(f, dtype=float), np.asarray(phi, dtype=float)


def optimise(problem: Any, budget: int, seed: int, *, order: str = "ortools",
             time_limit: float | None = None) -> OptimiseResult:
    """Score the pipeline's candidate plans (one evaluation each, while the budget lasts) and
    return the Deb-best; deterministic for a seed, identical in both start modes.

    Args:
        problem: the UAV problem (or an `Evaluator` of it).
        budget: evaluations at most.
        seed: drives the k-means inits and the slide's directions.
        order: one of `ORDERS` (module docstring).
        time_limit: None (default): one round of candidates, the peer as a practitioner runs
            it. Seconds of wall clock: the peer given that time (issue 31's comparison at the
            planner's wall time): after the first round it builds further rounds from new
            seeds (round r from `stream_seed(seed, "fresh", r)`, as the planner's fresh
            sweeps: other k-means inits and slide directions), scoring only plans not scored
            before, while the clock and the budget last; a round past the limit ends at its
            next site set. Not deterministic: how many rounds fit depends on the machine.

    Returns:
        The Deb-best plan, its f and phi, the evaluations used and the trace.

    Raises:
        ValueError: an unknown `order` or a non-positive `time_limit`.
    """
    if time_limit is not None and not float(time_limit) > 0.0:
        raise ValueError(f"time_limit: must be a number of seconds > 0, got {time_limit!r}")
    t0 = time.perf_counter()
    budgeted = as_evaluator(problem, budget)
    if time_limit is None:
        score_candidates(budgeted, seed, order)
    else:
        def late() -> bool:
            return time.perf_counter() - t0 >= float(time_limit)

        seen: set[bytes] = set()
        r = 0
        while budgeted.remaining > 0 and (r == 0 or not late()):
            seed_r = seed if r == 0 else stream_seed(seed, "fresh", r)
            score_candidates(budgeted, seed_r, order, stop=late if r else None, skip=seen)
            r += 1
    x, f, phi = budgeted.best("deb")
    return OptimiseResult(x, f, phi, budgeted.count, budgeted.trace("deb"))
