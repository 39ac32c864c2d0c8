"""Window re-planning: a stretch of a large plan planned again as a map of its own, by the
pipeline that is strong at the paper's sizes (POPMUSIC, Taillard & Voss, "POPMUSIC: Partial
Optimization Metaheuristic under Special Intensification Conditions", Essays and Surveys in
Metaheuristics, 2002: a large solution improved one part at a time, each part solved as a
small problem).

`replan_window` takes `width` consecutive hover points of the incumbent that hover (detour
corners are left to the re-routing), and makes a sub-map (`planner_core.model.mapio.sub_map_dict`):
start and end at the points before and after the window (the map's start or end at the plan's
ends), each sensor's required data what the window must collect given what the other points
collect now at their LP hover times (paper Sec. 3, simultaneous access: data at point i from
sensor j is T_i R_ij; in scheduled access the most their times can take, the evaluation's
max flow), the sensors and obstacles that meet the box of the window's points,
ends and those sensors widened by `MARGIN` (a sub-plan's leg that crosses a dropped obstacle
is re-routed when spliced, and the spliced plan is evaluated, C3 and C5 included, on the whole
map), I_max `SUB_POINTS`. The sub-map is planned by `WINDOW_PIPELINE` (the default pipeline
without seeder plans; `SUB_CANDIDATES` constructive plans, the DE's start uniform) with what
is left of the run's time limit and `sub_budget`'s evaluations: the improving stage's left,
shared among the windows to the end of the sweep (a sweep covers the plan once), at least
`SUB_MIN` and at most `SUB_BUDGET` (599 at the default quantum of 640: the race's 41 come
off); its hover points replace the window's, and the plan is evaluated with its LP hover
times and descended in a race against the incumbent (`planner_core.search.structure._move`:
legs that cut an obstacle re-routed first), kept when Deb-better. The sub-run's evaluations
are charged to the run's evaluator (`Evaluator.charge`), one for one.

Why: the improving rounds move one point or rebuild 2-5 points at a time; on the large maps
their plans stay 1-3 % above the long runs' best-known, while the pipeline on a map of ~20
sensors is at its best-known within a fraction of a second. On L02's final plan (seed 2),
eight windows of 8 points at 600 evaluations each took f from 4872.7 to 4816.8 (-1.15 %);
docs/scaling.md, "Windows planned again". Why a sweep's share: on L03 (~180 hovering points,
~22 windows a sweep) 600 evaluations a window covered a third of the plan before the budget
ended, and the share lowered f by 0.45 % (10 seeds, each lower); on L01 (~5 windows a sweep)
a fixed 200 or 300 raised it by 0.2-0.3 %, the share left it as it was (docs/scaling.md,
"A sweep's share").

Cost per window: the sub-map's problem (its visibility graph over the window's obstacles),
the sub-run (constructive plans over ~`width` x 3 sensors, LPs of ~`width` points), the whole
plan's rates (I x J) and `_move`'s LP and race; independent of the sensors outside the window
but for those O(I J) terms.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.model.formulas import deb_better

__all__ = ["MARGIN", "MIN_SECONDS", "RACE_TRIALS", "SUB_BUDGET", "SUB_CANDIDATES", "SUB_MIN",
           "SUB_POINTS", "WIDTH", "replan_window", "sub_budget", "window_map"]

#: hover points with hover time that one window replaces
WIDTH = 8
#: evaluations of one window's pipeline run (at most; the action's quantum less the race)
SUB_BUDGET = 600
#: evaluations of one window's pipeline run at least, where the action's trials allow
SUB_MIN = 150
#: constructive plans of a window's run (the default's 64 cost most of a 600-evaluation run)
SUB_CANDIDATES = 24
#: I_max of a window's map: at most the paper's sizes (its run takes the paper's rounds, so
#: windows never nest)
SUB_POINTS = 20
#: metres added on each side of the box of the window's points, ends and needing sensors: the
#: sub-map keeps the sensors (C3 with them) and the obstacles that meet the larger box; beyond
#: the radio reach (995 m on the large maps; 1.2 x the link's range cut where that is more)
MARGIN = 1200.0
#: the race of the spliced plan: at most this many evaluations after its own
RACE_TRIALS = 40
#: seconds of the run's time limit a window needs left to start
MIN_SECONDS = 0.05


def sub_budget(remaining: int, trials: int, n: int, i: int, w: int) -> int:
    """Evaluations of the sub-run of the window P[i:i + w] of n hovering points: `remaining`
    (the improving stage's evaluations left) shared among the windows from i to the sweep's
    end, less each one's race, between `SUB_MIN` and `SUB_BUDGET`, and at most what the
    action's `trials` leave after the race (below 100: no window, `replan_window`'s rule).

    Args:
        remaining: the improving stage's evaluations left.
        trials: evaluations the action may spend.
        n: hovering points of the plan.
        i: the window's first point.
        w: the window's width (points).

    Returns:
        The sub-run's budget (evaluations).
    """
    left = max(-(-(int(n) - int(i)) // max(int(w), 1)), 1)  # windows to the sweep's end
    share = int(remaining) // left - 1 - RACE_TRIALS
    return min(SUB_BUDGET, int(trials) - 1 - RACE_TRIALS, max(SUB_MIN, share))


def window_map(problem: Any, P: np.ndarray, T: np.ndarray, i: int, w: int
               ) -> dict[str, Any] | None:
    """The sub-map of the window P[i:i + w] of hover points P (n, 2) m with hover times T (n,)
    s (module docstring), or None when the other points already collect every sensor's data.

    Args:
        problem: the run's `Problem` (its model, map, start and end).
        P: the hovering points (n, 2), m.
        T: their hover times (n,), s.
        i: the window's first point.
        w: the window's width (points).

    Returns:
        A map dict (`planner_core.model.mapio.load_map` reads it), or None.
    """
    from planner_core.model.mapio import sub_map_dict

    m = problem.model
    n = len(P)
    out = np.r_[0:i, i + w:n]
    if getattr(problem, "scheduled", False):  # the most the other points' times can take
        from planner_core.search.polish import _collected

        got = _collected(problem, m.rates(P[out]), T[out])
    else:
        D = m.rates(P) * T[:, None]  # (n, J) Mbit collected at each point from each sensor
        got = D[out].sum(axis=0)
    req = np.maximum(m.required - got, 0.0)
    req = np.where(req > 1e-6 * np.maximum(m.required, 1e-12), req, 0.0)
    need = req > 0.0
    if not need.any():
        return None
    a = P[i - 1] if i > 0 else np.asarray(problem.start, dtype=float)
    e = P[i + w] if i + w < n else np.asarray(problem.end, dtype=float)
    S = np.asarray(m.sensors, dtype=float)
    pts = np.vstack([P[i:i + w], a, e, S[need]])
    half = float(m.window.half)  # the link's range cut (m): no rate beyond it
    margin = max(MARGIN, 1.2 * half) if np.isfinite(half) else MARGIN
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    near = np.all((S >= lo) & (S <= hi), axis=1)
    d = sub_map_dict(problem.map, a, e, req, keep=near | need, box=(lo, hi),
                     name=f"window-{i}")  # not the map's name: that may be at its length limit
    d["uav"] = dict(d.get("uav") or {})
    d["uav"]["max_hover_points"] = int(SUB_POINTS)
    return d


def replan_window(
    problem: Any, ev: Any, *, index: int, trials: int, seed: int, width: int = WIDTH,
) -> tuple[int, bool]:
    """Plan the window of `width` hovering points starting at `index` (modulo their number)
    of the run's incumbent again (module docstring), through the run's evaluator `ev`: the
    sub-run's evaluations charged, the spliced plan evaluated and raced.

    Args:
        problem: the run's `Problem`; ev: its `Evaluator` (the incumbent is `ev.best()`).
        index: the window's first point among the hovering points; trials: evaluations it
            may spend (the sub-run gets `sub_budget`'s share of `ev.remaining`, at most
            trials - 1 - `RACE_TRIALS`); seed: the sub-run's seed; width: hovering points
            in a window.

    Returns:
        (the next window's index: after the window, or after the spliced points when the
        incumbent improved, counted as if every spliced point hovers, so approximately;
        whether the incumbent improved). A window whose sensors the other points already
        serve, a sub-map the map reader refuses, an infeasible sub-plan or one past I_max
        spends only the sub-run (or nothing); so does a fixed-length problem (variable
        length only: a window changes the number of points) and a run with less than
        `MIN_SECONDS` of its time limit left.
    """
    from planner_core.model.mapio import MapError, load_map
    from planner_core.model.problem import Problem
    from planner_core.pipeline import WINDOW_PIPELINE, PlanConfig, run_pipeline
    from planner_core.search.descent import hover_of
    from planner_core.search.structure import _move

    x, f0, phi0 = ev.best()
    b = problem.breakdown(x)
    P, T = hover_of(b)
    keep = T > 0.0
    P, T = P[keep], T[keep]
    n = len(P)
    left_s = None if ev.time_limit is None else ev.time_limit - ev.elapsed
    if (phi0 > 0 or n < 2 or not problem.variable_length
            or (left_s is not None and left_s < MIN_SECONDS)):
        return index, False
    w = min(int(width), n)
    i = int(index) % n
    i = min(i, n - w)
    budget = sub_budget(ev.remaining, trials, n, i, w)
    if budget < 100:  # the action's last evaluations: too few for a pipeline run
        return index, False
    nxt = i + w if i + w < n else 0
    d = window_map(problem, P, T, i, w)
    if d is None:
        return nxt, False
    try:
        sub = Problem(load_map(d), variable_length=problem.variable_length)
    except (MapError, ValueError):
        return nxt, False
    res = run_pipeline(sub, PlanConfig(seed=int(seed), budget=budget, init="uniform",
                                       start_candidates=SUB_CANDIDATES, time_limit=left_s),
                       pipeline=WINDOW_PIPELINE)
    ev.charge(res.evaluations)
    sb = sub.breakdown(res.x)
    if sb["phi"] > 0:
        return nxt, False
    Ps = np.asarray(sb["hover_points"], dtype=float).reshape(-1, 2)
    Q = np.vstack([P[:i], Ps, P[i + w:]])
    if not 0 < len(Q) <= problem.hover_limit:
        return nxt, False
    left = min(RACE_TRIALS + 1, ev.remaining)
    if left < 1:
        return nxt, False
    r = _move(problem, Q, ev.evaluate, left, reroute=True, incumbent=float(f0))
    if r is None or not deb_better(r[1], r[2], float(f0), float(phi0)):
        return nxt, False
    return (i + len(Ps)) % max(len(Ps) + n - w, 1), True
