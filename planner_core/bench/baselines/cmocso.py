"""CMOCSO: competitive and cooperative swarm optimiser for constrained multi-objective problems.

Reference: F. Ming, W. Gong, D. Li, L. Wang and L. Gao, "A Competitive and Cooperative Swarm
Optimizer for Constrained Multiobjective Optimization Problems", IEEE Transactions on
Evolutionary Computation 27(5), 1313-1326, 2023, doi:10.1109/TEVC.2022.3199775. PlatEMO
publishes the authors' MATLAB version (BIMK/PlatEMO, Algorithms/Multi-objective
optimization/CMOCSO); this is our own numpy implementation of the method as described there
(no code copied), vectorised over the swarm.

The method keeps two swarms of N particles and one archive:

* **Competitive swarm** (the constrained one): selected each generation by an epsilon-constrained
  SPEA2 fitness (violations below epsilon count as 0; then a smaller violation dominates, equal
  violations compare by Pareto dominance; raw fitness R(i) = sum of the strengths of i's
  dominators, density D(i) = 1 / (sigma_k + 2) with sigma_k the distance in objective space to
  the k-th nearest neighbour, k = floor(sqrt(n))). It is paired at random; in each pair the one
  with the lower fitness wins, the loser learns from the winner (competitive swarm optimiser,
  Cheng & Jin 2015): v' = r1 v + y r2 (x_w - x_l), x' = x_l + v' + (-1)^n r1 (v' - v) (r1, r2
  one uniform draw per particle, n in {1, 2} one draw per generation); the winners go through
  too. Both then get polynomial mutation (rate 1/d, index 20). The learning factor y starts at
  10 and follows y = M^2 (g/G - 1)^2 + 1 (M objectives, g generations spent of G).
* **Cooperative swarm** (the unconstrained one): selected by the same fitness with epsilon = inf
  (constraints ignored); N parents by binary tournaments on that fitness, SBX (probability 1,
  index 20, each variable swapped with probability 1/2) and polynomial mutation (probability 1,
  index 20) give N offspring.
* Every offspring (both swarms') is offered to both swarms: the next swarm is the non-dominated
  set of old + new under its fitness, filled by fitness if smaller than N, cut by SPEA2's
  nearest-neighbour truncation if larger.
* **Epsilon** starts at the initial population's largest violation; each generation
  eps0 = the largest violation seen in the competitive swarm, rf = its feasible share
  (violation <= 1e-6): eps <- 0.95 eps while rf < alpha = 0.95, else eps0 (1 - g/Tc)^cp with
  cp = 2; 0 after Tc = 0.9 ceil(maxFE / N) (g counted in evaluations / N, as the method does).

Applied to the UAV problem (single objective, one constraint): **M = 1, objective f, total
violation phi** (the method's constraint handling, no penalty: the paper lists CMOCSO as the
tailored constrained optimiser, and applies the penalty f + 10 phi only to CMA-ES, L-SRTDE and
the MetaBBO peers). With M = 1 the dominance above is a lexicographic order on (eps-violation,
f), so the competitive swarm is ranked by the epsilon-relaxed Deb rule and the cooperative swarm
by f alone; y runs from 2 to 1. Stated adaptations: N = POPULATION (100, PlatEMO's default N);
each generation spends 2N evaluations (N/2 losers' and N/2 winners' moves, N cooperative
offspring) and the last one is cut to the budget left, so exactly `budget` evaluations are
spent; the result is the Deb-best of every evaluation (the benchmark's rule for every peer, the
method's own archive of feasible non-dominated points holds the same point when one is
feasible). Works in the unit box (x = lower + u (upper - lower)). With a problem that has an
``initial_population`` hook the first swarm comes from it (the seeded protocol), else uniform.

Cost per generation: O(N^2 M) for the fitness of the 2N + 2N merged candidates (pairwise
dominance and distances), on top of 2N problem evaluations (each grows with sensors and
obstacles as the problem's evaluation does); the truncation loop only runs when more than N
candidates are non-dominated (rare with M = 1: tied copies of the best).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planner_core.bench.baselines import OptimiseResult
from planner_core.bench.baselines.unit_start import unit_initial_population
from planner_core.defaults import POPULATION
from planner_core.pipeline.evaluator import as_evaluator

__all__ = ["optimise", "fitness", "select", "EPS_ALPHA", "EPS_TAU", "EPS_CP", "ETA"]

#: feasible share above which epsilon follows the schedule, shrink rate otherwise, exponent
EPS_ALPHA, EPS_TAU, EPS_CP = 0.95, 0.05, 2.0
#: share of the run after which epsilon is 0
EPS_TC = 0.9
#: distribution index of SBX and polynomial mutation
ETA = 20.0
#: learning factor of the first generation
Y0 = 10.0
FEASIBLE_TOL = 1e-6


def fitness(obj: np.ndarray, cv: np.ndarray, epsilon: float) -> np.ndarray:
    """Epsilon-constrained SPEA2 fitness of each candidate (lower is better; < 1: non-dominated).

    Args:
        obj: objectives, shape (n, M) (or (n,) for M = 1); minimised.
        cv: total constraint violation, shape (n,), >= 0.
        epsilon: violations below it count as 0 (inf: constraints ignored).

    Returns:
        (n,) array R + D: R(i) the summed strength (number dominated) of i's dominators,
        D(i) = 1 / (distance to the k-th nearest neighbour in objective space + 2),
        k = floor(sqrt(n)) (Ming et al. 2023 after Zitzler et al.'s SPEA2).
    """
    obj = _finite(np.asarray(obj, dtype=float).reshape(len(cv), -1))
    cv = np.asarray(cv, dtype=float)
    cv = np.zeros_like(cv) if math.isinf(epsilon) else np.where(cv < epsilon, 0.0, cv)
    n = obj.shape[0]
    less = np.any(obj[:, None, :] < obj[None, :, :], axis=2)
    more = np.any(obj[:, None, :] > obj[None, :, :], axis=2)
    same_cv = cv[:, None] == cv[None, :]
    dom = (cv[:, None] < cv[None, :]) | (same_cv & less & ~more)  # dom[i, j]: i dominates j
    strength = dom.sum(axis=1)
    raw = dom.T.astype(float) @ strength  # raw[j] = sum of strengths of j's dominators
    if n < 2:
        return raw + 0.5
    dist = _distances(obj)
    k = max(1, int(math.isqrt(n)))
    kth = np.sort(dist, axis=1)[:, min(k, n - 1) - 1]
    return raw + 1.0 / (kth + 2.0)


def _finite(obj: np.ndarray) -> np.ndarray:
    """Objectives with +inf (a failed evaluation) put just above the worst finite value."""
    ok = np.isfinite(obj)
    if ok.all():
        return obj
    top = obj[ok].max() if ok.any() else 0.0
    return np.where(ok, obj, top + 1.0 + abs(top))


def _distances(obj: np.ndarray) -> np.ndarray:
    diff = obj[:, None, :] - obj[None, :, :]
    dist = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
    np.fill_diagonal(dist, np.inf)
    return dist


def select(obj: np.ndarray, cv: np.ndarray, n: int, epsilon: float) -> np.ndarray:
    """Environmental selection of n candidates: indices of the next swarm (sorted).

    The non-dominated ones (fitness < 1); filled with the best by fitness if fewer than n,
    reduced by SPEA2's truncation (repeatedly drop the candidate whose sorted distances to the
    others are lexicographically smallest) if more.

    Args:
        obj: (m, M) or (m,) objectives; cv: (m,) violations; n: swarm size (<= m);
        epsilon: as in `fitness`.

    Returns:
        (n,) int array of indices into the candidates.
    """
    fit = fitness(obj, cv, epsilon)
    keep = fit < 1.0
    if keep.sum() < n:
        keep[:] = False
        keep[np.argsort(fit, kind="stable")[:n]] = True
    elif keep.sum() > n:
        idx = np.flatnonzero(keep)
        o = _finite(np.asarray(obj, dtype=float).reshape(len(cv), -1))[idx]
        if np.all(o == o[0]):  # all at one point (the case with M = 1): every row ties,
            keep[:] = False  # the stable order drops the first ones
            keep[idx[-n:]] = True
            return np.flatnonzero(keep)
        dist = _distances(o)
        alive = np.ones(idx.size, dtype=bool)
        for _ in range(idx.size - n):
            rows = np.flatnonzero(alive)
            d = np.sort(dist[np.ix_(rows, rows)], axis=1)
            worst = rows[np.lexsort(d.T[::-1])[0]]
            alive[worst] = False
        keep[:] = False
        keep[idx[alive]] = True
    return np.flatnonzero(keep)


def _polynomial_mutation(U: np.ndarray, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Deb's bounded polynomial mutation in the unit box (index ETA); U clipped first."""
    U = np.clip(U, 0.0, 1.0)
    site = rng.random(U.shape) < rate
    mu = rng.random(U.shape)
    p = 1.0 / (ETA + 1.0)
    low = site & (mu <= 0.5)
    high = site & (mu > 0.5)
    delta = np.zeros_like(U)
    a = 2.0 * mu + (1.0 - 2.0 * mu) * (1.0 - U) ** (ETA + 1.0)
    delta[low] = np.power(a[low], p) - 1.0
    b = 2.0 * (1.0 - mu) + 2.0 * (mu - 0.5) * U ** (ETA + 1.0)
    delta[high] = 1.0 - np.power(b[high], p)
    return np.clip(U + delta, 0.0, 1.0)


