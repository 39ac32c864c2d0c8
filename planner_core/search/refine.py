"""The memetic step of the planner (issue 14): structural moves and exact hover times for the
elite, during the run.

The DE moves every coordinate a little; it rarely changes a plan's structure (the order of the
hover points, how many there are) and never solves the hover times exactly. This step does both
for one solution, cheaply, and hands back a few candidates that the DE evaluates like any
trial (every candidate counts against the budget; `planner_core.search.de.loop.run` calls it):

1. re-order: 2-opt on the open route start -> hover points -> end by flight time (Eq. 1); a
   reversal is kept only when it shortens the route and keeps every leg collision-free (or
   does not add overlap), so feasibility is never traded for time;
2. exact hover times: the hover-time LP of `planner_core.search.polish` on the re-ordered points (it
   also drops points whose time is ~0 when that is safe);
3. remove: in the variable-length encoding, the `REMOVALS` points with the smallest LP times are
   each removed in turn, with the LP on the rest (a point the others can cover is pure cost);
4. repair (`repair_points`), only when the solution is infeasible: a hover point is inserted
   above each sensor no point can serve (at its cheapest place in the route), the legs that
   still cut an obstacle are re-routed through the seeder's visibility graph, the route is
   pruned back to I_max points when it has grown past it, then 2-opt and the LP again. From a
   uniform start the DE alone rarely finds the sensors out of every point's radio range (the
   data term is flat there); this move puts a point where one is missing.

Used through `Problem.refine`; deterministic (no randomness).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.model.geometry import overlap_lengths
from planner_core.search.polish import _route_flight_time, polish_hover_times

__all__ = ["covers", "refine", "repair", "repair_points", "two_opt_order", "use_memetic",
           "REMOVALS", "SERVE_FRACTION"]

#: a point serves a sensor in the repair when hovering this share of T_max collects its data
#: (the seeder's reach uses the same share)
SERVE_FRACTION = 0.9
#: points tried for removal per call (each costs one LP solve)
REMOVALS = 2
#: fractions of the way each point is pulled towards its route neighbours' midpoint
PULLS = (0.1, 0.3)


def _leg_cost(problem: Any, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flight times (s) and overlaps (m) of legs a -> b ((n, 2) each)."""
    d = np.hypot(b[:, 0] - a[:, 0], b[:, 1] - a[:, 1])
    return problem.model.flight_time(d), overlap_lengths(a, b, problem.obstacles)


def two_opt_order(problem: Any, pts: np.ndarray, max_passes: int = 4) -> np.ndarray:
    """Hover points (k, 2) re-ordered by first-improvement 2-opt on the open route from the
    map's start to its end: a segment reversal is kept when the route gets faster (Eq. 1 leg
    times) and its total overlap does not grow. Returns a permutation of the rows."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    k = len(pts)
    if k < 2:
        return pts
    nodes = np.vstack([problem.start, pts, problem.end])
    for _ in range(max_passes):
        improved = False
        t, o = _leg_cost(problem, nodes[:-1], nodes[1:])
        # reversing nodes[i+1 .. j] replaces legs (i, i+1) and (j, j+1) by (i, j) and (i+1, j+1)
        ii, jj = np.triu_indices(k + 1, 1)
        keep = jj <= k  # j + 1 stays within the route (last node is the fixed end)
        ii, jj = ii[keep], jj[keep]
        keep = jj > ii  # at least one hover point in the segment
        ii, jj = ii[keep], jj[keep]
        if len(ii) == 0:
            break
        t1, o1 = _leg_cost(problem, nodes[ii], nodes[jj])
        t2, o2 = _leg_cost(problem, nodes[ii + 1], nodes[jj + 1])
        gain = t[ii] + t[jj] - t1 - t2
        ok = (gain > 1e-9) & (o1 + o2 <= o[ii] + o[jj])
        if ok.any():
            m = int(np.argmax(np.where(ok, gain, -np.inf)))
            i, j = int(ii[m]), int(jj[m])
            nodes[i + 1 : j + 1] = nodes[i + 1 : j + 1][::-1].copy()
            improved = True
        if not improved:
            break
    return nodes[1:-1]


def use_memetic(setting: str, problem: Any) -> bool:
    """Whether a run on `problem` (as the optimiser sees it) uses the memetic step, for the
    defaults table's `memetic` setting: "on", "off", or "auto" = on exactly when the run starts
    without the problem's seeding hook (the uniform start, `planner_core.search.init_modes`).
    Raises ValueError naming `memetic` for any other setting."""
    from planner_core.defaults import check

    check("memetic", setting)
    if setting == "auto":
        return not hasattr(problem, "initial_population")
    return setting == "on"


def covers(problem: Any, sites: np.ndarray, frac: float = SERVE_FRACTION,
           rates: np.ndarray | None = None) -> np.ndarray:
    """(n, J) bool: whether hovering frac x T_max at each of the sites (n, 2) collects each
    sensor's required data (Eq. R_ij; a sensor that needs nothing counts as covered).
    `rates`: the sites' link rates (n, J), when the caller keeps them."""
    mp = problem.model
    need = np.asarray(mp.required, dtype=float)
    if rates is None:
        rates = mp.rates(np.asarray(sites, dtype=float).reshape(-1, 2))
    return (rates * (frac * mp.t_max) >= need[None, :]) | (need[None, :] <= 0)


