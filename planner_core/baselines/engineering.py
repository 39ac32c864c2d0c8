"""The plain engineering pipeline (issue 14): what a UAV/WSN engineer builds without any DE.

A constructive peer: hover sites from a set cover of the sensors, a visiting order from a
routing solver, obstacle detours from a visibility graph, hover times from an LP. No search
over the decision vector; evaluations are spent only to score the candidate plans it builds,
and the best (Deb's rule: least violation phi, then least f) is kept.

1. **Service reach.** A hover site *covers* sensor j when hovering `frac` x T_max there collects
   its data Q_j, i.e. it lies within `ground_reach(Q_j / (frac T_max))` of the sensor (the link
   model of Sec. 3 read backwards; frac = 0.9 is the seeder's reach).
2. **Candidate sites**: the sensor positions, the midpoints of sensor pairs, and every k-means
   centre of step 4; each moved out of any obstacle (the seeder's push-out) and dropped when its
   summed link rate exceeds 98 % of the bandwidth (C3). A sensor no candidate covers keeps its
   own (pushed-out) position as a candidate, so every cover exists.
3. **Greedy set cover** (Chvatal 1979, "A greedy heuristic for the set-covering problem",
   Math. Oper. Res. 4(3)): repeatedly the site covering the most still-uncovered sensors (ties:
   the shortest hover time those sensors need there, max_j Q_j / R_ij; then the lowest index).
   One cover per reach fraction in `FRACTIONS` (a tight reach: more sites, shorter hovers); a
   sensor no site covers at that fraction is covered at T_max.
4. **k-means sweep** over k = 1 .. min(I_max, J) (`scipy.cluster.vq.kmeans2`, k-means++ init,
   Arthur & Vassilvitskii 2007; `KMEANS_INITS` inits per k from the run's seed): the centres,
   completed to a cover at frac = 0.9 by the greedy of step 3 when some sensor is out of reach.
5. **Visiting order** of each site set: OR-Tools' routing solver (Google OR-Tools,
   `pywrapcp.RoutingModel`) on the open path start -> sites -> end (one vehicle, start and end
   depots fixed), arc costs the Eq. 1 flight time of the shortest obstacle-free way between the
   two points (straight when the leg is clear, else through the reduced visibility graph of
   `planner_core.routing`), first solution by cheapest arc, then guided local search for a fixed
   number of solutions (no time limit: the result depends on the inputs only).
6. **Line of sight and I_max**: each site is nudged within its sensors' service reach to clear
   its two legs and shorten them (the seeder's slide, `Seeder.slide`: every detour corner costs
   one of the I_max hover points, so a site that sees its neighbours saves them), then
   `planner_core.memetic.repair_points`: the seeder's visibility-graph routing of every
   still-blocked leg (corners inserted, string-pulled, as `Seeder.route`), brought back to
   I_max points in one or two ways (route then prune/merge; merge then re-route), each a plan.
7. **Hover times**: the hover-time LP of `planner_core.polish` (the same LP every peer ends with),
   then one evaluation of each distinct plan.

Candidates are scored in the order: greedy covers, then k = 1, 2, ... (each k's inits in turn);
the run stops when the budget is spent, so it never exceeds it, and usually uses far less
(`spends_budget=False` in the registry). It is the same in both start modes (`--init seeded|
uniform`): it never asks for the problem's initial population; the seed only drives the k-means
inits. Needs the UAV problem (`planner_core.problem.Problem`: model, obstacles, encode).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from typing import Any

import numpy as np

from planner_core.baselines import OptimiseResult
from planner_core.baselines.budget import as_budgeted
from planner_core.geometry import overlap_lengths, points_inside
from planner_core.memetic import covers
from planner_core.model import ground_reach
from planner_core.routing.graph import CLEAR

__all__ = [
    "FRACTIONS",
    "KMEANS_INITS",
    "candidate_sites",
    "build_plans",
    "greedy_cover",
    "optimise",
    "order_sites",
    "reach",
    "score_candidates",
    "site_sets",
]

#: reach fractions of the greedy covers: a site covers a sensor when hovering this share of
#: T_max there collects its data (0.9: the seeder's reach)
FRACTIONS = (0.9, 0.6, 0.35, 0.2)
#: k-means inits per k of the sweep
KMEANS_INITS = 2
#: summed link rate a candidate site may have, as a share of the bandwidth (C3; the seeder's)
BANDWIDTH_USE = 0.98
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


def reach(problem: Any, frac: float) -> np.ndarray:
    """(J,) ground distance (m) within which hovering frac x T_max collects each sensor's data."""
    mp = problem.model
    need = np.maximum(np.asarray(mp.required, dtype=float), 1e-9) / (frac * mp.t_max)
    return ground_reach(need, mp.altitude, mp.peak_rate, mp.decay)