def _sbx(P1: np.ndarray, P2: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """SBX (probability 1, index ETA, each variable's pair swapped with probability 1/2)."""
    mu = rng.random(P1.shape)
    beta = np.where(mu <= 0.5, (2.0 * mu) ** (1.0 / (ETA + 1.0)),
                    (2.0 - 2.0 * mu) ** (-1.0 / (ETA + 1.0)))
    beta = beta * np.where(rng.random(P1.shape) < 0.5, -1.0, 1.0)
    beta[rng.random(P1.shape) < 0.5] = 1.0
    mid, half = (P1 + P2) / 2.0, (P1 - P2) / 2.0
    return np.vstack([mid + beta * half, mid - beta * half])


def _epsilon(eps: float, eps0: float, rf: float, g: float, tc: float) -> float:
    if g > tc:
        return 0.0
    if rf < EPS_ALPHA:
        return (1.0 - EPS_TAU) * eps
    return eps0 * (1.0 - g / tc) ** EPS_CP


def optimise(problem: Any, budget: int, seed: int, population: int = POPULATION) -> OptimiseResult:
    """CMOCSO on objective f with constraint phi for exactly `budget` evaluations; Deb-best result.

    Args:
        problem: `lower`, `upper` (d,) and `evaluate(X) -> (f, phi)` for X (n, d), problem
            space; optionally `initial_population(rng, n)` (seeded start).
        budget: evaluations, initial swarm included (>= population).
        seed: same seed, same bytes.
        population: N, the size of each swarm (even, >= 4).

    Returns:
        OptimiseResult: the Deb-best of every evaluation, `budget` evaluations, the trace, and
        the competitive swarm's feasible share at the end.

    Raises:
        ValueError: population odd or below 4, or budget below it.
    """
    n = int(population)
    if n < 4 or n % 2:
        raise ValueError(f"population: must be even and >= 4, got {population}")
    if budget < n:
        raise ValueError(f"budget {budget} is below CMOCSO's population {n}")
    budgeted = as_evaluator(problem, budget)
    lo, hi = budgeted.lower, budgeted.upper
    span = hi - lo
    d = lo.shape[0]
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0xC5005]))

    U = unit_initial_population(problem, rng, n, d)
    f, phi = budgeted.evaluate(lo + U * span)
    V = np.zeros_like(U)
    # competitive swarm (cU, cV, cf, cp), cooperative swarm (kU, kf, kp) and its fitness
    cv_max = float(phi.max()) if np.isfinite(phi.max()) else 0.0
    eps = cv_max
    sel = select(f, phi, n, eps)
    cU, cV, cf, cp = U[sel], V[sel], f[sel], phi[sel]
    sel = select(f, phi, n, np.inf)
    kU, kf, kp = U[sel], f[sel], phi[sel]
    kfit = fitness(f, phi, np.inf)[sel]
    tc = EPS_TC * math.ceil(budget / n)
    G = budget / n
    y = Y0
    while budgeted.remaining > 0:
        g = math.ceil(budgeted.count / n)
        finite = cp[np.isfinite(cp)]
        cv_max = max(cv_max, float(finite.max()) if finite.size else 0.0)
        rf = float(np.count_nonzero(cp <= FEASIBLE_TOL)) / cp.size
        eps = _epsilon(eps, cv_max, rf, g, tc)
        cfit = fitness(cf, cp, eps)
        # competitive: random pairs, the lower fitness wins (ties: the one drawn first)
        perm = rng.permutation(n)
        lose, win = perm[: n // 2], perm[n // 2:]
        swap = cfit[lose] <= cfit[win]
        lose, win = np.where(swap, win, lose), np.where(swap, lose, win)
        r1 = rng.random((n // 2, 1))
        r2 = rng.random((n // 2, 1))
        v_new = r1 * cV[lose] + r2 * (cU[win] - cU[lose]) * y
        sign = -1.0 if rng.integers(1, 3) == 1 else 1.0
        u_new = cU[lose] + v_new + r1 * (v_new - cV[lose]) * sign
        O1 = _polynomial_mutation(np.vstack([u_new, cU[win]]), 1.0 / d, rng)
        W1 = np.vstack([v_new, cV[win]])
        # cooperative: binary tournaments on its fitness, SBX + polynomial mutation
        a, b = rng.integers(0, n, n), rng.integers(0, n, n)
        pool = np.where(kfit[b] < kfit[a], b, a)
        O2 = _polynomial_mutation(_sbx(kU[pool[: n // 2]], kU[pool[n // 2:]], rng), 1.0 / d, rng)
        O = np.vstack([O1, O2])
        W = np.vstack([W1, np.zeros_like(O2)])  # cooperative offspring start at rest
        m = min(O.shape[0], budgeted.remaining)
        O, W = O[:m], W[:m]
        of, op = budgeted.evaluate(lo + O * span)
        # both swarms take the better of old + all offspring
        aU, aV = np.vstack([cU, O]), np.vstack([cV, W])
        af, ap = np.concatenate([cf, of]), np.concatenate([cp, op])
        sel = select(af, ap, n, eps)
        cU, cV, cf, cp = aU[sel], aV[sel], af[sel], ap[sel]
        bU = np.vstack([O, kU])
        bf, bp = np.concatenate([of, kf]), np.concatenate([op, kp])
        sel = select(bf, bp, n, np.inf)
        kfit = fitness(bf, bp, np.inf)[sel]
        kU, kf, kp = bU[sel], bf[sel], bp[sel]
        g = math.ceil(budgeted.count / n)
        y = 1.0 * (g / G - 1.0) ** 2 + 1.0  # M^2 (g/G - 1)^2 + 1 with M = 1
    x, bf_, bp_ = budgeted.best("deb")
    feas = float(np.count_nonzero(cp == 0.0)) / cp.size
    return OptimiseResult(x, bf_, bp_, budgeted.count, budgeted.trace("deb"), feas)