def _cheapest_insertion(problem: Any, pts: np.ndarray, q: np.ndarray) -> int:
    """Index at which q joins the route start -> pts -> end for the least added flight time,
    with added length inside obstacles weighed first (1 m of overlap outweighs 1e6 s)."""
    nodes = np.vstack([problem.start, pts, problem.end])
    a, b = nodes[:-1], nodes[1:]
    qq = np.broadcast_to(q, a.shape)
    t0, o0 = _leg_cost(problem, a, b)
    t1, o1 = _leg_cost(problem, a, qq)
    t2, o2 = _leg_cost(problem, qq, b)
    cost = (o1 + o2 - o0) * 1e6 + (t1 + t2 - t0)
    return int(np.argmin(cost))


def repair_points(problem: Any, pts: np.ndarray) -> list[np.ndarray]:
    """Hover points (k, 2) -> repaired hover-point sets (m, 2), m <= I_max (= I_max in
    fixed-length mode): a point above each sensor out of every point's service reach (the
    seeder's reach: 90 % of T_max serves it), inserted where it adds least; blocked legs
    re-routed around obstacles through the visibility graph; then back to I_max in two ways
    (module docstring, step 4), each set once: (1) route, then prune and merge the routed points;
    (2) merge serving points and re-route until the corners fit. Which fits better depends on
    the map (measured on the suite, each alone leaves other runs infeasible), so the memetic
    step evaluates both. Deterministic."""
    seeder = problem.seeder
    mp = problem.model
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    sensors = np.asarray(mp.sensors, dtype=float)
    served = covers(problem, pts).any(axis=0)
    rng = np.random.default_rng(0)  # only for a point exactly at a circle's centre
    for j in np.flatnonzero(~served):
        if served[j]:
            continue  # a point inserted for an earlier sensor serves this one too
        q = seeder.push_one(sensors[j].copy(), rng)
        i = _cheapest_insertion(problem, pts, q)
        pts = np.insert(pts, i, q, axis=0)
        served |= covers(problem, q)[0]
    limit = mp.n_points
    routed, _ = seeder.route(pts)
    out = [_fit(problem, seeder, routed, merge_first=False)]
    if len(routed) > limit:
        centres = seeder.prune(pts, limit) if len(pts) > limit else pts
        routed, _ = seeder.route(centres)
        while len(routed) > limit and len(centres) > 1:
            merged = _merge_pair(problem, centres)
            if merged is None:
                break
            centres = merged
            routed, _ = seeder.route(centres)
        second = _fit(problem, seeder, routed, merge_first=True)
        if not np.array_equal(second, out[0]):
            out.append(second)
    return out


def _fit(problem: Any, seeder: Any, pts: np.ndarray, *, merge_first: bool) -> np.ndarray:
    """pts cut to I_max: prune (points others serve), merges (route-first way only), truncate
    (least overlap added); filled to I_max in fixed-length mode."""
    limit = problem.model.n_points
    if len(pts) > limit:
        pts = seeder.prune(pts, limit)
    while not merge_first and len(pts) > limit:
        merged = _merge_pair(problem, pts)
        if merged is None:
            break
        pts = merged
    if len(pts) > limit:
        pts = seeder.truncate(pts, limit)
    if not problem.variable_length:
        pts = seeder.fill(pts, limit)
    return pts


