"""Constructive starts (issue 14): whole plans built from the sensors, no search.

What a UAV/WSN engineer builds by hand, as a pipeline of well-known steps; `plan` puts the best
of these plans into the DE's initial population (`WithStarts`), and the `engineering` benchmark
peer (`planner_core.bench.baselines.engineering`) is this pipeline alone.

1. **Service reach.** A hover site *covers* sensor j when hovering `frac` x T_max there collects
   its data Q_j, i.e. it lies within `ground_reach(Q_j / (frac T_max))` of the sensor (the link
   model of Sec. 3 read backwards; frac = 0.9 is the seeder's reach).
2. **Candidate sites**: the sensor positions, the midpoints of sensor pairs, and every k-means
   centre of step 4; each moved out of any obstacle (the seeder's `push_one`) and dropped when
   its summed link rate exceeds 98 % of the bandwidth (C3). A sensor no candidate covers keeps
   its own (pushed-out) position as a candidate, so every cover exists.
3. **Greedy set cover** (Chvatal 1979, "A greedy heuristic for the set-covering problem",
   Math. Oper. Res. 4(3)): repeatedly the site covering the most still-uncovered sensors (ties:
   the shortest hover time those sensors need there, max_j Q_j / R_ij; then the lowest index).
   One cover per reach fraction in `FRACTIONS` (a tight reach: more sites, shorter hovers); a
   sensor no site covers at that fraction is covered at T_max.
4. **k-means sweep** over k = 1 .. min(I_max, J) (`scipy.cluster.vq.kmeans2`, k-means++ init,
   Arthur & Vassilvitskii 2007; `KMEANS_INITS` inits per k from the run's seed): the centres,
   completed to a cover at frac = 0.9 by the greedy of step 3 when some sensor is out of reach.
5. **Visiting order** of each site set on the open path start -> sites -> end (`order_sites`):
   arc costs the Eq. 1 flight time of the fastest obstacle-free way between the two points
   (`LegTimes`: straight when the leg is clear, else through the reduced visibility graph of
   `planner_core.model.routing`, every corner a stop), ordered by
   `planner_core.model.routing.open_path`
   (nearest neighbour and cheapest insertion, each improved by 2-opt and Or-opt; no OR-Tools on
   the planning path; the `engineering` peer can order with OR-Tools' routing solver instead).
6. **Line of sight and I_max**: each site is nudged within its sensors' service reach to clear
   its two legs and shorten them (`Seeder.slide`: every detour corner costs one of the I_max
   hover points, so a site that sees its neighbours saves them), then
   `planner_core.search.refine.repair_points`: every still-blocked leg routed through the visibility
   graph (`Seeder.route`), brought back to I_max points in one or two ways (route then
   prune/merge; merge then re-route), each a plan.
7. **Hover times**: the hover-time LP of `planner_core.search.polish` (the same LP every peer ends
   with); the plan as a decision vector of the problem's encoding.

`candidate_plans` gives the distinct plans in a fixed order (greedy covers, then k = 1, 2, ...
with the first k-means init, then with the next) up to a limit; the seed drives only the k-means
inits and the slide's candidate directions (one generator per site set), so the plans are the
same in both start modes and a limit takes a prefix of the full list. Needs the UAV problem
(`planner_core.model.problem.Problem`: model, obstacles, seeder, encode).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numba import njit

from planner_core.model.formulas import ground_reach, numpy_sum
from planner_core.model.geometry import overlap_lengths, points_inside
from planner_core.model.routing import open_path
from planner_core.model.routing.graph import CLEAR, weight_bounds
from planner_core.search.polish import polish_hover_times
from planner_core.search.refine import covers, repair_points
from planner_core.streams import stream_rng

__all__ = [
    "BANDWIDTH_USE",
    "FRACTIONS",
    "KMEANS_INITS",
    "LegTimes",
    "InjectedPopulation",
    "SEEDER_PLANS",
    "seeder_plans",
    "build_plans",
    "candidate_plans",
    "candidate_sites",
    "greedy_cover",
    "order_sites",
    "reach",
    "site_sets",
    "timed_plan",
]

#: reach fractions of the greedy covers: a site covers a sensor when hovering this share of
#: T_max there collects its data (0.9: the seeder's reach)
FRACTIONS = (0.9, 0.6, 0.35, 0.2)
#: k-means inits per k of the sweep
KMEANS_INITS = 2
#: summed link rate a candidate site may have, as a share of the bandwidth (C3; the seeder's)
BANDWIDTH_USE = 0.98
#: seeder plans scored beside the constructive ones when the best starts are descended
SEEDER_PLANS = 20
#: flight time (s) charged per metre inside obstacles for a leg the graph cannot route around
_UNROUTABLE = 1e6

#: a visiting order: (problem, sites (m, 2), leg times) -> permutation (m,)
Order = Callable[[Any, np.ndarray, "LegTimes"], np.ndarray]


def reach(problem: Any, frac: float) -> np.ndarray:
    """Each sensor's service reach (Sec. 3's link rate read backwards;
    `planner_core.model.formulas.ground_reach`).

    Args:
        problem: the UAV `Problem` (its model's required data, T_max and link).
        frac: the share of T_max hovered, > 0.

    Returns:
        (J,) ground distance (m) within which hovering frac x T_max collects each sensor's
        data (its Q_j floored at 1e-9 Mbit).
    """
    mp = problem.model
    need = np.maximum(np.asarray(mp.required, dtype=float), 1e-9) / (frac * mp.t_max)
    return ground_reach(need, mp.altitude, mp.peak_rate, mp.decay)


def _pushed(problem: Any, pts: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Points (n, 2) clipped to the area, those inside an obstacle moved out of it (once)."""
    seeder = problem.seeder
    C = np.clip(np.asarray(pts, dtype=float).reshape(-1, 2), 0.0, seeder.size)
    for m in np.flatnonzero(points_inside(C, problem.obstacles)):
        C[m] = seeder.push_one(C[m], rng)
    return C


def candidate_sites(problem: Any, extra: np.ndarray | None = None) -> np.ndarray:
    """Candidate hover sites (n, 2), metres: sensor positions, midpoints of sensor pairs, and
    `extra` (e.g. k-means centres), clipped to the area, pushed out of obstacles, deduplicated,
    those over `BANDWIDTH_USE` of the bandwidth dropped (but each sensor's own position kept
    when no other candidate covers it at frac = 0.9). Module docstring, step 2. A sensor no
    C3-respecting site covers first gets `ring_sites` around it.

    Args:
        problem: the UAV `Problem` (model, obstacles, seeder).
        extra: more points (k, 2) m, or None.

    Returns:
        (n, 2) sites, m.
    """
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
    rng = np.random.default_rng(0)  # only for a point exactly at a circle's centre
    C = np.clip(_pushed(problem, np.vstack(parts), rng), 0.0, seeder.size)
    C = np.unique(np.round(C, 6), axis=0)
    keep = C[_within_bandwidth(problem, C)]
    covered = covers(problem, keep, 0.9).any(axis=0) if len(keep) else np.zeros(len(S), bool)
    if not covered.all():
        # dense fields: every site near the sensor hears too many others (C3); try rings
        # around it out to its reach, where fewer of its neighbours are heard
        ring = _pushed(problem, ring_sites(S[~covered], lim[~covered]), rng)
        ring = np.clip(ring, 0.0, seeder.size)
        keep = np.vstack([keep, ring[_within_bandwidth(problem, ring)]])
        covered = covers(problem, keep, 0.9).any(axis=0)
    if not covered.all():
        keep = np.vstack([keep, _pushed(problem, S[~covered], rng)])
    return keep


def _within_bandwidth(problem: Any, pts: np.ndarray) -> np.ndarray:
    """(n,) bool: the points' summed link rate stays within `BANDWIDTH_USE` of R_lambda (C3)."""
    mp = problem.model
    if not len(pts):
        return np.zeros(0, dtype=bool)
    return mp.rates(pts).sum(axis=1) <= BANDWIDTH_USE * mp.bandwidth


#: ring sites around a sensor no C3-respecting candidate covers: these shares of its reach ...
RING_RADII = (0.55, 0.7, 0.85, 0.97)
#: ... in this many directions
RING_DIRECTIONS = 16


def ring_sites(sensors: np.ndarray, lim: np.ndarray) -> np.ndarray:
    """Candidate sites (len(sensors) x |RING_RADII| x RING_DIRECTIONS, 2) m on rings around
    each sensor (k, 2) at `RING_RADII` of its reach lim (k,) m: in a dense field the points
    that keep C3 (the summed rate of every sensor heard within R_lambda) lie towards the
    field's edge, still within the sensor's reach (issue 31).

    Args:
        sensors: the sensors' positions (k, 2), m.
        lim: their reach (k,), m (`reach`).

    Returns:
        (k x |RING_RADII| x RING_DIRECTIONS, 2) points, m, sensor by sensor, radius by
        radius; not clipped to the area nor pushed out of obstacles.
    """
    ang = 2.0 * np.pi * np.arange(RING_DIRECTIONS) / RING_DIRECTIONS
    unit = np.column_stack([np.cos(ang), np.sin(ang)])  # (D, 2)
    radii = np.asarray(lim, dtype=float)[:, None] * np.asarray(RING_RADII)[None, :]  # (k, R)
    pts = (np.asarray(sensors, dtype=float)[:, None, None, :]
           + radii[:, :, None, None] * unit[None, None, :, :])
    return pts.reshape(-1, 2)


class CoverTable:
    """What every greedy cover of one candidate site set (n, 2) reads, computed once: the
    sites' link rates R (n, J) and, per reach fraction, which sites cover which sensors (with
    the T_max fallback of `greedy_cover`), also as a sparse row list (`covered`). `site_sets`
    builds one for all its covers (n grows with the k-means sweep: ~I_max^2 sites). Memory: R,
    n J floats, and one n J bool array per fraction used (plus its non-zeros)."""

    def __init__(self, problem: Any, sites: np.ndarray) -> None:
        self.problem = problem
        self.sites = np.asarray(sites, dtype=float).reshape(-1, 2)
        self.need = np.asarray(problem.model.required, dtype=float)
        self.R = problem.model.rates(self.sites)
        self._cov: dict[float, np.ndarray] = {}
        self._csr: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def cover(self, frac: float) -> np.ndarray:
        """Which sites cover which sensors (cached per fraction).

        Args:
            frac: the reach fraction.

        Returns:
            (n, J) bool: site i covers sensor j at reach fraction frac; a sensor no site
            covers at frac counts as covered by the sites that collect its data within T_max.
        """
        if frac not in self._cov:
            cov = covers(self.problem, self.sites, frac, self.R)
            full = covers(self.problem, self.sites, 1.0, self.R)
            self._cov[frac] = np.where(cov.any(axis=0), cov, full)
        return self._cov[frac]

    def covered(self, frac: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`cover(frac)` as rows of non-zeros (cached per fraction).

        Args:
            frac: the reach fraction.

        Returns:
            (indptr (n + 1,) int64, sensors (nnz,) int64 ascending per site, hover (nnz,) s,
            the hover time each site needs for each sensor it covers, Q_j / R_ij, inf where
            R_ij = 0).
        """
        if frac not in self._csr:
            rows, cols = np.nonzero(self.cover(frac))
            indptr = np.searchsorted(rows, np.arange(len(self.sites) + 1)).astype(np.int64)
            R = self.R[rows, cols]
            need = self.need[cols]
            hov = np.where(R > 0, need / np.maximum(R, 1e-12), np.inf)
            self._csr[frac] = (indptr, cols.astype(np.int64), np.ascontiguousarray(hov))
        return self._csr[frac]


def greedy_cover(
    problem: Any, sites: np.ndarray, frac: float, chosen: np.ndarray | None = None,
    table: CoverTable | None = None,
) -> np.ndarray:
    """Indices into `sites` (n, 2) of a greedy set cover of the sensors at reach fraction
    `frac` (module docstring, step 3), after the sites `chosen` (points (m, 2), already in the
    plan; they are not returned). A sensor no site covers at `frac` counts as covered by the
    sites that collect its data within T_max; one no site serves even then is left uncovered.
    `table`: the sites' `CoverTable` when the caller keeps one (else built here).

    Lazy greedy (Minoux 1978, compiled: `_lazy_greedy`): a site's gain (sensors it covers
    still uncovered) only falls as the cover grows, so each pick recounts only the sites whose
    last count ties the largest, until one of them still has it; the ties of the step-3 rule
    (the most sensors, then the shortest hover, then the lowest index) are then all among
    them. Counts and hover maxima read each site's covered sensors (`CoverTable.covered`, a
    few per site on a large map), not the J columns. The same picks as recounting every site
    at every pick (`greedy_cover_reference`), at O(nnz) for the first count and O(n + the
    recounted sites' sensors) per pick instead of O(n J) per pick.

    Args:
        problem: the UAV `Problem`.
        sites: candidate sites (n, 2), m (unread when `table` is given).
        frac: the reach fraction.
        chosen: points (m, 2) m already in the plan, or None.
        table: the sites' `CoverTable`, or None.

    Returns:
        (p,) int64 site indices, in pick order.
    """
    table = table if table is not None else CoverTable(problem, sites)
    cov = table.cover(frac)
    left = cov.any(axis=0)
    if chosen is not None and len(chosen):
        left &= ~covers(problem, np.asarray(chosen, dtype=float), frac).any(axis=0)
    indptr, cols, hov = table.covered(frac)
    return _lazy_greedy(indptr, cols, hov, np.ascontiguousarray(left))


@njit(cache=True, nogil=True)
def _lazy_greedy(indptr, cols, hov, left):  # pragma: no cover - compiled
    """The picks of `greedy_cover` (site indices, in order) over the covered sensors of each
    site (indptr, cols, hov: `CoverTable.covered`); left (J,) bool, the sensors to cover
    (modified). Ties: the most sensors still uncovered, then the least of the largest hover
    time over them, then the lowest index (strict comparisons, ascending rows: numpy's
    flatnonzero and argmin)."""
    n = indptr.shape[0] - 1
    gain = np.zeros(n, dtype=np.int64)
    for i in range(n):
        c = 0
        for q in range(indptr[i], indptr[i + 1]):
            c += left[cols[q]]
        gain[i] = c
    n_left = 0
    for j in range(left.shape[0]):
        n_left += left[j]
    out = np.empty(n, dtype=np.int64)
    n_out = 0
    rows = np.empty(n, dtype=np.int64)
    true = np.empty(n, dtype=np.int64)
    while n_left > 0:
        top = 0
        for i in range(n):
            top = max(top, gain[i])
        nr = 0
        while top > 0:
            nr = 0
            hit = False
            for i in range(n):
                if gain[i] == top:
                    c = 0
                    for q in range(indptr[i], indptr[i + 1]):
                        c += left[cols[q]]
                    gain[i] = c
                    rows[nr] = i
                    true[nr] = c
                    nr += 1
                    hit |= c == top
            if hit:
                break
            top = 0
            for i in range(n):
                top = max(top, gain[i])
        if top == 0:
            break
        best = -1
        best_t = np.inf
        for r in range(nr):
            if true[r] != top:
                continue
            i = rows[r]
            t = 0.0
            for q in range(indptr[i], indptr[i + 1]):
                if left[cols[q]]:
                    t = max(t, hov[q])
            if best < 0 or t < best_t:
                best, best_t = i, t
        out[n_out] = best
        n_out += 1
        for q in range(indptr[best], indptr[best + 1]):
            if left[cols[q]]:
                left[cols[q]] = False
                n_left -= 1
    return out[:n_out].copy()


def greedy_cover_reference(
    problem: Any, sites: np.ndarray, frac: float, chosen: np.ndarray | None = None
) -> np.ndarray:
    """Indices into `sites` (n, 2) of a greedy set cover of the sensors at reach fraction
    `frac` (module docstring, step 3), after the sites `chosen` (points (m, 2), already in the
    plan; they are not returned). A sensor no site covers at `frac` counts as covered by the
    sites that collect its data within T_max; one no site serves even then is left uncovered.
    Every site recounted at every pick: what `greedy_cover` computes lazily (tests hold the
    two equal).

    Args:
        problem: the UAV `Problem`.
        sites: candidate sites (n, 2), m.
        frac: the reach fraction.
        chosen: points (m, 2) m already in the plan, or None.

    Returns:
        (p,) int64 site indices, in pick order.
    """
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
    """k-means centres (<= k, 2) of the sensors S (J, 2), k-means++ init from rng (empty
    clusters dropped): `_kmeans_reference` to the bit, rng left in the same state (tests).

    scipy's k-means++ init (`scipy.cluster.vq._kpp`) recomputes every chosen centre's
    distances to the J sensors for each new centre, O(k^2 J) per call; the sweep asks
    k = 1 .. I_max twice, ~I_max^3 J in all (I_max ~ J / 2 on the large maps: ~0.25 s of
    L02's plan). `_kpp_indices` keeps each sensor's least squared distance across picks,
    O(k J) per call, with the same draws (one integer, then k - 1 uniforms) and the same
    arithmetic (`cdist`'s squared distances, numpy's pairwise sum (`formulas.numpy_sum`), a
    sequential cumulative sum, a left search); the k-means iterations are scipy's
    `kmeans2(..., minit="matrix")` from that init, compiled (`_lloyd`: its 10 rounds of
    nearest centre by squared distance, first on ties, and member means summed in sensor
    order, an empty cluster kept where it was). Compiled because the improving rounds'
    rebuilds call it once a draw, and scipy's wrappers cost ~0.4 ms a call."""
    S = np.ascontiguousarray(S, dtype=np.float64)
    if S.ndim != 2 or S.shape[1] != 2 or not 1 <= k <= len(S):
        return _kmeans_reference(S, k, rng)
    first = int(rng.integers(len(S), high=None, size=None, dtype="int64", endpoint=False))
    u = rng.uniform(size=k - 1)
    idx = _kpp_indices(S, first, u)
    if (idx < 0).any():  # a draw past the last cumulative share: scipy raises there
        raise IndexError("k-means++ draw past the last sensor")
    C, label = _lloyd(S, S[idx], KMEANS_ROUNDS)
    return C[np.unique(label)]


#: rounds of `_lloyd` (scipy's `kmeans2` default, `iter=10`)
KMEANS_ROUNDS = 10


@njit(cache=True, nogil=True)
def _lloyd(S, C0, rounds):  # pragma: no cover - compiled
    """scipy's `kmeans2(S, C0, iter=rounds, minit="matrix")` on points S (n, 2) from centres
    C0 (k, 2): each round every point to its nearest centre (squared distance summed over the
    two axes in order, the first centre on a tie, scipy's `vq` for fewer than 5 features),
    then each centre the mean of its points (summed in point order, then divided by their
    count; an empty centre stays where it was). Returns (centres (k, 2), labels (n,)).
    O(rounds x n x k)."""
    n, k = S.shape[0], C0.shape[0]
    C = C0.copy()
    label = np.zeros(n, dtype=np.int32)
    for _ in range(rounds):
        for i in range(n):
            best = np.inf
            for j in range(k):
                d = 0.0
                for a in range(2):
                    diff = S[i, a] - C[j, a]
                    d += diff * diff
                if d < best:
                    best = d
                    label[i] = j
        new = np.zeros((k, 2))
        count = np.zeros(k, dtype=np.int64)
        for i in range(n):
            new[label[i], 0] += S[i, 0]
            new[label[i], 1] += S[i, 1]
            count[label[i]] += 1
        for j in range(k):
            if count[j] > 0:
                new[j, 0] /= count[j]
                new[j, 1] /= count[j]
            else:
                new[j, 0], new[j, 1] = C[j, 0], C[j, 1]
        C = new
    return C, label


def _kmeans_reference(S: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """k-means centres (<= k, 2) of the sensors, scipy's k-means++ init from rng (empty
    clusters dropped): the slow reference of `_kmeans`."""
    from scipy.cluster.vq import kmeans2

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scipy warns when a cluster ends empty
        C, label = kmeans2(S, k, minit="++", rng=rng)
    return C[np.unique(label)]


@njit(cache=True, nogil=True, error_model="numpy")
def _kpp_indices(data, first, u):  # pragma: no cover - compiled
    """Rows of data (J, 2) that scipy's k-means++ picks (k = len(u) + 1): first, then for
    each uniform u[i] the first row whose cumulative share of the least squared distance to
    the centres so far reaches u[i]; -1 where none does (scipy raises there)."""
    J = data.shape[0]
    k = u.shape[0] + 1
    out = np.empty(k, dtype=np.int64)
    out[0] = first
    D2 = np.full(J, np.inf)
    for i in range(1, k):
        c = out[i - 1]
        cx, cy = data[c, 0], data[c, 1]
        for j in range(J):
            dx = cx - data[j, 0]
            dy = cy - data[j, 1]
            s = dx * dx + dy * dy
            if s < D2[j]:
                D2[j] = s
        tot = numpy_sum(D2, 0, J)
        r = u[i - 1]
        cum = 0.0
        pick = -1
        for j in range(J):
            cum += D2[j] / tot
            if not cum < r:  # numpy's left search (NaN shares: the first row)
                pick = j
                break
        out[i] = pick
        if pick < 0:
            break
    return out


def site_sets(problem: Any, seed: int) -> Iterator[tuple[str, np.ndarray]]:
    """The candidate site sets in scoring order, each as (label, sites (m, 2)): one greedy
    cover per reach fraction, then the k-means sweep, k = 1 .. min(I_max, J) for the first
    init, then again for the next (module docstring, steps 2-4).

    Args:
        problem: the UAV `Problem`.
        seed: the run's seed (the k-means inits' stream).

    Yields:
        (label, sites (m, 2) m): "cover <frac>", then "k-means k=<k> init <r>" (the
        in-bandwidth pushed-out centres, then the greedy sites covering the rest at 0.9);
        one ("no sensors", (0, 2)) on a map without sensors.
    """
    mp = problem.model
    S = np.asarray(mp.sensors, dtype=float)
    J = len(S)
    if J == 0:
        yield "no sensors", np.zeros((0, 2))
        return
    rng = stream_rng(seed, "kmeans")
    ks = list(range(1, min(int(mp.n_points), J) + 1))
    centres = {(k, r): _kmeans(S, k, rng) for k in ks for r in range(KMEANS_INITS)}
    sites = candidate_sites(problem, np.vstack(list(centres.values())))
    table = CoverTable(problem, sites)
    for frac in FRACTIONS:
        yield f"cover {frac:g}", sites[greedy_cover(problem, sites, frac, table=table)]
    pushed_rng = np.random.default_rng(0)
    # one init of every k before the next init: a limited prefix still spans every k
    for r in range(KMEANS_INITS):
        for k in ks:
            C = _pushed(problem, centres[k, r], pushed_rng)
            C = C[_within_bandwidth(problem, C)]  # a centre in a dense field breaks C3
            more = sites[greedy_cover(problem, sites, 0.9, chosen=C, table=table)]
            yield f"k-means k={k} init {r}", np.vstack([C, more])


class LegTimes:
    """Eq. 1 flight time (s) of the fastest obstacle-free way between two points of one map:
    the straight leg when it is clear, else start -> visibility-graph corners -> end, each hop a
    leg from rest to rest (a corner is a hover point of the plan). A pair the graph cannot join
    keeps its straight leg plus `_UNROUTABLE` s per metre inside obstacles.

    Built once per problem and reused for every site set: each point's times to the corners,
    straight and over the graph (a multi-source Dijkstra with Eq. 1 hop times), are cached by
    its coordinates, so a point shared by several site sets is connected to the graph once.
    """

    def __init__(self, problem: Any) -> None:
        self.problem = problem
        self.graph = problem.seeder.graph
        #: Eq. 1 time (s) of each graph edge as a hop from rest to rest (aligned with indices)
        self.hop_times = problem.model.flight_time(self.graph.weights)
        self._bounds = weight_bounds(self.hop_times)  # for the Dijkstra's bucket queue
        self._first: dict[bytes, np.ndarray] = {}  # point -> its times to the corners it sees
        self._far: dict[bytes, np.ndarray] = {}  # point -> its times to every corner

    def _to_corners(self, pts: np.ndarray, far: bool = True
                    ) -> tuple[np.ndarray, np.ndarray | None]:
        """For points pts (P, 2): (first, far), each (P, N) flight times (s): `first` to each
        graph corner the point sees tangentially (one straight hop; inf elsewhere), `far` to
        each corner over the graph via those (inf where it sees none; a Dijkstra over the
        graph per point, so only when asked: None otherwise)."""
        keys = [p.tobytes() for p in pts]
        new = [i for i, k in enumerate(keys) if k not in self._first]
        if new:
            seen = self.problem.seeder.connect(pts[new])  # (n, N) metres, inf where unseen
            for i, row in zip(new, self.problem.model.flight_time(seen), strict=True):
                self._first[keys[i]] = row
        first = np.array([self._first[k] for k in keys]).reshape(len(pts), self.graph.n)
        if not far:
            return first, None
        for k, row in zip(keys, first, strict=True):
            if k not in self._far:
                self._far[k] = self.graph.spread(row, self.hop_times, self._bounds)
        return first, np.array([self._far[k] for k in keys]).reshape(len(pts), self.graph.n)

    def matrix(self, nodes: np.ndarray) -> np.ndarray:
        """Leg times between points.

        Args:
            nodes: the points (P, 2), m.

        Returns:
            (P, P) symmetric leg times (s), zero diagonal (class docstring: a blocked pair
            over the graph, else `_UNROUTABLE` s per metre inside obstacles on top).
        """
        nodes = np.asarray(nodes, dtype=float).reshape(-1, 2)
        mp = self.problem.model
        P = len(nodes)
        ia, ib = np.triu_indices(P, 1)
        cost = mp.flight_time(np.hypot(*(nodes[ia] - nodes[ib]).T))
        inside = overlap_lengths(nodes[ia], nodes[ib], self.problem.obstacles)
        blocked = np.flatnonzero(inside > CLEAR)
        if len(blocked):
            via = np.full(len(blocked), np.inf)
            if self.graph.n:
                # a -> over the graph -> b: the graph's times from a (one Dijkstra per a end),
                # the straight hops into b
                src = np.unique(ia[blocked])
                dst = np.unique(ib[blocked])
                first = np.full((P, self.graph.n), np.inf)
                far = np.full((P, self.graph.n), np.inf)
                first[dst] = self._to_corners(nodes[dst], far=False)[0]
                far[src] = self._to_corners(nodes[src])[1]
                # a -> (over the graph) -> corner v -> b, where b sees v
                via = via_corners(far, first, ia[blocked], ib[blocked])
            cost[blocked] = np.where(np.isfinite(via), via,
                                     cost[blocked] + _UNROUTABLE * inside[blocked])
        W = np.zeros((P, P))
        W[ia, ib] = W[ib, ia] = cost
        return W


def via_corners(far: np.ndarray, first: np.ndarray, ia: np.ndarray, ib: np.ndarray
                ) -> np.ndarray:
    """(K,) s: for each pair k, min over graph corners v of far[ia[k], v] + first[ib[k], v]
    (point a over the graph to v, then straight to point b, which sees v), inf where none;
    far and first (P, N) s. A point sees few of the N corners tangentially, so the minimum
    runs over b's finite entries only: O(K x corners seen) instead of the (K, N) array of
    `(far[ia] + first[ib]).min(axis=1)`, the same value (tests).

    Args:
        far: times (P, N) s from each point to each corner over the graph.
        first: times (P, N) s from each point straight to each corner it sees (inf elsewhere).
        ia: the pairs' first points (K,), row indices.
        ib: the pairs' second points (K,), row indices.

    Returns:
        (K,) s, inf where no corner joins the pair.
    """
    ia = np.asarray(ia, dtype=np.int64)
    ib = np.asarray(ib, dtype=np.int64)
    if not len(ia):
        return np.zeros(0)
    rows, cols = np.nonzero(np.isfinite(first))  # row-major: each point's seen corners
    indptr = np.searchsorted(rows, np.arange(first.shape[0] + 1))
    return _via_corners(np.ascontiguousarray(far), np.ascontiguousarray(first), ia, ib,
                        indptr, cols.astype(np.int64))


@njit(cache=True, nogil=True)
def _via_corners(far, first, ia, ib, indptr, cols):  # pragma: no cover - compiled
    out = np.empty(ia.shape[0])
    for k in range(ia.shape[0]):
        a, b = ia[k], ib[k]
        best = np.inf
        for t in range(indptr[b], indptr[b + 1]):
            v = cols[t]
            s = far[a, v] + first[b, v]
            if s < best:
                best = s
        out[k] = best
    return out


def order_sites(problem: Any, sites: np.ndarray, legs: LegTimes | None = None) -> np.ndarray:
    """Visiting order (m,) of the sites (m, 2) on the open path start -> sites -> end: our own
    open path (`planner_core.model.routing.open_path`: nearest neighbour and cheapest insertion,
    2-opt,
    Or-opt) on the obstacle-aware Eq. 1 leg times of `legs` (module docstring, step 5).

    Args:
        problem: the UAV `Problem` (start, end).
        sites: the sites (m, 2), m.
        legs: the map's `LegTimes` (None: built here).

    Returns:
        (m,) int64 permutation of the sites (identity for m <= 1).
    """
    sites = np.asarray(sites, dtype=float).reshape(-1, 2)
    if len(sites) <= 1:
        return np.arange(len(sites))
    legs = legs if legs is not None else LegTimes(problem)
    W = legs.matrix(np.vstack([problem.start, sites, problem.end]))
    return np.asarray(open_path(W)[1:-1] - 1, dtype=np.int64)


def timed_plan(problem: Any, pts: np.ndarray) -> np.ndarray:
    """The decision vector (d,) of hover points pts (m, 2) with LP hover times
    (`planner_core.search.polish`); when every slot must stay active (tau <= 0), filled to I_max
    with
    collinear points first.

    Args:
        problem: the UAV `Problem`.
        pts: hover points (m, 2), m, in visiting order.

    Returns:
        (d,) decision vector (`Problem.encode`): the LP's kept points and times; where every
        slot must stay, all points, those the LP dropped with time 0.
    """
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


def build_plans(
    problem: Any,
    sites: np.ndarray,
    rng: np.random.Generator,
    *,
    order: Order | None = None,
    legs: LegTimes | None = None,
) -> list[np.ndarray]:
    """Decision vectors (d,) from a site set (m, 2): visiting order (`order`, default
    `order_sites`), slide, visibility-graph detours and I_max (`refine.repair_points`, one or
    two hover-point sets), LP hover times (module docstring, steps 5-7); one vector per set.
    `rng` drives the slide's candidate directions only.

    Args:
        problem: the UAV `Problem`.
        sites: the site set (m, 2), m.
        rng: the slide's generator.
        order: the visiting order (None: `order_sites`).
        legs: the map's `LegTimes` (None: built here).

    Returns:
        One (d,) decision vector per hover-point set (one or two).
    """
    sites = np.asarray(sites, dtype=float).reshape(-1, 2)
    legs = legs if legs is not None else LegTimes(problem)
    C = sites[(order or order_sites)(problem, sites, legs)]
    if len(C):
        # each sensor slides with the site that serves it fastest (a covering one if any)
        R = problem.model.rates(C)
        owner = np.argmax(np.where(covers(problem, C, 0.9), R + 1e6, R), axis=0)
        C = problem.seeder.slide(C, owner, reach(problem, 0.9), rng)
    return [timed_plan(problem, pts) for pts in repair_points(problem, C)]


def candidate_plans(
    problem: Any, seed: int, limit: int | None = None, *, order: Order | None = None,
    stop: Callable[[], bool] | None = None, progress: Callable[[str], None] | None = None,
) -> tuple[np.ndarray, list[str]]:
    """The pipeline's distinct plans in scoring order, at most `limit` (None: all): (X (m, d)
    decision vectors, labels (m,) naming the site set each came from). Deterministic for a
    seed; nothing is evaluated. `stop`: asked after each site set once a plan exists; True
    ends the list there (the pipeline's time limit). `progress`: told after each site set what
    is built so far ("12/64 plans").

    Args:
        problem: the UAV `Problem`.
        seed: the run's seed (k-means inits, slides).
        limit: the most plans (None: all; <= 0: none).
        order: the visiting order (None: `order_sites`).
        stop: the early stop, or None.
        progress: the progress callback, or None.

    Returns:
        (X (m, d), labels): distinct decision vectors and their site sets' labels.
    """
    d = int(np.asarray(problem.lower).shape[0])
    rows: list[np.ndarray] = []
    labels: list[str] = []
    if limit is not None and limit <= 0:
        return np.zeros((0, d)), labels
    legs = LegTimes(problem)
    seen: set[bytes] = set()
    for i, (label, sites) in enumerate(site_sets(problem, int(seed))):
        # each set's own slide directions: a set's plans do not depend on those built before
        rng = stream_rng(seed, "site-slide", i)
        for x in build_plans(problem, sites, rng, order=order, legs=legs):
            key = x.tobytes()
            if key in seen:
                continue
            seen.add(key)
            rows.append(x)
            labels.append(label)
            if limit is not None and len(rows) >= limit:
                return np.asarray(rows, dtype=float).reshape(-1, d), labels
        if progress is not None:
            progress(f"{len(rows)}/{limit if limit is not None else '-'} plans")
        if rows and stop is not None and stop():
            break
    return np.asarray(rows, dtype=float).reshape(-1, d), labels


def seeder_plans(problem: Any, seed: int, k: int,
                 progress: Callable[[str], None] | None = None) -> np.ndarray:
    """k (k, d) plans of the problem's seeder (`Seeder.solution`: clustered sensors, a short
    order, visibility-graph detours; what the DE's seeded start population holds), from their
    own generator of `seed`, so the same in both start modes. `progress`: told after each
    plan ("3/20 seeder plans").

    Args:
        problem: the UAV `Problem` (its seeder).
        seed: the run's seed.
        k: how many (< 0 counts as 0).
        progress: the progress callback, or None.

    Returns:
        (k, d) decision vectors.
    """
    rng = stream_rng(seed, "seeder-plans")
    d = int(np.asarray(problem.lower).shape[0])
    rows = []
    for i in range(max(k, 0)):
        rows.append(problem.seeder.solution(rng))
        if progress is not None:
            progress(f"{i + 1}/{k} seeder plans")
    return np.asarray(rows, dtype=float).reshape(-1, d)


class InjectedPopulation:
    """A problem whose `initial_population(rng, n)` is its own (uniform in the box when it has
    none: what the DE itself would draw) with the last rows replaced by the plans `starts`
    (k, d), problem space (the pipeline's injected constructive plans); every other attribute
    is the wrapped problem's (also `problem`).

    `seeded` (s, d): sensor-aware plans already built (the pool's seeder plans) that stand in
    for the wrapped problem's own hook when it has one: the population is then uniform with its
    first rows these plans, so the seeder, ~0.3 s a plan at 160 sensors, is not run again for
    the DE. When `starts` fill the population nothing else is drawn (the repair stage's
    restart from a whole population)."""

    def __init__(self, problem: Any, starts: np.ndarray, seeded: np.ndarray | None = None
                 ) -> None:
        self.problem = problem
        self.starts = np.asarray(starts, dtype=float)
        self.seeded = None if seeded is None else np.asarray(seeded, dtype=float)

    def __getattr__(self, name: str) -> Any:
        if name in ("problem", "starts", "seeded"):  # safe before __init__ ran
            raise AttributeError(name)
        return getattr(self.problem, name)

    def initial_population(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """(n, d) problem-space starts: the wrapped problem's (or uniform, with the `seeded`
        rows first), last rows replaced by `starts`.

        Args:
            rng: the DE run's generator (the hook's or the uniform draw).
            n: the population size.

        Returns:
            (n, d) starts; the first n of `starts` when they fill it.
        """
        k = min(len(self.starts), n)
        if k == n:
            return np.array(self.starts[:n], dtype=float)
        hook = getattr(self.problem, "initial_population", None)
        own = self.seeded if hook is not None and self.seeded is not None else None
        if hook is not None and (own is None or not len(own)):
            X = np.array(hook(rng, n), dtype=float)
        else:
            lo, hi = np.asarray(self.lower, dtype=float), np.asarray(self.upper, dtype=float)
            X = lo + rng.random((n, lo.shape[0])) * (hi - lo)
            if own is not None:
                s = min(len(own), n - k)
                X[:s] = own[:s]
        if k:
            X[n - k :] = self.starts[:k]
        return X
