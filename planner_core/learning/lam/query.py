"""The two-stage query of paper Sec. 4.3 and the synthetic constrained training problems.

Given M target tasks with landscape features ``z_f[m]`` (objective) and ``z_phi[m]``
(violation), and the database features ``z_s`` of every instance s:

Stage 1 (paper eq. select_obj): ``S_f`` = the K instances with the smallest mean distance
``(1/M) sum_m ||z_f[m] - z_s||``. The sum over S of per-instance scores is minimised exactly by
taking the K smallest scores (ties broken by database order).

Stage 2: each ``s_k`` is tied to its corresponding task ``m(k) = argmin_m ||z_f[m] - z_{s_k}||``
(the paper's "corresponding constraint feature z_m^phi"); ``s'_k`` is the instance of the same
dimension as ``s_k`` (other than ``s_k``) nearest to ``z_phi[m(k)]``.

Ablations (paper Table "retrieval strategies"):

- ``selection="random"`` (LAMDE-R): K objective instances uniformly at random (seeded), each
  paired with a random same-dimension instance.
- ``selection="local"`` (LAMDE-L): per task, its own nearest instances by ``z_f`` (round-robin
  over tasks, ceil(K / M) each, no repeats), then stage 2 as above.
- ``features="ela"`` (LAMDE-E) vs ``"learned"`` (LAMDE): which extractor gives z.

ELA features are standardised with the database's per-feature mean and standard deviation
before distances (their scales differ by orders of magnitude); the learned features are unit
vectors and used as they are.

Training problem ``<s_k, s'_k>`` (:class:`PairProblem`): on the unit box, ``f(x) = s_k(x)`` (BBOB
precision) and ``phi(x) = max(0, s'_k(x) - t_k) / scale_k``. Threshold rule: ``t_k`` is the
``rho``-quantile of ``s'_k`` on its database probe, with ``rho`` the tasks' mean probed
feasible fraction clipped to [0.05, 0.95]; so on that probe a share ``rho`` of the points is
feasible (neither none nor all), and the feasible region ``{s'_k <= t_k}`` is a sub-level set
of a BBOB landscape, shaped like the tasks' violation landscape. ``scale_k`` is the probe's
value range of ``s'_k`` (1 if constant), so violations are O(1) whatever the function.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner_core.learning.lam.bbob import InstanceKey, bbob_values, check_key
from planner_core.learning.lam.probe import N_PROBE, blas_single_thread, probe

__all__ = [
    "RHO_RANGE",
    "SELECTIONS",
    "PairProblem",
    "Selected",
    "TaskFeatures",
    "match",
    "stage_one",
    "standardiser",
    "task_features",
    "threshold_for",
]

SELECTIONS = ("global", "random", "local")
#: the feasible-share target is clipped to this range (never empty, never everything)
RHO_RANGE = (0.05, 0.95)


@dataclass(frozen=True)
class TaskFeatures:
    """Per task: name, dimension, z_f (M, k), z_phi (M, k), probed feasible fraction (M,)."""

    names: tuple[str, ...]
    dimensions: tuple[int, ...]
    z_f: np.ndarray
    z_phi: np.ndarray
    feasible_fraction: np.ndarray


def task_features(
    problems: list[Any],
    names: list[str],
    extractor: Any,
    n_probe: int = N_PROBE,
    seed: int = 0,
) -> TaskFeatures:
    """Probe each task (LHS, seed ``SeedSequence([seed, m])``) and extract z_f and z_phi.

    Args:
        problems: the M task problems (box problems: ``lower``, ``upper``, ``evaluate``).
        names: their names.
        extractor: the feature extractor (``__call__(U, y) -> (q,)``).
        n_probe: probe points per task.
        seed: the probes' base seed.

    Returns:
        The `TaskFeatures`: names, dimensions, z_f (M, q), z_phi (M, q), probed feasible
        fraction (M,).
    """
    zf, zp, ff, dims = [], [], [], []
    with blas_single_thread():
        for m, prob in enumerate(problems):
            p = probe(prob, n_probe, np.random.SeedSequence([int(seed), m]))
            zf.append(extractor(p.U, p.f))
            zp.append(extractor(p.U, p.phi))
            ff.append(p.feasible_fraction)
            dims.append(int(np.asarray(prob.lower).size))
    return TaskFeatures(tuple(names), tuple(dims), np.array(zf), np.array(zp), np.array(ff))


def standardiser(Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mean, std) per feature over the database; std 0 -> 1.

    Args:
        Z: (S, q) database features.

    Returns:
        (mean (q,), std (q,), ddof 0, zeros replaced by 1).
    """
    mu = Z.mean(axis=0)
    sd = Z.std(axis=0)
    return mu, np.where(sd > 0, sd, 1.0)