#: pairs whose trial routes `_merge_pair` builds at once (bounds its memory: a block holds
#: two trial routes of k + 1 legs per pair and two rate rows of J sensors)
_MERGE_BLOCK = 1 << 20


def _merge_pair(problem: Any, pts: np.ndarray) -> np.ndarray | None:
    """pts (k, 2) with two points replaced by one that still serves every sensor only those two
    serve (within the seeder's reach: 90 % of T_max), placed at their sensors' centroid or the
    pair's midpoint, choosing the pair and place that add the least flight time (the first in
    pair order, midpoint before centroid, among equals); None when no pair can be merged. The
    merged point takes the first point's place in the route.

    All k (k - 1) / 2 pairs are scored in blocks: per pair the sensors only it serves (J), both
    places' coverage (2 J rates) and both trial routes' flight times (2 (k + 1) legs), so one
    call costs O(k^2 (k + J)) in `_MERGE_BLOCK`-bounded memory; `merge_pair_reference` is the
    loop it replaces (same result to the bit, tests)."""
    mp = problem.model
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    k = len(pts)
    if k < 2:
        return None
    need = np.asarray(mp.required, dtype=float)
    serves = covers(problem, pts)  # (k, J)
    count = serves.sum(axis=0)
    sensors = np.asarray(mp.sensors, dtype=float)
    base = _route_flight_time(problem, pts)
    full = np.vstack([problem.start, pts, problem.end])
    ii, jj = np.triu_indices(k, 1)  # the reference's loop order: i, then j > i
    block = max(1, _MERGE_BLOCK // (k + 1 + len(need) + 1))
    best: tuple[float, int, int] | None = None  # (added time, pair, place)
    for lo in range(0, len(ii), block):
        i, j = ii[lo : lo + block], jj[lo : lo + block]
        own = (serves[i] | serves[j]) & (count[None, :] - serves[i] - serves[j] <= 0) \
            & (need > 0)[None, :]
        has = own.any(axis=1)
        places = np.empty((len(i), 2, 2))
        places[:, 0] = 0.5 * (pts[i] + pts[j])
        # the centroid of the pair's own sensors, summed in sensor order (as mean() does)
        acc = np.zeros((len(i), 2))
        for s in np.flatnonzero(own.any(axis=0)):
            acc[own[:, s]] += sensors[s]
        with np.errstate(invalid="ignore", divide="ignore"):
            places[:, 1] = acc / own.sum(axis=1)[:, None]
        valid = np.stack([np.ones(len(i), dtype=bool), has], axis=1)
        q = places.reshape(-1, 2)
        flat_own = np.repeat(own, 2, axis=0)
        fits = (covers(problem, np.where(valid.reshape(-1, 1), q, 0.0)) | ~flat_own).all(axis=1)
        valid &= fits.reshape(-1, 2) | ~has[:, None]
        # the trial routes: start -> pts without j, i at the new place -> end
        cols = np.arange(k + 1)[None, :]
        idx = cols + (cols >= (j + 1)[:, None])
        t = np.full((len(i), 2), np.inf)
        for c in range(2):
            rows = np.flatnonzero(valid[:, c])
            if not len(rows):
                continue
            nodes = full[idx[rows]]
            nodes[np.arange(len(rows)), i[rows] + 1] = places[rows, c]
            d = np.linalg.norm(np.diff(nodes, axis=1), axis=2)
            t[rows, c] = mp.flight_time(d).sum(axis=1) - base
        flat = t.reshape(-1)
        m = int(np.argmin(flat))
        if np.isfinite(flat[m]) and (best is None or flat[m] < best[0]):
            best = (float(flat[m]), lo + m // 2, m % 2)
    if best is None:
        return None
    _, pair, place = best
    i, j = int(ii[pair]), int(jj[pair])
    trial = np.delete(pts, j, axis=0)
    if place == 0:
        trial[i] = 0.5 * (pts[i] + pts[j])
    else:
        own = (serves[i] | serves[j]) & (count - serves[i] - serves[j] <= 0) & (need > 0)
        trial[i] = sensors[own].mean(axis=0)
    return trial


def merge_pair_reference(problem: Any, pts: np.ndarray) -> np.ndarray | None:
    """`_merge_pair` the obvious way, pair by pair and place by place (one rate row and one
    route sum each): what `_merge_pair` computes in blocks of pairs (tests hold the two
    equal)."""
    mp = problem.model
    need = np.asarray(mp.required, dtype=float)
    serves = covers(problem, pts)  # (k, J)
    count = serves.sum(axis=0)
    sensors = np.asarray(mp.sensors, dtype=float)
    base = _route_flight_time(problem, pts)
    best: tuple[float, np.ndarray] | None = None
    k = len(pts)
    for i in range(k):
        for j in range(i + 1, k):
            # sensors that lose their only servers when i and j go
            own = (serves[i] | serves[j]) & (count - serves[i] - serves[j] <= 0) & (need > 0)
            cands = [0.5 * (pts[i] + pts[j])]
            if own.any():
                cands.append(sensors[own].mean(axis=0))
            for q in cands:
                if own.any() and not covers(problem, q)[0, own].all():
                    continue
                trial = np.delete(pts, j, axis=0)
                trial[i] = q
                t = _route_flight_time(problem, trial) - base
                if best is None or t < best[0]:
                    best = (t, trial)
    return None if best is None else best[1]


def _repairs(problem: Any, b: dict[str, Any]) -> list[np.ndarray]:
    """Encoded repairs (step 4) of the solution whose breakdown is b: none when it is
    feasible; else each of `repair_points`' sets, 2-opt ordered, with LP hover times."""
    out = []
    if b["phi"] > 0.0:
        pts = np.asarray(b["hover_points"], dtype=float).reshape(-1, 2)
        for rp in repair_points(problem, pts):
            if len(rp):
                pr = polish_hover_times(problem, two_opt_order(problem, rp))
                out.append(problem.encode(pr.hover_points, pr.hover_times))
    return out


def repair(problem: Any, x: np.ndarray) -> np.ndarray:
    """The repair alone (step 4) as a refine function: candidates (m, d), problem space, for an
    infeasible x; (0, d) for a feasible one. The memetic step without its improving moves
    (steps 1-3), for measuring what the repair of unserved sensors does on its own
    (`benchmarks/validate_policy.py --pipeline repair`)."""
    b = problem.breakdown(np.asarray(x, dtype=float))
    d = int(np.asarray(problem.lower).shape[0])
    return np.asarray(_repairs(problem, b), dtype=float).reshape(-1, d)


def refine(problem: Any, x: np.ndarray) -> np.ndarray:
    """Candidates (m, d), problem space, from solution x: re-ordered with LP hover times, then
    each of up to `REMOVALS` removals, and for an infeasible x its repair (module docstring)."""
    b = problem.breakdown(np.asarray(x, dtype=float))
    pts = np.asarray(b["hover_points"], dtype=float).reshape(-1, 2)
    d = int(np.asarray(problem.lower).shape[0])
    out = _repairs(problem, b)
    if len(pts) == 0:
        return np.asarray(out, dtype=float).reshape(-1, d)
    pts = two_opt_order(problem, pts)
    pol = polish_hover_times(problem, pts)
    out.append(problem.encode(pol.hover_points, pol.hover_times))
    # shorten: pull every point towards the midpoint of its route neighbours, LP times
    nodes = np.vstack([problem.start, pol.hover_points, problem.end])
    mid = 0.5 * (nodes[:-2] + nodes[2:])
    for frac in PULLS:
        pp = pol.hover_points + frac * (mid - pol.hover_points)
        pr = polish_hover_times(problem, pp)
        out.append(problem.encode(pr.hover_points, pr.hover_times))
    if problem.variable_length and len(pol.hover_points) > 1:
        base, times = pol.hover_points, pol.hover_times
        for i in np.argsort(times, kind="stable")[:REMOVALS]:
            rest = np.delete(base, int(i), axis=0)
            pr = polish_hover_times(problem, rest)
            out.append(problem.encode(pr.hover_points, pr.hover_times))
    return np.asarray(out, dtype=float).reshape(-1, d)
