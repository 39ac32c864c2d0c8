"""L-SRTDE: success-rate-based adaptive DE, winner of the CEC 2024 bound-constrained competition.

Reference: V. Stanovov and E. Semenkin, "Success Rate-based Adaptive Differential Evolution
L-SRTDE for CEC 2024 Competition", 2024 IEEE Congress on Evolutionary Computation (CEC),
Yokohama, pp. 1-8, doi:10.1109/CEC60901.2024.10611907.

Written from the paper's description (no code copied); the rules as implemented here:

* Scaling factor from the last generation's success rate SR (share of trials that replaced
  their target): F ~ N(0.4 + 0.25 tanh(5 SR), 0.02), clipped to (0, 1].
* Greediness from SR: the p-best share is 0.7 exp(-7 SR) (at least 2 individuals).
* Crossover rate from a success-history memory of H = 5 cells, started at 1.0: Cr ~ N(M_k,
  0.05) clipped to [0, 1]; each generation one cell takes the improvement-weighted Lehmer mean
  of the successful Cr values (as in SHADE).
* Mutation current-to-pbest/1 whose r1 is drawn with rank-based selective pressure
  (probability proportional to exp(-3 rank / NP), the authors' LSHADE-RSP device), binomial
  crossover, out-of-box components repaired to the midpoint between the parent and the bound.
* Linear population size reduction from NP_max to NP_min = 4 over the budget.

Adaptations to this project, stated: NP_max = 20 D as in the paper but capped at budget / 25
(the paper's budget is 10,000 D evaluations, ours 10,000 in total, so 20 D individuals with
D = 40..80 would leave a handful of generations); constraints by Deb's rule
(`planner_core.model.formulas.deb_not_worse` for replacement, `deb_order` for ranking), since the
paper's
competition is unconstrained. The incumbent is the Deb-best seen. With a problem that has an
``initial_population`` hook the first population comes from it (the seeded protocol), else it is
uniform in the box.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planner_core.bench.baselines import OptimiseResult
from planner_core.bench.baselines.unit_start import unit_initial_population
from planner_core.model.formulas import deb_not_worse, deb_order
from planner_core.pipeline.evaluator import as_evaluator

__all__ = ["optimise", "NP_MIN", "MEMORY"]

NP_MIN = 4
MEMORY = 5
#: population per dimension at the start (paper: 20 D) and the cap relative to the budget
NP_PER_DIM = 20
BUDGET_PER_IND = 25


def optimise(problem: Any, budget: int, seed: int) -> OptimiseResult:
    """L-SRTDE for exactly min(budget, what the schedule spends) evaluations; Deb-best result.

    Works in the unit box (x = lower + u (upper - lower)).

    Args:
        problem: has `lower`, `upper` (d,) and `evaluate(X) -> (f, phi)` for X (n, d);
            optionally the `initial_population` hook (the seeded protocol).
        budget: evaluations at most, >= NP_MIN.
        seed: the run's seed.

    Returns:
        The `OptimiseResult` of the Deb-best seen, with the last population's feasible share
        as `last_feasible_rate`.

    Raises:
        ValueError: the budget is below NP_MIN.
    """
    budgeted = as_evaluator(problem, budget)
    lo, hi = budgeted.lower, budgeted.upper
    span = hi - lo
    d = lo.shape[0]
    if budget < NP_MIN:
        raise ValueError(f"budget {budget} is below L-SRTDE's minimum population {NP_MIN}")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5A7DE]))
    np_max = int(max(NP_MIN, min(NP_PER_DIM * d, budget // BUDGET_PER_IND)))
    U = unit_initial_population(problem, rng, np_max, d)
    f, phi = budgeted.evaluate(lo + U * span)
    mem = np.ones(MEMORY)
    k_mem = 0
    sr = 0.0
    while budgeted.remaining > 0:
        n = U.shape[0]
        order = deb_order(f, phi)
        rank = np.empty(n, dtype=int)
        rank[order] = np.arange(n)
        # parameters from the success rate (paper: F mean 0.4 + 0.25 tanh(5 SR), pb 0.7 e^-7SR)
        F = np.clip(rng.normal(0.4 + 0.25 * math.tanh(5.0 * sr), 0.02, n), 1e-3, 1.0)
        pb = max(2, int(round(0.7 * math.exp(-7.0 * sr) * n)))
        Cr = np.clip(rng.normal(mem[rng.integers(0, MEMORY, n)], 0.05), 0.0, 1.0)
        pbest = order[rng.integers(0, min(pb, n), n)]
        w = np.exp(-3.0 * rank / n)
        r1 = rng.choice(n, size=n, p=w / w.sum())
        r2 = rng.integers(0, n, n)
        V = U + F[:, None] * (U[pbest] - U) + F[:, None] * (U[r1] - U[r2])
        V = np.where(V < 0.0, U / 2.0, V)
        V = np.where(V > 1.0, (U + 1.0) / 2.0, V)
        cross = rng.random((n, d)) < Cr[:, None]
        cross[np.arange(n), rng.integers(0, d, n)] = True
        T = np.where(cross, V, U)
        m = min(n, budgeted.remaining)
        ft, pt = budgeted.evaluate(lo + T[:m] * span)
        win = deb_not_worse(ft, pt, f[:m], phi[:m])
        better = win & ((pt < phi[:m]) | (ft < f[:m]))
        sr = float(np.count_nonzero(better)) / n
        if np.any(better):
            pm, fm = phi[:m][better], f[:m][better]
            gain = np.where(pt[better] < pm, pm - pt[better], fm - ft[better])
            gain = np.where(np.isfinite(gain), np.abs(gain), 0.0) + 1e-300
            c = Cr[:m][better]
            wts = gain / gain.sum()
            mem[k_mem] = float(np.sum(wts * c**2) / max(np.sum(wts * c), 1e-300))
            k_mem = (k_mem + 1) % MEMORY
        U[:m][win] = T[:m][win]
        f[:m][win], phi[:m][win] = ft[win], pt[win]
        # linear population size reduction over the budget, dropping the Deb-worst
        target = int(round(np_max + (NP_MIN - np_max) * budgeted.count / budget))
        target = max(NP_MIN, min(n, target))
        if target < n:
            keep = deb_order(f, phi)[:target]
            U, f, phi = U[keep], f[keep], phi[keep]
    x, bf, bp = budgeted.best("deb")
    feas = float(np.count_nonzero(phi == 0.0)) / phi.size
    return OptimiseResult(x, bf, bp, budgeted.count, budgeted.trace("deb"), feas)