@dataclass(frozen=True)
class Selected:
    """One chosen pair: database indices of s_k and s'_k, the task m(k), distances."""

    objective: int
    constraint: int
    task: int
    distance_f: float  # stage-1 score (global: mean over tasks; local: to its task)
    distance_phi: float  # ||z_phi[m(k)] - z_{s'_k}||


def match(
    keys: list[InstanceKey],
    Z: np.ndarray,
    z_f: np.ndarray,
    z_phi: np.ndarray,
    k: int,
    selection: str = "global",
    seed: int = 0,
) -> list[Selected]:
    """The two-stage query (module doc) over database keys / features Z (S, q).

    Args:
        keys: the database's S instance keys.
        Z: (S, q) their features (standardised as the tasks').
        z_f: (M, q) the tasks' objective features.
        z_phi: (M, q) the tasks' violation features.
        k: pairs to select, 1..S.
        selection: "global", "random" or "local" (module doc's ablations).
        seed: the random selection's seed.

    Returns:
        k `Selected` pairs, in the order taken.

    Raises:
        ValueError: an unknown selection, k < 1 or k > the database size.
    """
    if selection not in SELECTIONS:
        raise ValueError(f"selection: {selection!r} is not one of {SELECTIONS}")
    S = len(keys)
    if not 1 <= k <= S:
        raise ValueError(f"k: {k} must be in 1..{S} (the database size)")
    dims = np.array([key.dimension for key in keys])
    Df = np.linalg.norm(z_f[:, None, :] - Z[None, :, :], axis=-1)  # (M, S)
    Dp = np.linalg.norm(z_phi[:, None, :] - Z[None, :, :], axis=-1)  # (M, S)
    rng = np.random.default_rng(seed)

    if selection == "random":
        objs = rng.choice(S, size=k, replace=False)
        out = []
        for s in objs:
            same = np.flatnonzero((dims == dims[s]) & (np.arange(S) != s))
            c = int(rng.choice(same)) if same.size else int(s)
            m = int(np.argmin(Df[:, s]))
            out.append(Selected(int(s), c, m, float(Df[:, s].mean()), float(Dp[m, c])))
        return out

    objs, tasks, scores = stage_one(Df, k, selection)

    out = []
    for s, m, sc in zip(objs, tasks, scores, strict=True):
        cand = np.flatnonzero((dims == dims[s]) & (np.arange(S) != s))
        if cand.size == 0:
            cand = np.array([s])
        c = int(cand[np.argmin(Dp[m, cand])])
        out.append(Selected(int(s), c, int(m), float(sc), float(Dp[m, c])))
    return out


