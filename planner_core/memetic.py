"""The memetic step of the planner (issue 14): structural moves and exact hover times for the
elite, during the run.

The DE moves every coordinate a little; it rarely changes a plan's structure (the order of the
hover points, how many there are) and never solves the hover times exactly. This step does both
for one solution, cheaply, and hands back a few candidates that the DE evaluates like any
trial (every candidate counts against the budget; `planner_core.de.loop.run` calls it):

1. re-order: 2-opt on the open route start -> hover points -> end by flight time (Eq. 1); a
   reversal is kept only when it shortens the route and keeps every leg collision-free (or
   does not add overlap), so feasibility is never traded for time;
2. exact hover times: the hover-time LP of `planner_core.polish` on the re-ordered points (it
   also drops points whose time is ~0 when that is safe);
3. remove: in the variable-length encoding, the `REMOVALS` points with the smallest LP times are
   each removed in turn, with the LP on the rest (a point the others can cover is pure cost).

Used through `Problem.refine`; deterministic (no randomness).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.geometry import overlap_lengths
from planner_core.polish import polish_hover_times

__all__ = ["refine", "two_opt_order", "REMOVALS"]

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


def refine(problem: Any, x: np.ndarray) -> np.ndarray:
    """Candidates (m, d), problem space, from solution x: re-ordered with LP hover times, then
    each of up to `REMOVALS` removals (module docstring). Empty (0, d) when x has no points."""
    b = problem.breakdown(np.asarray(x, dtype=float))
    pts = np.asarray(b["hover_points"], dtype=float).reshape(-1, 2)
    d = int(np.asarray(problem.lower).shape[0])
    if len(pts) == 0:
        return np.zeros((0, d))
    pts = two_opt_order(problem, pts)
    out = []
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
