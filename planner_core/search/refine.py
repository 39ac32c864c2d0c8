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
from numba import njit

from planner_core.model.formulas import slant_rate
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
    """Hover points (k, 2) re-ordered by 2-opt on the open route from the map's start to its
    end: in each pass the reversal of most gain is kept when the route gets faster (Eq. 1 leg
    times) and its total overlap does not grow.

    Args:
        problem: the UAV `Problem` (start, end, obstacles, flight time).
        pts: hover points (k, 2), m.
        max_passes: the most passes (one reversal each).

    Returns:
        The points (k, 2) in the new order (the rows permuted, not their indices); `pts`
        as (k, 2) for k < 2.
    """
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

    Args:
        setting: "on", "off" or "auto".
        problem: the problem as the optimiser sees it.

    Returns:
        Whether the memetic step runs.

    Raises:
        ValueError: naming `memetic`, for any other setting.
    """
    from planner_core.defaults import check

    check("memetic", setting)
    if setting == "auto":
        return not hasattr(problem, "initial_population")
    return setting == "on"


def covers(problem: Any, sites: np.ndarray, frac: float = SERVE_FRACTION,
           rates: np.ndarray | None = None) -> np.ndarray:
    """(n, J) bool: whether hovering frac x T_max at each of the sites (n, 2) collects each
    sensor's required data (Eq. R_ij; a sensor that needs nothing counts as covered).

    Args:
        problem: the UAV `Problem` (required data, T_max, link).
        sites: hover sites (n, 2), m.
        frac: the share of T_max hovered.
        rates: the sites' link rates (n, J) Mbit/s, when the caller keeps them.

    Returns:
        (n, J) bool.
    """
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
    step evaluates both. Deterministic.

    Args:
        problem: the UAV `Problem` (model, seeder).
        pts: hover points (k, 2), m, in visiting order.

    Returns:
        One or two point sets (m, 2), m; the second only when the route outgrew I_max and
        the other way gave another set.
    """
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


#: pairs whose trial routes `_merge_pair` builds at once when it scores its shortlist exactly
#: (bounds its memory: a block holds one trial route of k + 1 legs per pair)
_MERGE_BLOCK = 1 << 20
#: `_merge_pair`'s shortlist margin, in units of (k + 2) x the route's flight time: a pair's
#: added time from its changed legs alone differs from the whole trial route's sum minus the
#: base by rounding only (~(k + 2) x 1.1e-16 of the route time), so every pair within this
#: margin of the least is scored exactly and the rest cannot be the least
_MERGE_SLACK = 1e-12


def _sole_servers(serves: np.ndarray, need: np.ndarray) -> tuple[np.ndarray, ...]:
    """The sensors (needing data) that one point or exactly two points serve, as sorted lists
    per point and per pair: (u1_ptr (k + 1,), u1_idx, u2_ptr (k (k - 1) / 2 + 1,), u2_idx),
    CSR form, sensors ascending within each list; pairs (i < j) in `np.triu_indices` order."""
    k = serves.shape[0]
    count = serves.sum(axis=0)
    first = np.argmax(serves, axis=0)
    last = k - 1 - np.argmax(serves[::-1], axis=0)
    one = np.flatnonzero((count == 1) & (need > 0))
    order = np.argsort(first[one], kind="stable")
    u1_idx = one[order]
    u1_ptr = np.zeros(k + 1, dtype=np.int64)
    np.cumsum(np.bincount(first[one], minlength=k), out=u1_ptr[1:])
    two = np.flatnonzero((count == 2) & (need > 0))
    p, q = first[two], last[two]
    pair = p * k - p * (p + 1) // 2 + (q - p - 1)
    order = np.argsort(pair, kind="stable")
    u2_idx = two[order]
    n_pairs = k * (k - 1) // 2
    u2_ptr = np.zeros(n_pairs + 1, dtype=np.int64)
    np.cumsum(np.bincount(pair, minlength=n_pairs), out=u2_ptr[1:])
    return u1_ptr, u1_idx.astype(np.int64), u2_ptr, u2_idx.astype(np.int64)