def candidate_sites(problem: Any, extra: np.ndarray | None = None) -> np.ndarray:
    """Candidate hover sites (n, 2): sensor positions, midpoints of sensor pairs, and `extra`
    (e.g. k-means centres), clipped to the area, pushed out of obstacles, deduplicated, those
    over `BANDWIDTH_USE` of the bandwidth dropped (but each sensor's own position kept when no
    other candidate covers it at frac = 0.9)."""
    mp = problem.model
    seeder = problem.seeder
    S = np.asarray(mp.sensors, dtype=float)
    ia, ib = np.triu_indices(len(S), 1)
    mids = 0.5 * (S[ia] + S[ib])
    lim = reach(problem, 0.9)
    # a midpoint is useful only when it can serve both of its sensors
    near = np.hypot(*(S[ia] - S[ib]).T) <= 2.0 * np.minimum(lim[ia], lim[ib])
    parts = [S, mids[near]]
    if extra is not None and len(extra):
        parts.append(np.asarray(extra, dtype=float).reshape(-1, 2))
    C = np.vstack(parts)
    rng = np.random.default_rng(0)  # only for a point exactly at a circle's centre
    inside = points_inside(np.clip(C, 0.0, seeder.size), problem.obstacles)
    C = np.clip(C, 0.0, seeder.size)
    for m in np.flatnonzero(inside):
        C[m] = seeder.push_one(C[m], rng)
    C = np.clip(C, 0.0, seeder.size)
    C = np.unique(np.round(C, 6), axis=0)
    ok = mp.rates(C).sum(axis=1) <= BANDWIDTH_USE * mp.bandwidth
    keep = C[ok]
    covered = covers(problem, keep, 0.9).any(axis=0) if len(keep) else np.zeros(len(S), bool)
    if not covered.all():
        own = np.clip(S[~covered], 0.0, seeder.size)
        for m in range(len(own)):
            if points_inside(own[m : m + 1], problem.obstacles)[0]:
                own[m] = seeder.push_one(own[m], rng)
        keep = np.vstack([keep, own])
    return keep


def greedy_cover(
    problem: Any, sites: np.ndarray, frac: float, chosen: np.ndarray | None = None
) -> np.ndarray:
    """Indices into `sites` of a greedy set cover of the sensors at reach fraction `frac`
    (module docstring, step 3), after the sites `chosen` (points (m, 2), already in the plan;
    they are not returned). A sensor no site covers at `frac` counts as covered by the sites
    that collect its data within T_max; one no site serves even then is left uncovered."""
    mp = problem.model
    need = np.asarray(mp.required, dtype=float)
    cov = covers(problem, sites, frac)
    cov = np.where(cov.any(axis=0), cov, covers(problem, sites, 1.0))
    R = mp.rates(sites)
    hover = np.where(R > 0, need[None, :] / np.maximum(R, 1e-12), np.inf)  # (n, J) s
    left = cov.any(axis=0)
    if chosen is not None and len(chosen):
        left &= ~covers(problem, np.asarray(chosen, dtype=float), frac).any(axis=0)
    out: list[int] = []
    while left.any():
        gain = (cov & left).sum(axis=1)
        if gain.max() == 0:
            break
        t = np.max(np.where(cov & left, hover, 0.0), axis=1)
        best = np.flatnonzero(gain == gain.max())
        i = int(best[np.argmin(t[best])])  # first of the ties
        out.append(i)
        left &= ~cov[i]
    return np.asarray(out, dtype=np.int64)


def _kmeans(S: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """k-means centres (<= k, 2) of the sensors, k-means++ init from rng (empty clusters
    dropped)."""
    from scipy.cluster.vq import kmeans2

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scipy warns when a cluster ends empty
        C, label = kmeans2(S, k, minit="++", rng=rng)
    return C[np.unique(label)]


def site_sets(problem: Any, seed: int) -> Iterator[tuple[str, np.ndarray]]:
    """The candidate site sets in scoring order, each as (label, sites (m, 2)): one greedy
    cover per reach fraction, then the k-means sweep (module docstring, steps 2-4)."""
    mp = problem.model
    S = np.asarray(mp.sensors, dtype=float)
    J = len(S)
    if J == 0:
        yield "no sensors", np.zeros((0, 2))
        return
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 14]))
    ks = list(range(1, min(int(mp.n_points), J) + 1))
    centres = {(k, r): _kmeans(S, k, rng) for k in ks for r in range(KMEANS_INITS)}
    sites = candidate_sites(problem, np.vstack(list(centres.values())))
    for frac in FRACTIONS:
        yield f"cover {frac:g}", sites[greedy_cover(problem, sites, frac)]
    seeder = problem.seeder
    pushed_rng = np.random.default_rng(0)
    for (k, r), C in centres.items():
        C = np.clip(C.copy(), 0.0, seeder.size)
        for m in np.flatnonzero(points_inside(C, problem.obstacles)):
            C[m] = seeder.push_one(C[m], pushed_rng)
        more = sites[greedy_cover(problem, sites, 0.9, chosen=C)]
        yield f"k-means k={k} init {r}", np.vstack([C, more])


