"""Obstacle-aware starting solutions: routes that serve every sensor and avoid every obstacle.

Deb's rule never accepts a detour that crosses an obstacle (V5 >= mu) to save a few hundred
Mbit of shortfall (V4), so on dense maps a population that starts from colliding
sensor-serving routes ends collision-free with sensors unserved. `Seeder` builds starts that
are feasible in most cases:

1. once per map, a *reduced visibility graph* (`planner_core.model.routing`): obstacle corners
   pushed out by a margin (circles as circumscribed hexagons), edges between mutually visible
   nodes whose line is tangent to both nodes' polygons (the only edges a shortest path uses);
2. per start (every random draw from the caller's generator): k-means++-seeded sensor clusters
   grown until every sensor lies within a random service radius of a centre; centres pushed out
   of obstacles; an order by nearest neighbour + 2-opt on lengths that charge for crossing
   obstacles; each centre *slid* within its sensors' service radius to clear its legs and
   shorten the tour (red-black sweeps, all candidates in one geometry call); legs still blocked
   (large no-fly zones) routed through the graph (Dijkstra on demand); corners whose neighbours
   see each other dropped; points whose sensors others serve pruned while there are more than
   I_max or while that lowers our estimate of f; still too many -> fewer, larger clusters next
   attempt, finally the least-colliding truncation. Hover times: each sensor from its best
   point (corners included), times a random 1.0-1.1 margin, capped at T_max.

Only geometry queries run here (`overlap_lengths`, `points_inside`, `ModelParams.rates`): the DE
counts the evaluations of the starts itself. The steps other builders reuse are public methods
(the constructive starts of `planner_core.search.construct` and the memetic repair): `push_one`,
`connect`, `slide`, `route`, `prune`, `truncate`, `fill`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

from planner_core.model.formulas import (
    ModelParams,
    flight_time,
    ground_reach,
    leg_time,
    numpy_sum,
    slant_rate,
)
from planner_core.model.geometry import Obstacles, overlap_first, overlap_lengths, points_inside
from planner_core.model.routing import build_visibility_graph, open_tour
from planner_core.model.routing.graph import CLEAR as _CLEAR

__all__ = ["MARGIN", "Seeder"]

#: metres by which graph nodes (and pushed-out points) stand off the obstacles
MARGIN = 20.0
_ORDER_DETOUR = 2.0  # ordering: a blocked leg costs its length + this x its length inside
_BLOCKED = 1e6  # slide objective: cost of one blocked leg (V5 >= mu)
# slide objective: cost of exceeding the bandwidth (V3), per (1 + Mbit/s); above two blocked
# legs, since a blocked leg can still be routed around (visibility-graph corners) while no
# hover time repairs a point that hears too many sensors at once (dense fields, issue 31)
_OVER_BANDWIDTH = 1e7
_OVER_BANDWIDTH_NODE = 1e7  # routing: metres charged to enter a graph corner breaking C3
#: blocked legs whose corners `Seeder.route` keeps (a bound on that table: a call that finds
#: it fuller starts it afresh, so it holds at most this many plus one path's legs; ~400 bytes
#: a leg)
ROUTE_LEGS = 100_000
#: points whose graph links `Seeder.connect` keeps (the same kind of bound: a call that finds
#: the table fuller starts it afresh; a point keeps the corners it sees, ~50-130 on the large
#: maps, ~1 kB; a default L06 plan meets ~4,000 points)
CONNECT_POINTS = 50_000
_BANDWIDTH_USE = 0.98  # points keep their summed rate below this share of the bandwidth
_SLIDE_RINGS = (60.0, 150.0, 300.0, 500.0)  # candidate offsets (m) around a centre
_SLIDE_DIRS = 8
_ATTEMPTS = 4
_RADIUS = (350.0, 800.0)  # range of the random service radius (m)
_SHRINK = 0.6  # the candidate rings shrink by this factor after each full sweep
_SWEEPS = 3


# ----------------------------------------------------------------------------- kernels


@njit(cache=True, nogil=True)
def _slide_costs(cand, prv, nxt, member, S, lim, req, H, peak, decay, bw, v_max, accel, alpha):
    """(n, Q) local cost of moving centre r to candidate q: alpha * flight time of its two
    legs + (1 - alpha) * hover time of its slowest member, + `_OVER_BANDWIDTH` (1 + excess)
    where the summed rate exceeds the bandwidth bw (V3); inf where a member would be out of its
    service radius (candidate 0, the current position, always allowed).

    Per centre only its members and the sensors some candidate can hear (rate > 0 at the
    least distance from the candidates' bounding box) are visited, in sensor order: the others
    add exactly 0 to the summed rate, so the costs equal `_slide_costs_reference` to the bit
    (tests). O(n x (J + Q x sensors in radio range)) instead of O(n x Q x J).
    """
    n, Q = cand.shape[0], cand.shape[1]
    J = S.shape[0]
    out = np.empty((n, Q))
    near = np.empty(J, dtype=np.int64)
    h2 = H * H
    for r in range(n):
        x0 = x1 = cand[r, 0, 0]
        y0 = y1 = cand[r, 0, 1]
        for q in range(1, Q):
            x0 = min(x0, cand[r, q, 0])
            x1 = max(x1, cand[r, q, 0])
            y0 = min(y0, cand[r, q, 1])
            y1 = max(y1, cand[r, q, 1])
        m = 0
        for j in range(J):
            if member[r, j]:
                near[m] = j
                m += 1
                continue
            # the least squared distance of any candidate; the rate falls with the distance
            # (also in floating point), so rate <= 0 there means rate <= 0 at every candidate
            dx = max(max(x0 - S[j, 0], S[j, 0] - x1), 0.0)
            dy = max(max(y0 - S[j, 1], S[j, 1] - y1), 0.0)
            if slant_rate(dx * dx + dy * dy, h2, peak, decay) > 0.0:
                near[m] = j
                m += 1
        _centre_costs(r, near[:m], cand, prv, nxt, member, S, lim, req, h2, peak, decay, bw,
                      v_max, accel, alpha, out)  # fmt: skip
    return out


@njit(cache=True, nogil=True)
def _slide_costs_reference(
    cand, prv, nxt, member, S, lim, req, H, peak, decay, bw, v_max, accel, alpha
):
    """The slow reference of `_slide_costs`: every candidate against every sensor."""
    n = cand.shape[0]
    out = np.empty((n, cand.shape[1]))
    every = np.arange(S.shape[0])
    for r in range(n):
        _centre_costs(r, every, cand, prv, nxt, member, S, lim, req, H * H, peak, decay, bw,
                      v_max, accel, alpha, out)  # fmt: skip
    return out


@njit(cache=True, nogil=True)
def _centre_costs(r, sensors, cand, prv, nxt, member, S, lim, req, h2, peak, decay, bw, v_max,
                  accel, alpha, out):  # fmt: skip
    """Row r of `_slide_costs`: every candidate of centre r against `sensors` (in that order;
    the members among them)."""
    for q in range(cand.shape[1]):
        x = cand[r, q, 0]
        y = cand[r, q, 1]
        hover = 0.0
        total = 0.0
        ok = True
        for j in sensors:
            d2 = (x - S[j, 0]) ** 2 + (y - S[j, 1]) ** 2
            rate = slant_rate(d2, h2, peak, decay)
            total += max(rate, 0.0)
            if member[r, j]:
                if d2 > lim[j] * lim[j]:
                    ok = False
                hover = max(hover, req[j] / max(rate, 1e-9))
        if not ok and q > 0:
            out[r, q] = np.inf
            continue
        l1 = math.hypot(x - prv[r, 0], y - prv[r, 1])
        l2 = math.hypot(nxt[r, 0] - x, nxt[r, 1] - y)
        fly = leg_time(l1, v_max, accel) + leg_time(l2, v_max, accel)
        out[r, q] = alpha * fly + (1.0 - alpha) * hover
        if total > bw:
            out[r, q] += _OVER_BANDWIDTH * (1.0 + total - bw)


@njit(cache=True, nogil=True)
def _slide_candidates(cur, prv, nxt, rings, frac, w, h):
    """Candidates (n, Q, 2) for each centre: itself, itself + rings, and fractions of the way to
    the closest point of the chord prev -> next (clipped to the area); with the legs from prev
    to each candidate and from each candidate to next, packed as (n, 2Q, 2) starts and ends."""
    n = cur.shape[0]
    Q = 1 + rings.shape[0] + frac.shape[0]
    cand = np.empty((n, Q, 2))
    a = np.empty((n, 2 * Q, 2))
    b = np.empty((n, 2 * Q, 2))
    for r in range(n):
        cx, cy = cur[r, 0], cur[r, 1]
        ex, ey = nxt[r, 0] - prv[r, 0], nxt[r, 1] - prv[r, 1]
        t = ((cx - prv[r, 0]) * ex + (cy - prv[r, 1]) * ey) / max(ex * ex + ey * ey, 1e-12)
        t = min(max(t, 0.0), 1.0)
        fx, fy = prv[r, 0] + t * ex - cx, prv[r, 1] + t * ey - cy
        cand[r, 0, 0], cand[r, 0, 1] = cx, cy
        for q in range(rings.shape[0]):
            cand[r, 1 + q, 0] = cx + rings[q, 0]
            cand[r, 1 + q, 1] = cy + rings[q, 1]
        for q in range(frac.shape[0]):
            cand[r, 1 + rings.shape[0] + q, 0] = cx + frac[q] * fx
            cand[r, 1 + rings.shape[0] + q, 1] = cy + frac[q] * fy
        for q in range(Q):
            x = min(max(cand[r, q, 0], 0.0), w)
            y = min(max(cand[r, q, 1], 0.0), h)
            cand[r, q, 0], cand[r, q, 1] = x, y
            a[r, q, 0], a[r, q, 1] = prv[r, 0], prv[r, 1]
            b[r, q, 0], b[r, q, 1] = x, y
            a[r, Q + q, 0], a[r, Q + q, 1] = x, y
            b[r, Q + q, 0], b[r, Q + q, 1] = nxt[r, 0], nxt[r, 1]
    return cand, a, b


@njit(cache=True, nogil=True)
def _kpp_seeds(S, first, u):  # pragma: no cover - compiled
    """The seeder's k-means++ seeds (k = len(u) + 1 sensor indices): first, then for each
    uniform u[i] the first sensor whose cumulative least squared distance to the seeds so far
    exceeds u[i] times the total (numpy's right search), at most J - 1. Each squared distance
    is dx * dx + dy * dy and the cumulative sum runs in index order, as numpy's."""
    J = S.shape[0]
    out = np.empty(u.shape[0] + 1, dtype=np.int64)
    out[0] = first
    d2 = np.empty(J)
    for j in range(J):
        dx = S[j, 0] - S[first, 0]
        dy = S[j, 1] - S[first, 1]
        d2[j] = dx * dx + dy * dy
    cum = np.empty(J)
    for i in range(u.shape[0]):
        c = 0.0
        for j in range(J):
            c += d2[j]
            cum[j] = c
        v = u[i] * cum[J - 1]
        pick = J
        for j in range(J):
            if cum[j] > v:
                pick = j
                break
        pick = min(pick, J - 1)
        out[i + 1] = pick
        for j in range(J):
            dx = S[j, 0] - S[pick, 0]
            dy = S[j, 1] - S[pick, 1]
            d = dx * dx + dy * dy
            if d < d2[j]:
                d2[j] = d
    return out


@njit(cache=True, nogil=True)
def _nearest_centres(S, C):  # pragma: no cover - compiled
    """For sensors S (J, 2) and centres C (K, 2), K >= 1: (the index of each sensor's nearest
    centre (the first of equals, np.argmin's rule), its squared distance dx * dx + dy * dy).
    O(J K)."""
    J, K = S.shape[0], C.shape[0]
    owner = np.zeros(J, dtype=np.int64)
    best = np.empty(J)
    for j in range(J):
        b = np.inf
        o = 0
        for q in range(K):
            dx = S[j, 0] - C[q, 0]
            dy = S[j, 1] - C[q, 1]
            d = dx * dx + dy * dy
            if d < b:
                b = d
                o = q
        owner[j] = o
        best[j] = b
    return owner, best


@njit(cache=True, nogil=True)
def _prune_step(full, R, ok, b1, b2, idx, n, req, c, t_max, alpha, v_max, accel, limit
                ):  # pragma: no cover - compiled
    """One removal of `Seeder.prune`, compiled, on its state for n points: full (>= n + 2,
    2) start, points, end; R (>= n, J) the points' rates; ok (>= n,) whether each point's
    neighbours see each other; b1, b2 (J,) each sensor's best and second-best point; idx the
    points' indices in the prune's input; c = 0.95 T_max. Returns the point m removed (the
    arrays updated in place for n - 1 points; the caller then renews ok[m - 1], ok[m]) or -1
    when the prune stops.

    The bookkeeping: once point m is gone a sensor's best point changes only when m was its
    best (it moves to its second best), so the cost of every removal needs only each sensor's
    best and second-best point and the (n, n) matrix `gain` of the largest need point m hands
    to point i (`own`: each point's own greedy time, the longest need of the sensors it
    serves); a point is a candidate when no sensor it alone serves within c would go unserved
    (its second best cannot) and its neighbours see each other. After the removal the best
    two are recomputed only for the sensors whose best two lost a point (O(n) each), the
    others renumbered; the rates and the legs' clearance are kept and updated, not
    recomputed (the caller checks the two legs that changed). `Seeder.prune_reference` does
    the same from an (n, n, J) array, O(n^2 J) per removal.

    Every quantity as numpy computes it: the greedy times' row sums by `numpy_sum`, leg
    lengths by hypot, Eq. 1 by `leg_time`, first-of-equals extrema, so the points kept equal
    `prune_reference`'s to the bit (tests). O(n^2 + J) (+ O(n J) for the rows moved up)."""
    J = R.shape[1]
    served = np.ones(n, dtype=np.bool_)
    for j in range(J):
        if R[b1[j], j] * c >= req[j] and R[b2[j], j] * c < req[j]:
            served[b1[j]] = False  # removing b1[j] leaves sensor j unserved
    any_cand = False
    for i in range(n):
        if ok[i] and served[i]:
            any_cand = True
            break
    if not any_cand:
        return -1
    own = np.zeros(n)
    gain = np.zeros((n, n))
    for j in range(J):
        need1 = req[j] / max(R[b1[j], j], 1e-12)
        need2 = req[j] / max(R[b2[j], j], 1e-12)
        own[b1[j]] = max(own[b1[j]], need1)
        gain[b1[j], b2[j]] = max(gain[b1[j], b2[j]], need2)
    legs = np.empty(n + 1)
    for i in range(n + 1):
        legs[i] = leg_time(np.hypot(full[i + 1, 0] - full[i, 0], full[i + 1, 1] - full[i, 1]),
                           v_max, accel)
    row = np.empty(n)
    m = -1
    best = 0.0
    for i in range(n):
        if not (ok[i] and served[i]):
            continue
        for q in range(n):
            row[q] = max(own[q], gain[i, q])
        row[i] = 0.0
        short = leg_time(np.hypot(full[i + 2, 0] - full[i, 0], full[i + 2, 1] - full[i, 1]),
                         v_max, accel)
        d_fly = short - legs[i] - legs[i + 1]
        cost = alpha * d_fly + (1.0 - alpha) * numpy_sum(row, 0, n)
        if m < 0 or cost < best:
            m = i
            best = cost
    if n <= limit:
        # `Seeder._times`: each sensor from its best point (the first of equals)
        times = np.zeros(n)
        for j in range(J):
            bi = 0
            for i in range(1, n):
                if R[i, j] > R[bi, j]:
                    bi = i
            r = R[bi, j]
            need = req[j] / max(r, 1e-12) if r > 0 else np.inf
            times[bi] = max(times[bi], min(need, t_max))
        if best >= (1.0 - alpha) * numpy_sum(times, 0, n):
            return -1
    # remove point m (full's row m + 1)
    for i in range(m + 1, n + 1):
        full[i, 0] = full[i + 1, 0]
        full[i, 1] = full[i + 1, 1]
    for i in range(m, n - 1):
        for j in range(J):
            R[i, j] = R[i + 1, j]
        ok[i] = ok[i + 1]
        idx[i] = idx[i + 1]
    n -= 1
    # a sensor's best two change only where m was one of them; the rest renumber
    for j in range(J):
        hit = b1[j] == m or b2[j] == m
        if b1[j] > m:
            b1[j] -= 1
        if b2[j] > m:
            b2[j] -= 1
        if hit and n > 1:
            bi = 0
            for i in range(1, n):
                if R[i, j] > R[bi, j]:
                    bi = i
            bs = -1
            for i in range(n):
                if i != bi and (bs < 0 or R[i, j] > R[bs, j]):
                    bs = i
            b1[j] = bi
            b2[j] = bs
    return m


# ----------------------------------------------------------------------------- seeder


def _best_two(R: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per column of R (n, k), n >= 2: the row of its largest entry and the row of its largest
    once that one is gone, each the first of equals (np.argmax's rule)."""
    b1 = np.argmax(R, axis=0)
    R2 = R.copy()
    R2[b1, cols] = -1.0  # rates are >= 0
    return b1, np.argmax(R2, axis=0)


def _recentred(S: np.ndarray, C: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """The centres C (K, 2) moved to the mean of the sensors S (J, 2) each owns (owner (J,)),
    the empty ones dropped (an empty cluster serves nobody): one k-means step of
    `Seeder._clusters` and its reference."""
    cnt = np.bincount(owner, minlength=len(C))
    sx = np.bincount(owner, weights=S[:, 0], minlength=len(C))
    sy = np.bincount(owner, weights=S[:, 1], minlength=len(C))
    has = cnt > 0
    C[has] = np.column_stack([sx[has], sy[has]]) / cnt[has, None]
    return C[has]


def _uncovered_seeds(S: np.ndarray, gap: np.ndarray, lim: np.ndarray) -> np.ndarray:
    """Sensors (m, 2) to seed new centres at: those out of reach (gap (J,) m > 0), worst
    first, each kept only when farther than its lim (J,) m from the new ones before it
    (`Seeder._clusters` and its reference). O(m J)."""
    new: list[int] = []
    near = np.full(len(S), np.inf)  # each sensor's distance to the nearest new centre
    for j in np.argsort(-gap).tolist():
        if gap[j] <= 0.0:
            break
        if near[j] > lim[j]:
            new.append(j)
            near = np.minimum(near, np.hypot(S[:, 0] - S[j, 0], S[:, 1] - S[j, 1]))
    return S[new].astype(float)


class Seeder:
    """Builds obstacle-aware, sensor-serving starting solutions for one map (reusable).

    `model`: the map's `ModelParams`; `obstacles`: its `geometry.Obstacles`;
    `variable_length`: False for the fixed-length encoding (every start then has I_max points);
    `progress`: told the fraction of the visibility graph's build done (the slow part at the
    obstacle limit; `build_visibility_graph`), None: nothing.
    """

    def __init__(
        self,
        model: ModelParams,
        obstacles: Obstacles,
        *,
        variable_length: bool = True,
        margin: float = MARGIN,
        progress: Callable[[float], None] | None = None,
    ):
        p = self.p = model
        self.obstacles = obstacles
        self.variable_length = bool(variable_length)
        self.margin = float(margin)
        self.graph = build_visibility_graph(obstacles, p.width, p.height, self.margin,
                                            progress=progress)  # fmt: skip
        self.size = np.array([p.width, p.height], dtype=float)
        # farthest ground distance at which 90% of T_max still serves each sensor
        rate_needed = np.maximum(p.required, 1e-9) / (0.9 * p.t_max)
        self.reach = ground_reach(rate_needed, p.altitude, p.peak_rate, p.decay)
        self._ends = self.connect(np.vstack([p.start, p.end]))  # graph links of start, end
        # corners that hear more than the bandwidth (C3) in a dense field: a route through
        # one makes a hover point no hover time repairs, so routes pay `_OVER_BANDWIDTH_NODE`
        # metres to enter one and take it only when nothing else joins the leg's ends
        g = self.graph
        self._c3_bad = (p.rates(g.nodes).sum(axis=1) > p.bandwidth if g.n
                        else np.zeros(0, dtype=bool))
        self._route_weights = (g.weights + _OVER_BANDWIDTH_NODE * self._c3_bad[g.indices]
                               if self._c3_bad.any() else None)
        # each blocked leg's corners by its ends (`route`): valid while the graph, its route
        # weights and `_c3_bad` stay as built here (whoever changes them clears it)
        self._legs: dict[tuple[bytes, bytes, bool, bool], list[int]] = {}
        ang = 2.0 * np.pi * np.arange(_SLIDE_DIRS) / _SLIDE_DIRS
        self._unit = np.column_stack([np.cos(ang), np.sin(ang)])

    @classmethod
    def for_problem(cls, problem: Any, margin: float = MARGIN, *,
                    progress: Callable[[float], None] | None = None) -> Seeder:
        """The seeder of a `planner_core.model.problem.Problem` (its model, obstacles and
        encoding).

        Args:
            problem: the Problem (its `model`, `obstacles`, `variable_length`).
            margin: metres a pushed point is set beyond an obstacle's side, and how far the
                visibility graph pushes the obstacles out (`build_visibility_graph`).
            progress: told the fraction of the visibility graph's build done
                (`build_visibility_graph`'s `progress`); None: nothing.

        Returns:
            A new Seeder.
        """
        return cls(problem.model, problem.obstacles, variable_length=problem.variable_length,
                   margin=margin, progress=progress)  # fmt: skip

    # ------------------------------------------------------------------ geometry helpers
    def _clear(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Whether each leg a -> b is collision-free (`overlap_first`: a cut leg leaves the
        obstacle tests at its first cut; the same answer as ``overlap_lengths <= CLEAR``)."""
        return overlap_first(a, b, self.obstacles) <= _CLEAR

    def _push_out(self, pts: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Points clipped to the area and moved out of any obstacle they are in."""
        pts = np.clip(pts, 0.0, self.size)
        for _ in range(4):
            inside = points_inside(pts, self.obstacles)
            if not inside.any():
                break
            for m in np.flatnonzero(inside):
                pts[m] = self.push_one(pts[m], rng)
            pts = np.clip(pts, 0.0, self.size)
        return pts

    def push_one(self, q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Point q (2,) moved `margin` metres beyond the nearest side of the first obstacle
        containing it (q itself when it is in none); rng only picks a direction for a point at a
        circle's exact centre.

        Args:
            q: (2,) the point, local metres.
            rng: draws the direction for a point within 1e-9 m of a circle's centre (one draw
                when a circle holds q).

        Returns:
            (2,) the moved point, or q itself.
        """
        obs = self.obstacles
        circ = obs.circles
        # only circles whose box holds q can hold it (hypot >= each |coordinate difference|);
        # those are tested exactly, in order, as in `push_one_reference`
        dx, dy = np.abs(q[0] - circ[:, 0]), np.abs(q[1] - circ[:, 1])
        for cx, cy, r in circ[(dx < circ[:, 2]) & (dy < circ[:, 2])]:
            d = math.hypot(q[0] - cx, q[1] - cy)
            if d < r:
                a = rng.random() * 2.0 * math.pi
                u = (q - (cx, cy)) / d if d > 1e-9 else np.array([math.cos(a), math.sin(a)])
                return np.array([cx, cy]) + u * (r + self.margin)
        return self._push_out_of_polygon(q)

    def push_one_reference(self, q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The slow reference of `push_one`: every circle tested with `math.hypot`.

        Args:
            q: (2,) the point, local metres.
            rng: as in `push_one`.

        Returns:
            (2,) the moved point, or q itself (the same as `push_one`).
        """
        obs = self.obstacles
        for cx, cy, r in obs.circles:
            d = math.hypot(q[0] - cx, q[1] - cy)
            if d < r:
                a = rng.random() * 2.0 * math.pi
                u = (q - (cx, cy)) / d if d > 1e-9 else np.array([math.cos(a), math.sin(a)])
                return np.array([cx, cy]) + u * (r + self.margin)
        return self._push_out_of_polygon(q)

    def _push_out_of_polygon(self, q: np.ndarray) -> np.ndarray:
        """`push_one`'s polygon part: q (2,) moved out of the first polygon holding it."""
        obs = self.obstacles
        box = obs.poly_boxes
        near = (box[:, 0] <= q[0]) & (q[0] <= box[:, 2]) & (box[:, 1] <= q[1]) & (q[1] <= box[:, 3])
        for p in np.flatnonzero(near):  # only polygons whose bounding box holds q
            lo, hi = obs.poly_offsets[p], obs.poly_offsets[p + 1]
            nrm = obs.edge_normals[lo:hi]
            sd = np.sum(nrm * (q - obs.poly_vertices[lo:hi]), axis=1)  # < 0 inside
            if np.all(sd < 0.0):
                # out through the nearest real side (a piece's diagonals lead into its region)
                outer = obs.edge_flags[lo:hi] == 0
                e = int(np.argmax(np.where(outer, sd, -np.inf) if outer.any() else sd))
                return q + nrm[e] * (self.margin - sd[e])
        return q

    def connect(self, pts: np.ndarray) -> np.ndarray:
        """(P, N) distance (m) from each point of pts (P, 2) to each graph node it sees,
        tangentially at the node (inf elsewhere).

        A point's row depends on that point alone, so each is kept (the nodes it sees and
        their distances, by the point's coordinates; `CONNECT_POINTS` at most, plus one call's
        points) and a point met again, by the seeder's
        routes or the constructive leg times (a third of L02's points), is not tested again
        against the ~1,000 corners it is tangent to: the new points of a call are tested in
        one `connect_reference` call. The same rows as `connect_reference` (tests).

        Args:
            pts: (P, 2) points, local metres; anything but a float64 (P, 2) array (or an
                empty graph or no points) goes to `connect_reference` uncached.

        Returns:
            (P, N) float array, metres; inf where the point does not see the node tangentially
            (N: the graph's nodes).
        """
        g = self.graph
        pts = np.asarray(pts)
        if g.n == 0 or len(pts) == 0 or pts.dtype != np.float64 or pts.ndim != 2:
            return self.connect_reference(pts)
        links = self.__dict__.setdefault("_links", {})
        if len(links) > CONNECT_POINTS:
            links.clear()
        keys = [q.tobytes() for q in pts]
        new = [i for i, k in enumerate(keys) if k not in links]
        if new:
            rows = self.connect_reference(pts[new])
            for i, row in zip(new, rows, strict=True):
                seen = np.flatnonzero(row != np.inf)
                links[keys[i]] = (seen, row[seen])
        out = np.full((len(pts), g.n), np.inf)
        for i, k in enumerate(keys):
            seen, dist = links[k]
            out[i, seen] = dist
        return out

    def connect_reference(self, pts: np.ndarray) -> np.ndarray:
        """`connect` computed afresh for every point: its slow reference.

        Args:
            pts: (P, 2) points, local metres.

        Returns:
            (P, N) distances, metres (inf elsewhere), as `connect`.
        """
        g = self.graph
        out = np.full((len(pts), g.n), np.inf)
        if g.n == 0 or len(pts) == 0:
            return out
        pi, ni = np.nonzero(g.tangent_mask(pts))
        ok = self._clear(pts[pi], g.nodes[ni])
        pi, ni = pi[ok], ni[ok]
        out[pi, ni] = np.hypot(pts[pi, 0] - g.nodes[ni, 0], pts[pi, 1] - g.nodes[ni, 1])
        return out

    # ------------------------------------------------------------------ clustering
    def _clusters(
        self, rng: np.random.Generator, k: int, radius: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """k-means++-seeded centres, grown until every sensor is within min(radius, reach) of
        one, kept out of obstacles: (centres (K, 2), owner (J,) the centre serving each).

        The seeding and the sensor-to-centre distances are compiled (`_kpp_seeds`,
        `_nearest_centres`): O(k J) and O(J K) per round without the (J, K, 2) arrays, the
        same draws (one integer, then the k - 1 uniforms in one call) and the same arithmetic,
        so the same centres, owners and generator state as `_clusters_reference` (tests)."""
        S = self.p.sensors
        J = len(S)
        k = max(1, min(k, J))
        first = int(rng.integers(J))
        C = S[_kpp_seeds(S, first, rng.random(k - 1))].astype(float)
        lim = np.minimum(radius, self.reach)
        for _ in range(J + 1):
            owner = _nearest_centres(S, C)[0]
            C = _recentred(S, C, owner)
            C = self._push_out(C + rng.normal(0.0, 20.0, C.shape), rng)
            gap = np.sqrt(_nearest_centres(S, C)[1]) - lim  # sqrt is monotone: min of sqrt
            if gap.max() <= 0.0 or len(C) >= 2 * J:
                break
            C = np.vstack([C, self._push_out(_uncovered_seeds(S, gap, lim), rng)])
        owner = _nearest_centres(S, C)[0]
        return C, owner

    def _clusters_reference(
        self, rng: np.random.Generator, k: int, radius: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """`_clusters` with numpy's (J, K, 2) distance arrays and one draw per k-means++ seed:
        its slow reference (tests hold the two equal)."""
        S = self.p.sensors
        J = len(S)
        k = max(1, min(k, J))
        first = int(rng.integers(J))
        idx = [first]
        d2 = np.sum((S - S[first]) ** 2, axis=1)
        for _ in range(1, k):
            # k-means++: the next seed drawn with probability proportional to d2
            cum = np.cumsum(d2)
            j = min(int(np.searchsorted(cum, rng.random() * cum[-1], side="right")), J - 1)
            idx.append(j)
            d2 = np.minimum(d2, np.sum((S - S[j]) ** 2, axis=1))
        C = S[idx].astype(float)
        lim = np.minimum(radius, self.reach)
        for _ in range(J + 1):
            owner = np.argmin(np.sum((S[:, None, :] - C[None]) ** 2, axis=2), axis=1)
            C = _recentred(S, C, owner)
            C = self._push_out(C + rng.normal(0.0, 20.0, C.shape), rng)
            dist = np.sqrt(np.sum((S[:, None, :] - C[None]) ** 2, axis=2))
            gap = dist.min(axis=1) - lim
            if gap.max() <= 0.0 or len(C) >= 2 * J:
                break
            C = np.vstack([C, self._push_out(_uncovered_seeds(S, gap, lim), rng)])
        owner = np.argmin(np.sum((S[:, None, :] - C[None]) ** 2, axis=2), axis=1)
        return C, owner

    # ------------------------------------------------------------------ ordering
    def _order(self, C: np.ndarray) -> np.ndarray:
        """Visiting order of the centres: nearest neighbour, then 2-opt, start and end fixed;
        a blocked leg counts its length plus `_ORDER_DETOUR` times its length inside."""
        p = self.p
        pts = np.vstack([p.start, C, p.end])
        P = len(pts)
        W = np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
        ia, ib = np.triu_indices(P, 1)
        inside = overlap_lengths(pts[ia], pts[ib], self.obstacles)
        W[ia, ib] += _ORDER_DETOUR * inside
        W[ib, ia] = W[ia, ib]
        t = open_tour(W)
        return t[1:-1] - 1

    # ------------------------------------------------------------------ sliding
    def slide(
        self,
        C: np.ndarray,
        owner: np.ndarray,
        lim: np.ndarray,
        rng: np.random.Generator,
        sweeps: int = _SWEEPS,
    ) -> np.ndarray:
        """Centres C (K, 2), already in visiting order, each moved within its sensors' service
        radius (owner (J,): the centre serving each sensor; lim (J,) metres) to clear its two
        legs and lower its share of f; alternate halves, all candidates of a half in one
        geometry call.

        Args:
            C: (K, 2) centres in visiting order, local metres.
            owner: (J,) index of the centre serving each sensor.
            lim: (J,) each sensor's service radius, metres.
            rng: turns the candidate directions (one draw).
            sweeps: rounds; each moves every other centre, then the rest, the candidate rings
                shrinking by `_SHRINK` per round.

        Returns:
            (K, 2) the moved centres (a point whose every candidate lands in an obstacle
            keeps its position); C itself when K is 0.
        """
        p = self.p
        K = len(C)
        if K == 0:
            return C
        S = p.sensors
        member = owner[None, :] == np.arange(K)[:, None]  # (K, J)
        pts = np.vstack([p.start, C, p.end])
        rot = rng.random() * 2.0 * math.pi
        c, s = math.cos(rot), math.sin(rot)
        dirs = self._unit @ np.array([[c, s], [-s, c]])
        rings = (np.array(_SLIDE_RINGS)[:, None, None] * dirs[None]).reshape(-1, 2)
        frac = np.array([0.25, 0.5, 0.75, 1.0])
        for sweep in range(2 * sweeps):
            idx = np.arange(1 + sweep % 2, K + 1, 2)
            if len(idx) == 0:
                continue
            cur, prv, nxt = pts[idx], pts[idx - 1], pts[idx + 1]
            # candidates: stay, rings around, and toward the chord prev -> next
            scale = _SHRINK ** (sweep // 2)
            cand, a, b = _slide_candidates(cur, prv, nxt, rings * scale, frac, *self.size)
            n, Q = cand.shape[:2]
            cost = _slide_costs(
                cand, prv, nxt, member[idx - 1], S, lim, p.required, p.altitude, p.peak_rate,
                p.decay, _BANDWIDTH_USE * p.bandwidth, p.v_max, p.accel, p.alpha,
            )  # fmt: skip
            inside = overlap_lengths(a, b, self.obstacles)
            blocked = (inside[:, :Q] > _CLEAR).astype(float) + (inside[:, Q:] > _CLEAR)
            cost = cost + _BLOCKED * blocked + inside[:, :Q] + inside[:, Q:]
            # a point inside an obstacle has blocked legs, so it only wins when every
            # candidate is blocked; keep the old position then
            pick = cand[np.arange(n), np.argmin(cost, axis=1)]
            pts[idx] = np.where(points_inside(pick, self.obstacles)[:, None], cur, pick)
        return pts[1:-1]

    # ------------------------------------------------------------------ routing
    def route(self, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Path start -> centres C (K, 2) -> end with visibility-graph corners on the legs that
        are still blocked, string-pulled: (interior points (M, 2), is_centre (M,) bool).

        A blocked leg's corners depend on its two ends alone, so each is kept (by the ends'
        coordinates, about `ROUTE_LEGS` at most) and a leg met again, as the improving rounds' moves
        meet the incumbent's legs outside what they change, is not routed again: the same
        corners as a fresh search (tests). Cost: the legs' obstacle tests, O((K + 1) x the
        obstacles' vertices), and a shortest path over the visibility graph per new blocked
        leg.

        Args:
            C: (K, 2) centres in visiting order, local metres.

        Returns:
            (interior points (M, 2) local metres, is_centre (M,) bool: False at a corner).
        """
        p = self.p
        pts = np.vstack([p.start, C, p.end])
        clear = self._clear(pts[:-1], pts[1:])
        out: list[np.ndarray] = [pts[1:-1]]
        is_centre: list[np.ndarray] = [np.ones(len(C), dtype=bool)]
        blocked = np.flatnonzero(~clear)
        if len(blocked) and self.graph.n:
            known = self._legs
            if len(known) > ROUTE_LEGS:
                known.clear()
            last = len(pts) - 1
            key = {leg: (pts[leg].tobytes(), pts[leg + 1].tobytes(), leg == 0, leg + 1 == last)
                   for leg in blocked.tolist()}
            new = np.array([leg for leg, k in key.items() if k not in known], dtype=np.int64)
            links: dict[int, np.ndarray] = {}  # the graph links of the new legs' ends only
            if len(new):
                ends = np.unique(np.concatenate([new, new + 1]))
                inner = ends[(ends > 0) & (ends < last)]
                links[0], links[last] = self._ends[0], self._ends[1]
                links.update(zip(inner.tolist(), self.connect(pts[inner]), strict=True))
                if self._route_weights is not None:  # enter a C3-breaking corner last of all
                    over = _OVER_BANDWIDTH_NODE * self._c3_bad
                    links = {i: row + over for i, row in links.items()}
            pos = np.arange(len(C), dtype=float)  # insertion keys: corners go after centre i-1
            keys = [pos]
            for leg in blocked.tolist():
                path = known.get(key[leg])
                if path is None:
                    _, path = self.graph.route(links[leg], links[leg + 1],
                                               self._route_weights)
                    known[key[leg]] = path
                if path:
                    out.append(self.graph.nodes[path])
                    is_centre.append(np.zeros(len(path), dtype=bool))
                    keys.append(leg - 1 + (np.arange(len(path)) + 1.0) / (len(path) + 1.0))
            order = np.argsort(np.concatenate(keys), kind="stable")
            M = np.concatenate(out)[order]
            centre = np.concatenate(is_centre)[order]
            return self._pull(M, centre)
        return pts[1:-1].copy(), np.ones(len(C), dtype=bool)

    def _pull(self, M: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Drop corners whose neighbours see each other (string pulling), a few passes."""
        p = self.p
        for _ in range(4):
            corners = np.flatnonzero(~centre)
            if len(corners) == 0:
                break
            full = np.vstack([p.start, M, p.end])
            ok = self._clear(full[corners], full[corners + 2])
            drop: list[int] = []
            for m, good in zip(corners.tolist(), ok.tolist(), strict=True):
                if good and (not drop or drop[-1] != m - 1):  # never two neighbours at once
                    drop.append(m)
            if not drop:
                break
            keep = np.ones(len(M), dtype=bool)
            keep[drop] = False
            M, centre = M[keep], centre[keep]
        return M, centre

    def prune(self, M: np.ndarray, limit: int) -> np.ndarray:
        """Route points M (k, 2) with points removed whose sensors the others still serve
        within 95% of T_max and whose neighbours see each other: while more than `limit`
        remain, the one whose removal costs least; then any whose removal lowers the estimated
        f. Returns the kept points in order (m, 2).

        The cost of removing point m: alpha x the flight time it saves (its two legs replaced
        by one) + (1 - alpha) x the greedy hover times of the rest, each sensor served from
        its best remaining point, from every sensor's best and second-best point kept across
        removals (`_prune_step` explains the bookkeeping). Each removal is one compiled step
        (`_prune_step`: O(n^2 + J)) and one check of the two legs it changed; numpy's
        arithmetic is kept (its sums, `hypot`, Eq. 1's `leg_time`), so the same points as
        `prune_reference` (O(n^2 J) per removal) to the bit (tests).

        Args:
            M: (k, 2) route points, local metres.
            limit: points are removed while more than this remain (I_max in `hover_plan`).

        Returns:
            (m, 2) the kept points, in order; M itself (as float (k, 2)) when k <= 1.
        """
        p = self.p
        M = np.asarray(M, dtype=float).reshape(-1, 2)
        if len(M) <= 1:
            return M
        R = p.rates(M)
        full = np.vstack([p.start, M, p.end])
        n = len(M)
        ok = self._clear(full[:n], full[2:])
        b1, b2 = _best_two(R, np.arange(R.shape[1]))
        b1, b2 = b1.astype(np.int64), b2.astype(np.int64)
        R = np.ascontiguousarray(R)
        ok = ok.astype(np.bool_)
        idx = np.arange(n)
        while n > 1:
            m = _prune_step(full, R, ok, b1, b2, idx, n, p.required, 0.95 * p.t_max,
                            float(p.t_max), float(p.alpha), float(p.v_max), float(p.accel),
                            int(limit))  # fmt: skip
            if m < 0:
                break
            n -= 1
            # the legs that skip point m - 1 and point m (as numbered now) changed
            fix = np.array([i for i in (m - 1, m) if 0 <= i < n], dtype=int)
            if len(fix):
                ok[fix] = self._clear(full[fix], full[fix + 2])
        return M[idx[:n]]

    def prune_reference(self, M: np.ndarray, limit: int) -> np.ndarray:
        """`prune` the obvious way: every iteration recomputes, for each point m, the greedy
        hover times of the others from an (n, n, J) array, O(n^3 J) over a prune of n points;
        what `prune` computes from each sensor's best and second-best point (tests hold the
        two equal).

        Args:
            M: (k, 2) route points, local metres.
            limit: the most points kept without a cost saving.

        Returns:
            (m, 2) the kept points, in order (as `prune`).
        """
        p = self.p
        while len(M) > 1:
            full = np.vstack([p.start, M, p.end])
            n = len(M)
            m_idx = np.arange(n)
            ok = self._clear(full[m_idx], full[m_idx + 2])
            R = p.rates(M)  # (n, J)
            # greedy hover times once point m is gone: each sensor from its best other point
            R3 = np.where(np.eye(n, dtype=bool)[:, :, None], -1.0, R[None, :, :])  # (n, n, J)
            best = np.argmax(R3, axis=1)  # (n, J)
            r = np.take_along_axis(R3, best[:, None, :], axis=1)[:, 0, :]
            # no sensor served now may go unserved (one out of reach anyway does not block)
            now = R.max(axis=0) * (0.95 * p.t_max) >= p.required
            served = np.all((r * (0.95 * p.t_max) >= p.required) | ~now, axis=1)
            cand = np.flatnonzero(ok & served)
            if len(cand) == 0:
                break
            need = p.required / np.maximum(r, 1e-12)
            # times[m, i]: the longest need among the sensors point i then serves
            mine = best[:, None, :] == m_idx[None, :, None]  # (n, n, J)
            times = np.max(np.where(mine, need[:, None, :], 0.0), axis=2)
            legs = flight_time(np.hypot(*np.diff(full, axis=0).T), p.v_max, p.accel)
            short = flight_time(np.hypot(*(full[m_idx + 2] - full[m_idx]).T), p.v_max, p.accel)
            d_fly = short - legs[m_idx] - legs[m_idx + 1]
            cost = p.alpha * d_fly + (1.0 - p.alpha) * times.sum(axis=1)
            m = int(cand[np.argmin(cost[cand])])
            if len(M) <= limit and cost[m] >= (1.0 - p.alpha) * self._times(M)[0].sum():
                break
            M = np.delete(M, m, axis=0)
        return M

    def truncate(self, M: np.ndarray, limit: int) -> np.ndarray:
        """Route points M (k, 2) cut to `limit`, each time dropping the one whose removal adds
        the least length inside obstacles (the partially colliding fallback).

        Args:
            M: (k, 2) route points, local metres.
            limit: how many to keep.

        Returns:
            (min(k, limit), 2) the kept points, in order.
        """
        p = self.p
        while len(M) > limit:
            full = np.vstack([p.start, M, p.end])
            m_idx = np.arange(len(M))
            cost = overlap_lengths(full[m_idx], full[m_idx + 2], self.obstacles)
            M = np.delete(M, int(np.argmin(cost)), axis=0)
        return M

    def fill(self, M: np.ndarray, limit: int) -> np.ndarray:
        """Route points M (k, 2) with the longest legs split by collinear points until there
        are `limit` (fixed-length mode: a point on a clear leg keeps it clear).

        Args:
            M: (k, 2) route points, local metres.
            limit: how many points to reach.

        Returns:
            (max(k, limit), 2) points, in route order; each new one at the first of the leg's
            candidate fractions (0.5 first) whose point hears at most `_BANDWIDTH_USE` x the
            bandwidth (C3), else the one that hears least above it.
        """
        p = self.p
        frac = np.array([0.5, 0.35, 0.65, 0.2, 0.8, 0.05, 0.95])
        while len(M) < limit:
            full = np.vstack([p.start, M, p.end])
            seg = np.hypot(*np.diff(full, axis=0).T)
            m = int(np.argmax(seg))
            cand = full[m] + frac[:, None] * (full[m + 1] - full[m])
            over = p.rates(cand).sum(axis=1) - _BANDWIDTH_USE * p.bandwidth
            pick = int(np.argmax(over <= 0.0)) if np.any(over <= 0.0) else int(np.argmin(over))
            M = np.insert(M, m, cand[pick], axis=0)
        return M

    def _times(self, M: np.ndarray, R: np.ndarray | None = None) -> tuple[np.ndarray, int]:
        """Greedy hover times, each sensor served from its best point (capped at T_max):
        (times, how many sensors that leaves short). `R`: the points' link rates (k, J), when
        the caller has them."""
        p = self.p
        times = np.zeros(len(M))
        if len(M) == 0:
            return times, len(p.sensors)
        R = p.rates(M) if R is None else R
        best = np.argmax(R, axis=0)
        r = R[best, np.arange(R.shape[1])]
        need = np.where(r > 0, p.required / np.maximum(r, 1e-12), np.inf)
        np.maximum.at(times, best, np.minimum(need, p.t_max))
        return times, int(np.sum(need > p.t_max * (1 + 1e-9)))

    # ------------------------------------------------------------------ public
    def hover_plan(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """One start as (hover points (M, 2), hover times (M,)); M <= I_max, and M = I_max when
        every slot is active (fixed-length mode).

        Args:
            rng: every random draw of the plan (cluster count, radius, k-means++, jitter,
                time factor).

        Returns:
            (hover points (M, 2) local metres, hover times (M,) s: the greedy times x a
            factor drawn in 1..1.1, capped at T_max). Filled to M = I_max when not
            `variable_length` or tau <= 0.
        """
        p = self.p
        I, J = p.n_points, len(p.sensors)
        hi = min(I, J)
        lo = min(hi, max(1, math.ceil(J / 3)))
        k = int(rng.integers(lo, hi + 1))
        radius = float(rng.uniform(*_RADIUS))
        best: tuple[tuple[int, int, int], np.ndarray] | None = None
        for _ in range(_ATTEMPTS):
            C, owner = self._clusters(rng, k, radius)
            order = self._order(C)
            lim = np.minimum(radius, self.reach)
            C = self.slide(C[order], np.argsort(order)[owner], lim, rng)
            M, _ = self.route(C)
            M = self.prune(M, I)
            full = np.vstack([p.start, M, p.end])
            n_blocked = int(np.sum(~self._clear(full[:-1], full[1:])))
            _, unserved = self._times(M)
            key = (max(len(M) - I, 0), n_blocked, unserved)
            if best is None or key < best[0]:
                best = (key, M)
            if key == (0, 0, 0):
                break
            # too many points (or blocked): fewer, larger clusters next time
            k = max(1, min(len(C), k) - max(1, len(M) - I))
            radius = min(radius * 1.25, float(np.max(self.reach)))
        assert best is not None
        M = best[1]
        if len(M) > I:
            M = self.truncate(M, I)
        if not self.variable_length or p.tau <= 0.0:
            M = self.fill(M, I)
        times, _ = self._times(M)
        return M, np.minimum(times * rng.uniform(1.0, 1.1), p.t_max)

    def solution(self, rng: np.random.Generator) -> np.ndarray:
        """One decision vector: the hover plan at sorted random slots, random inactive rest.

        Args:
            rng: the plan's draws (`hover_plan`), then the slots and the inactive rest.

        Returns:
            (4 n_points,) the rows (x m, y m, t s, eps) flattened: the plan's rows get eps in
            [tau, 1), the others uniform positions in the area, t in [0, T_max) and eps in
            [0, tau).
        """
        p = self.p
        I = p.n_points
        M, times = self.hover_plan(rng)
        k = len(M)
        slots = np.sort(rng.choice(I, size=k, replace=False))
        x = np.empty((I, 4))
        x[:, :2] = rng.random((I, 2)) * self.size
        x[:, 2] = rng.random(I) * p.t_max
        x[:, 3] = rng.random(I) * p.tau  # inactive
        x[slots, :2] = M
        x[slots, 2] = times
        x[slots, 3] = p.tau + rng.random(k) * (1.0 - p.tau)
        return x.reshape(-1)