def stage_one(Df: np.ndarray, k: int, selection: str = "global"
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stage 1 of the query (module doc) from the task-to-instance distances.

    Args:
        Df: ||z_f[m] - z_s|| (M tasks, S instances); k: instances to take (1..S);
        selection: "global" (the k smallest mean distances) or "local" (each task's nearest
            in turn, ceil(k / M) each, no repeats).

    Returns:
        (instances (k,), their tasks m(k) (k,), their scores (k,)), instances in order taken.
    """
    M, S = Df.shape
    if selection == "global":
        score = Df.mean(axis=0)
        objs = np.argsort(score, kind="stable")[:k]
        tasks = np.argmin(Df[:, objs], axis=0)
        scores = score[objs]
    else:  # local
        order = np.argsort(Df, axis=1, kind="stable")
        per = math.ceil(k / M)
        taken: set[int] = set()
        objs_l, tasks_l, scores_l = [], [], []
        pos = np.zeros(M, dtype=int)
        count = np.zeros(M, dtype=int)
        while len(objs_l) < k:
            progressed = False
            for m in range(M):
                if len(objs_l) >= k or count[m] >= per:
                    continue
                while pos[m] < S and int(order[m, pos[m]]) in taken:
                    pos[m] += 1
                if pos[m] >= S:
                    continue
                s = int(order[m, pos[m]])
                taken.add(s)
                objs_l.append(s)
                tasks_l.append(m)
                scores_l.append(float(Df[m, s]))
                count[m] += 1
                progressed = True
            if not progressed:
                per += 1
        objs, tasks, scores = np.array(objs_l), np.array(tasks_l), np.array(scores_l)

    return objs, tasks, scores


def threshold_for(
    constraint: InstanceKey, rho: float, n_probe: int = N_PROBE, seed: int = 0
) -> tuple[float, float]:
    """(t, scale) of the threshold rule (module doc) for one constraint instance: the
    rho-quantile and value range of its database probe.

    Args:
        constraint: the constraint instance s'_k.
        rho: the feasible-share target, clipped to `RHO_RANGE`.
        n_probe: the database's probe size.
        seed: the database's probe seed.

    Returns:
        (t, scale): the threshold and the probe's value range (1 if constant).
    """
    from planner_core.learning.lam.database import instance_probe

    y = instance_probe(constraint, n_probe, seed).f
    rho = float(np.clip(rho, *RHO_RANGE))
    t = float(np.quantile(y, rho))
    scale = float(np.ptp(y))
    return t, (scale if scale > 0 else 1.0)


class PairProblem:
    """Training problem <s_k, s'_k>: unit box, f = s_k(x), phi = max(0, s'_k(x) - t) / scale.

    ``objective`` and ``constraint`` must have the same dimension and be valid keys
    (:func:`~planner_core.learning.lam.bbob.check_key`; ValueError otherwise).
    """

    def __init__(
        self,
        objective: InstanceKey | tuple[int, int, int],
        constraint: InstanceKey | tuple[int, int, int],
        threshold: float,
        scale: float = 1.0,
    ):
        self.objective = check_key(objective, "objective")
        self.constraint = check_key(constraint, "constraint")
        if self.objective.dimension != self.constraint.dimension:
            raise ValueError(
                f"constraint: dimension {self.constraint.dimension} differs from the "
                f"objective's {self.objective.dimension}"
            )
        if not (math.isfinite(threshold) and math.isfinite(scale) and scale > 0):
            raise ValueError(f"threshold/scale: need finite values and scale > 0, got "
                             f"{threshold}, {scale}")  # fmt: skip
        self.threshold = float(threshold)
        self.scale = float(scale)
        self.dim = self.objective.dimension
        self.lower = np.zeros(self.dim)
        self.upper = np.ones(self.dim)

    def __repr__(self) -> str:
        o, c = self.objective, self.constraint
        return (
            f"PairProblem(f{o.function}/i{o.instance} s.t. f{c.function}/i{c.instance} "
            f"<= {self.threshold:.4g}, d={self.dim})"
        )

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Evaluate unit-box points: f = s_k(x), phi = max(0, s'_k(x) - t) / scale.

        Args:
            X: (n, d) unit-box points.

        Returns:
            (f (n,), phi (n,) >= 0).

        Raises:
            ValueError: X's second axis is not the problem's dimension.
        """
        f = bbob_values(self.objective, X)
        g = bbob_values(self.constraint, X)
        return f, np.maximum(0.0, g - self.threshold) / self.scale