def _arc_costs(problem: Any, nodes: np.ndarray) -> np.ndarray:
    """(P, P) Eq. 1 flight time (s) of the shortest obstacle-free way between nodes: the
    straight leg when clear, else through the visibility graph (corner to corner, each hop a
    leg from rest to rest); a pair the graph cannot join keeps its straight leg plus 1e6 s
    per metre inside obstacles."""
    mp = problem.model
    P = len(nodes)
    ia, ib = np.triu_indices(P, 1)
    d = np.hypot(*(nodes[ia] - nodes[ib]).T)
    cost = mp.flight_time(d)
    inside = overlap_lengths(nodes[ia], nodes[ib], problem.obstacles)
    blocked = np.flatnonzero(inside > CLEAR)
    if len(blocked):
        seeder = problem.seeder
        g = seeder.graph
        A = seeder.connect(nodes) if g.n else None
        for e in blocked.tolist():
            a, b = int(ia[e]), int(ib[e])
            path: list[int] = []
            if A is not None:
                _, path = g.route(A[a], A[b])
            if path:
                way = np.vstack([nodes[a], g.nodes[path], nodes[b]])
                cost[e] = float(mp.flight_time(np.hypot(*np.diff(way, axis=0).T)).sum())
            else:
                cost[e] += 1e6 * inside[e]
    W = np.zeros((P, P))
    W[ia, ib] = W[ib, ia] = cost
    return W


def order_sites(problem: Any, sites: np.ndarray) -> np.ndarray:
    """Visiting order (m,) of the sites on the open path start -> sites -> end, by OR-Tools'
    routing solver on obstacle-aware flight times (module docstring, step 5)."""
    from ortools.constraint_solver import pywrapcp, routing_enums_pb2

    sites = np.asarray(sites, dtype=float).reshape(-1, 2)
    m = len(sites)
    if m <= 1:
        return np.arange(m)
    nodes = np.vstack([problem.start, sites, problem.end])
    P = len(nodes)
    W = np.rint(_arc_costs(problem, nodes) * _COST_SCALE).astype(np.int64)
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


def build_plans(problem: Any, sites: np.ndarray, rng: np.random.Generator) -> list[np.ndarray]:
    """Decision vectors from a site set: OR-Tools order, slide, visibility-graph detours and
    I_max (`planner_core.memetic.repair_points`, which gives one or two hover-point sets: route
    then prune/merge, or merge then re-route), LP hover times (module docstring, steps 5-7); one
    vector per set. `rng` drives the slide's candidate directions only."""
    from planner_core.memetic import repair_points

    sites = np.asarray(sites, dtype=float).reshape(-1, 2)
    C = sites[order_sites(problem, sites)]
    if len(C):
        # each sensor slides with the site that serves it fastest (a covering one if any)
        R = problem.model.rates(C)
        owner = np.argmax(np.where(covers(problem, C, 0.9), R + 1e6, R), axis=0)
        C = problem.seeder.slide(C, owner, reach(problem, 0.9), rng)
    return [_timed(problem, pts) for pts in repair_points(problem, C)]


def _timed(problem: Any, pts: np.ndarray) -> np.ndarray:
    """The decision vector of hover points pts (m, 2) with LP hover times (`planner_core.polish`);
    when every slot must stay active (tau <= 0), filled to I_max with collinear points first."""
    from planner_core.polish import polish_hover_times

    I = int(problem.n_points)
    if problem.variable_length and problem.tau <= 0.0 and len(pts) < I:
        pts = problem.seeder.fill(pts, I)  # every slot is active: collinear fillers
    pol = polish_hover_times(problem, pts)
    if len(pol.hover_points) == len(pts) or (problem.variable_length and problem.tau > 0.0):
        return problem.encode(pol.hover_points, pol.hover_times)
    # all I_max slots must stay: the dropped (~0 s) points keep time 0
    times = np.zeros(len(pts))
    times[np.setdiff1d(np.arange(len(pts)), pol.dropped)] = pol.hover_times
    return problem.encode(pts, times)


def score_candidates(
    budgeted: Any, seed: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Build the pipeline's candidate plans in order and evaluate each distinct one once through
    `budgeted` (a `BudgetedProblem`) while its budget lasts: (X (m, d), f (m,), phi (m,))."""
    base = _base(budgeted)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 15]))
    seen: set[bytes] = set()
    rows: list[np.ndarray] = []
    fs: list[float] = []
    phis: list[float] = []
    for _label, sites in site_sets(base, int(seed)):
        for x in build_plans(base, sites, rng):
            key = x.tobytes()
            if budgeted.remaining < 1 or key in seen:
                continue
            seen.add(key)
            f, phi = budgeted.evaluate(x[None, :])
            rows.append(x)
            fs.append(float(f[0]))
            phis.append(float(phi[0]))
        if budgeted.remaining < 1:
            break
    d = int(np.asarray(budgeted.lower).shape[0])
    return np.asarray(rows, dtype=float).reshape(-1, d), np.asarray(fs), np.asarray(phis)


def optimise(problem: Any, budget: int, seed: int) -> OptimiseResult:
    """Score the pipeline's candidate plans (one evaluation each, while the budget lasts) and
    return the Deb-best; deterministic for a seed, identical in both start modes."""
    budgeted = as_budgeted(problem, budget)
    score_candidates(budgeted, seed)
    x, f, phi = budgeted.best("deb")
    return OptimiseResult(x, f, phi, budgeted.count, budgeted.trace("deb"))