@njit(cache=True, nogil=True)
def _merge_places(pts, sensors, need, ii, jj, u1_ptr, u1_idx, u2_ptr, u2_idx, h2, peak_rate,
                  decay, serve_t):  # pragma: no cover - compiled
    """Per pair (ii[p], jj[p]): both places (midpoint, centroid of the sensors only the pair
    serves, summed in sensor order) and whether each still serves all of those sensors
    (`covers`' test, the rates as `_link_rates_2d` computes them). Returns places (P, 2, 2),
    valid (P, 2)."""
    n_pairs = ii.shape[0]
    places = np.full((n_pairs, 2, 2), np.nan)
    valid = np.zeros((n_pairs, 2), dtype=np.bool_)
    buf = np.empty(sensors.shape[0], dtype=np.int64)
    big = sensors.shape[0] + 1
    for p in range(n_pairs):
        i, j = ii[p], jj[p]
        mx = 0.5 * (pts[i, 0] + pts[j, 0])
        my = 0.5 * (pts[i, 1] + pts[j, 1])
        places[p, 0, 0] = mx
        places[p, 0, 1] = my
        # the pair's own sensors: i's alone, j's alone and the two's together, merged ascending
        a, a_end = u1_ptr[i], u1_ptr[i + 1]
        b, b_end = u1_ptr[j], u1_ptr[j + 1]
        c, c_end = u2_ptr[p], u2_ptr[p + 1]
        n = 0
        while a < a_end or b < b_end or c < c_end:
            sa = u1_idx[a] if a < a_end else big
            sb = u1_idx[b] if b < b_end else big
            sc = u2_idx[c] if c < c_end else big
            if sa <= sb and sa <= sc:
                buf[n] = sa
                a += 1
            elif sb <= sc:
                buf[n] = sb
                b += 1
            else:
                buf[n] = sc
                c += 1
            n += 1
        if n == 0:
            valid[p, 0] = True
            continue
        sx = 0.0
        sy = 0.0
        for t in range(n):
            sx += sensors[buf[t], 0]
            sy += sensors[buf[t], 1]
        cx = sx / n
        cy = sy / n
        places[p, 1, 0] = cx
        places[p, 1, 1] = cy
        for c2 in range(2):
            qx = mx if c2 == 0 else cx
            qy = my if c2 == 0 else cy
            ok = True
            for t in range(n):
                s = buf[t]
                dx = qx - sensors[s, 0]
                dy = qy - sensors[s, 1]
                rate = max(slant_rate(dx * dx + dy * dy, h2, peak_rate, decay), 0.0)
                if not rate * serve_t >= need[s]:
                    ok = False
                    break
            valid[p, c2] = ok
    return places, valid


