"""Destroy-and-repair moves on a feasible plan: a large neighbourhood search (Shaw, "Using
constraint programming and local search methods to solve vehicle routing problems", CP 1998;
Ropke & Pisinger, Transportation Science 40(4), 2006) over the hover points.

`rebuild` removes a window of consecutive hover points, gives the sensors they served new
sites (k-means centres of those sensors, each snapped to the nearest candidate site that keeps
C3, `planner_core.search.construct.candidate_sites`), puts them in the window's gap in the order
of the shortest open path between its ends (`planner_core.model.routing.open_path`), re-routes
legs that cut an obstacle, and evaluates and descends the
plan in a race against the incumbent (`planner_core.search.structure._move`), keeping it when
Deb-better. Kicks (`structure.kicks`) move one point at a time, so a plan whose points serve a
stretch of sensors in a poor grouping stays there: on the large map L07 (120 sensors on a
corridor) two seeds' final plans stayed at f 1950.6 and 1952.2 after 4,000 more kick
evaluations, where 4,000 evaluations of rebuilds reached 1907.0 and 1924.1 (docs/search.md,
"Rebuilding windows").

Cost per move: the data each point collects (the points' rates, I x J), k-means over the
window's sensors (O(k x J_w)), the snap (O(k log n) over the n candidate sites,
`Rebuilder.nearest`), the open path over the k new sites (O(k^2)), then `_move`'s LP
(I x J) and up to `move_trials` evaluations. `Rebuilder` builds the candidate sites once
per problem: O(J^2) sensor-pair midpoints filtered by reach, their rates O(sites x J) and
their obstacle tests O(sites x obstacles).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from planner_core.search.descent import Descent, Evaluate
from planner_core.streams import stream_rng

__all__ = ["OWNS", "REBUILD_ATTEMPTS", "WINDOWS", "Rebuilder", "nearest_reference", "rebuild"]

#: |coordinate| (m) up to which `Rebuilder.nearest` uses its compiled scan (its squared
#: distances stay finite; maps end at 1e6, `mapio.MAX_COORD`); beyond, and for non-finite
#: points, the reference
_TREE_LIMIT = 1e150
#: window sizes (consecutive hover points removed), drawn uniformly
WINDOWS = (2, 3, 4, 5)
#: a sensor is re-served when the window's points collect more than this share of its data
OWNS = 0.5
#: draws per evaluation allowed: a draw refused before evaluation (a site set that breaks C3 or
#: C5 or leaves a sensor unserved, or more points than I_max) costs no evaluation
REBUILD_ATTEMPTS = 20


class Rebuilder:
    """The per-problem table a rebuild needs, built on first use and kept: the candidate
    sites (n, 2) m (`construct.candidate_sites`).

    Args:
        problem: the run's `Problem`.
    """

    def __init__(self, problem: Any) -> None:
        self.problem = problem
        self._sites: np.ndarray | None = None
        self._fast = False
        self._fast_of: np.ndarray | None = None  # the sites `_fast` was judged on

    @property
    def sites(self) -> np.ndarray:
        """Candidate sites (n, 2), metres, within the bandwidth.

        Returns:
            `construct.candidate_sites(problem)`, built on first use and kept.
        """
        if self._sites is None:
            from planner_core.search.construct import candidate_sites

            self._sites = candidate_sites(self.problem)
        return self._sites

    def nearest(self, pts: np.ndarray) -> np.ndarray:
        """Index (k,) of the candidate site nearest to each point of pts (k, 2) m: the first
        index of least squared distance, as `nearest_reference`'s argmin over every site
        (tests hold them equal), by a compiled scan (`_nearest_scan`: the same sums, no
        (k, n, 2) temporary). Cost: O(k n) for n sites, about 10 ns a pair (on L06, 9,629
        sites, a draw's k <= 6 centres take ~0.1 ms; the k-d tree it replaces spent as much
        in its Python calls). Points or sites that are not finite or lie beyond `_TREE_LIMIT`
        go to the reference.

        Args:
            pts: points (k, 2), m.

        Returns:
            (k,) int64 indices into `sites`.
        """
        sites = self.sites
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        if self._fast_of is not sites:  # first use, or new sites
            self._fast = bool(np.isfinite(sites).all()
                              and np.abs(sites).max(initial=0.0) < _TREE_LIMIT)
            self._fast_of = sites
        if not (self._fast and len(sites) and np.isfinite(pts).all()
                and np.abs(pts).max(initial=0.0) < _TREE_LIMIT):
            return nearest_reference(sites, pts)  # beyond any map: squares would overflow
        return _nearest_scan(np.ascontiguousarray(sites), np.ascontiguousarray(pts))

    def draw(self, P: np.ndarray, T: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
        """One rebuilt point set (I', 2) m in visiting order from hover points P (I, 2) m with
        hover times T (I,) s, or None when the draw has nothing to rebuild.

        A window of w consecutive points (w from `WINDOWS`, at most I) is drawn; the sensors
        whose data those points collect more than `OWNS` of (data at point i from sensor j:
        T_i R_ij, the simultaneous-access model of paper Sec. 3; under scheduled access an
        upper bound, used only to group sensors) get k = w - 1, w or w + 1 new sites (k-means
        centres, `construct._kmeans`, each snapped to the nearest candidate site; duplicates
        merged); the other points stay. None when no sensor is the window's or the plan would
        exceed I_max hover points (`Problem.hover_limit`; the re-routing's corners may use
        corner slots).

        Args:
            P: hover points (I, 2), m, in visiting order.
            T: their hover times (I,), s.
            rng: the rebuild's generator (window size and place, k, the k-means init).

        Returns:
            The point set (I', 2), or None (also for I = 0).
        """
        from planner_core.model.routing import open_path
        from planner_core.search.construct import _kmeans

        problem = self.problem
        n = len(P)
        if n == 0:
            return None
        w = min(int(rng.choice(WINDOWS)), n)
        i = int(rng.integers(0, n - w + 1))
        D = problem.rates(P) * T[:, None]  # (I, J) Mbit
        total = D.sum(axis=0)
        share = D[i:i + w].sum(axis=0) / np.maximum(total, 1e-12)
        owned = np.flatnonzero(share > OWNS)
        k = min(max(1, w + int(rng.integers(-1, 2))), len(owned))
        if k < 1:
            return None
        S = np.asarray(problem.sensors, dtype=float)[owned]
        centres = _kmeans(S, k, rng)
        new = _unique_rows(self.sites[np.unique(self.nearest(centres))])
        if n - w + len(new) > problem.hover_limit:
            return None
        # the new sites fill the window's gap, in the order of the shortest open path from the
        # point before it to the point after it (Eq. 1 times of straight legs)
        prev = P[i - 1] if i > 0 else problem.start
        nxt = P[i + w] if i + w < n else problem.end
        nodes = np.vstack([prev, new, nxt])
        W = problem.model.flight_time(np.hypot(*(nodes[:, None, :] - nodes[None, :, :]).T))
        order = open_path(np.ascontiguousarray(W))[1:-1] - 1
        return np.vstack([P[:i], new[order], P[i + w:]])


@njit(cache=True, fastmath=False, nogil=True)
def _nearest_scan(sites, pts):  # pragma: no cover - compiled
    """For each point, the first site index of least (dx^2 + dy^2), as `nearest_reference`
    sums it (finite inputs)."""
    out = np.empty(len(pts), dtype=np.int64)
    for q in range(len(pts)):
        px, py = pts[q, 0], pts[q, 1]
        best, arg = np.inf, 0
        for i in range(len(sites)):
            dx = px - sites[i, 0]
            dy = py - sites[i, 1]
            d2 = dx * dx + dy * dy
            if d2 < best:
                best, arg = d2, i
        out[q] = arg
    return out


def _unique_rows(a: np.ndarray) -> np.ndarray:
    """`np.unique(a, axis=0)` for a few rows (k, 2): the distinct rows in lexicographic order
    (x, then y), without its structured-view sort (a sixth of a draw on the large maps)."""
    if len(a) < 2:
        return a.copy()
    a = a[np.lexsort((a[:, 1], a[:, 0]))]
    keep = np.r_[True, np.any(a[1:] != a[:-1], axis=1)]
    return a[keep]


def nearest_reference(sites: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Index (k,) of the site of sites (n, 2) nearest to each point of pts (k, 2): the first
    index of least squared distance over every site (`Rebuilder.nearest`'s reference). O(k n).

    Args:
        sites: the sites (n, 2), m.
        pts: the points (k, 2), m.

    Returns:
        (k,) int indices into `sites`.
    """
    d2 = ((pts[:, None, :] - sites[None, :, :]) ** 2).sum(axis=-1)
    return d2.argmin(axis=1)


def rebuild(
    problem: Any, x: np.ndarray, evaluate: Evaluate, *, trials: int, seed: int,
    stream: int = 0, move_trials: int = 40, rebuilder: Rebuilder | None = None,
) -> Descent | None:
    """Large neighbourhood search around plan x (d,): `Rebuilder.draw` destroys a window of
    hover points and repairs it with new sites; each drawn plan is evaluated with its LP hover
    times and descended in a race against the incumbent (`structure.perturbation_search`, the
    loop `kicks` shares, through `structure._move`: at most
    `move_trials` more evaluations, legs through obstacles re-routed first), and kept when
    Deb-better; repeated until `trials` evaluations are spent (at most `REBUILD_ATTEMPTS` x
    `trials` draws). Zero-time points (detour corners, points the LP left idle) are dropped
    before each draw: the re-routing puts back the corners a leg needs.

    Args:
        problem: the run's `Problem`; x (d,): a plan; evaluate: the run's counted evaluator.
        trials: evaluations to spend; seed, stream: the random stream (same seed and stream,
            same plan; the pipeline's improving rounds pass their step).
        move_trials: a move's descent cap; rebuilder: the tables to reuse (None: built here).

    Returns:
        The best plan found (`Descent`), or None in the fixed-length mode or with tau <= 0
        (the number of points is fixed), for an infeasible x or `trials` < 1.
    """
    from planner_core.search.structure import perturbation_search

    if not problem.variable_length or problem.tau <= 0.0 or trials < 1:
        return None
    rng = stream_rng(seed, "rebuild", stream)
    rb = rebuilder

    def destroy_and_repair(P: np.ndarray, T: np.ndarray) -> np.ndarray | None:
        nonlocal rb
        if rb is None:  # built on the first draw: not for an infeasible x
            rb = Rebuilder(problem)
        keep = T > 0.0
        return rb.draw(P[keep], T[keep], rng)

    return perturbation_search(problem, x, evaluate, destroy_and_repair, trials=trials,
                               attempts=REBUILD_ATTEMPTS, move_trials=move_trials,
                               reroute=True)