def _merge_pair(problem: Any, pts: np.ndarray) -> np.ndarray | None:
    """pts (k, 2) with two points replaced by one that still serves every sensor only those two
    serve (within the seeder's reach: 90 % of T_max), placed at their sensors' centroid or the
    pair's midpoint, choosing the pair and place that add the least flight time (the first in
    pair order, midpoint before centroid, among equals); None when no pair can be merged. The
    merged point takes the first point's place in the route.

    A sensor is the pair's own when every point serving it is one of the two, so only the
    sensors one point or exactly two points serve can be (`_sole_servers`): each pair checks
    its own few (compiled, `_merge_places`) instead of all J. Each pair's added time is first
    taken from the legs it changes (O(1)); the pairs within `_MERGE_SLACK` of the least are
    then scored as the reference does, on the whole trial route (blocks of `_MERGE_BLOCK`), so
    the choice is the reference's to the bit. One call costs O(k J) for the coverage, O(k^2)
    for the pairs plus O(k) per sensor a single point serves (k pairs hold it), and O(k) per
    shortlisted pair; `merge_pair_reference` is the loop it replaces (tests hold the two
    equal)."""
    mp = problem.model
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    k = len(pts)
    if k < 2:
        return None
    need = np.asarray(mp.required, dtype=float)
    serves = covers(problem, pts)  # (k, J)
    sensors = np.ascontiguousarray(mp.sensors, dtype=float)
    ii, jj = np.triu_indices(k, 1)  # the reference's loop order: i, then j > i
    u1_ptr, u1_idx, u2_ptr, u2_idx = _sole_servers(serves, need)
    places, valid = _merge_places(pts, sensors, need, ii.astype(np.int64), jj.astype(np.int64),
                                  u1_ptr, u1_idx, u2_ptr, u2_idx, float(mp.altitude) ** 2,
                                  float(mp.peak_rate), float(mp.decay),
                                  SERVE_FRACTION * mp.t_max)
    if not valid.any():
        return None
    base = _route_flight_time(problem, pts)
    full = np.vstack([problem.start, pts, problem.end])
    leg = mp.flight_time(np.linalg.norm(np.diff(full, axis=0), axis=1))  # (k + 1,)

    def ft(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return mp.flight_time(np.hypot(b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]))

    # added time from the changed legs: i's two legs to the new place, j's two legs closed up
    # (the four legs i-1 -> i -> j -> j+1 become i-1 -> q -> j+1 for neighbours)
    adj = jj == ii + 1
    q = places  # (P, 2, 2)
    after_i = np.where(adj, jj + 2, ii + 2)  # the node the new place flies on to
    new = ft(full[ii][:, None, :], q) + ft(q, full[after_i][:, None, :])
    old = leg[ii] + leg[ii + 1] + np.where(adj, leg[jj + 1], leg[jj] + leg[jj + 1])
    closed = np.where(adj, 0.0, ft(full[jj], full[jj + 2]))
    with np.errstate(invalid="ignore"):
        delta = np.where(valid, new - old[:, None] + closed[:, None], np.inf).reshape(-1)
    least = float(np.min(delta))
    slack = _MERGE_SLACK * (k + 2) * (abs(base) + abs(least) + 1.0)
    short = np.flatnonzero(delta <= least + 2.0 * slack)  # ascending: pair, then place
    # the shortlist scored as the reference scores a trial: the whole route's flight time
    cols = np.arange(k + 1)[None, :]
    block = max(1, _MERGE_BLOCK // (k + 2))
    best: tuple[float, int] | None = None  # (added time, flat index)
    for lo in range(0, len(short), block):
        flat = short[lo : lo + block]
        pair, place = flat // 2, flat % 2
        i, j = ii[pair], jj[pair]
        nodes = full[cols + (cols >= (j + 1)[:, None])]
        nodes[np.arange(len(flat)), i + 1] = places[pair, place]
        d = np.linalg.norm(np.diff(nodes, axis=1), axis=2)
        t = mp.flight_time(d).sum(axis=1) - base
        m = int(np.argmin(t))
        if best is None or t[m] < best[0]:
            best = (float(t[m]), int(flat[m]))
    assert best is not None
    pair, place = best[1] // 2, best[1] % 2
    i, j = int(ii[pair]), int(jj[pair])
    trial = np.delete(pts, j, axis=0)
    if place == 0:
        trial[i] = 0.5 * (pts[i] + pts[j])
    else:
        count = serves.sum(axis=0)
        own = (serves[i] | serves[j]) & (count - serves[i] - serves[j] <= 0) & (need > 0)
        trial[i] = sensors[own].mean(axis=0)
    return trial


def merge_pair_reference(problem: Any, pts: np.ndarray) -> np.ndarray | None:
    """`_merge_pair` the obvious way, pair by pair and place by place (one rate row and one
    route sum each): what `_merge_pair` computes in blocks of pairs (tests hold the two
    equal).

    Args:
        problem: the UAV `Problem`.
        pts: hover points (k, 2), m.

    Returns:
        The points (k - 1, 2) with the pair merged, or None when no pair can be merged.
    """
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
    (`benchmarks/validate_policy.py --pipeline repair`).

    Args:
        problem: the UAV `Problem`.
        x: a decision vector (d,), problem space.

    Returns:
        (m, d) candidates, m <= 2 (one per non-empty repaired set).
    """
    b = problem.breakdown(np.asarray(x, dtype=float))
    d = int(np.asarray(problem.lower).shape[0])
    return np.asarray(_repairs(problem, b), dtype=float).reshape(-1, d)


def refine(problem: Any, x: np.ndarray) -> np.ndarray:
    """Candidates (m, d), problem space, from solution x: re-ordered with LP hover times, then
    each of up to `REMOVALS` removals, and for an infeasible x its repair (module docstring).

    Args:
        problem: the UAV `Problem`.
        x: a decision vector (d,), problem space.

    Returns:
        (m, d) candidates in this order: the repairs (infeasible x only); then, when x has
        hover points, the 2-opt order with LP times, the points pulled `PULLS` of the way
        towards their route neighbours' midpoint (LP times), and (variable length, more
        than one point) each of the `REMOVALS` least-time points removed.
    """
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
