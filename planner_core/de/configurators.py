"""Configurators: who picks (mutation, crossover, F, Cr) per individual each generation.

Protocol (see :class:`planner_core.de.core.Configurator`): ``init(state) -> memory``,
``configure(state, rng) -> Config`` (reads ``state.memory``), ``update(memory, outcome) ->
memory``. Memory values are immutable, so a configurator object can be shared between runs
and a run is reproducible from its seed alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from planner_core.de.core import Config, DEState, Outcome, deb_order
from planner_core.de.operators import (
    N_CROSSOVERS,
    N_MUTATIONS,
    crossover_index,
    mutation_index,
)


def _full(n: int, value: float, dtype: type = float) -> np.ndarray:
    return np.full(n, value, dtype=dtype)


@dataclass(frozen=True)
class FixedConfigurator:
    """The same configuration for everyone, every generation (default DE/rand/1/bin, 0.5, 0.9)."""

    mutation: str | int = "rand/1"
    crossover: str | int = "bin"
    F: float = 0.5
    Cr: float = 0.9

    def __post_init__(self) -> None:
        mutation_index(self.mutation)
        crossover_index(self.crossover)
        if not (0.0 <= self.F <= 1.0 and 0.0 <= self.Cr <= 1.0):
            raise ValueError("F and Cr must lie in [0, 1]")

    def init(self, state: DEState) -> None:
        return None

    def configure(self, state: DEState, rng: np.random.Generator) -> Config:
        n = state.population
        return Config(
            _full(n, mutation_index(self.mutation), np.intp),
            _full(n, crossover_index(self.crossover), np.intp),
            _full(n, self.F),
            _full(n, self.Cr),
        )

    def update(self, memory: Any, outcome: Outcome) -> None:
        return None


@dataclass(frozen=True)
class RandomConfigurator:
    """Uniform operators, F and Cr uniform in [0, 1]: the untrained-policy baseline."""

    def init(self, state: DEState) -> None:
        return None

    def configure(self, state: DEState, rng: np.random.Generator) -> Config:
        n = state.population
        return Config(
            rng.integers(0, N_MUTATIONS, size=n),
            rng.integers(0, N_CROSSOVERS, size=n),
            rng.random(n),
            rng.random(n),
        )

    def update(self, memory: Any, outcome: Outcome) -> None:
        return None


class AdaptiveMemory(NamedTuple):
    """Success-history memory of :class:`AdaptiveConfigurator` (arrays are never mutated)."""

    m_f: np.ndarray  # (H,) location of the Cauchy F distribution
    m_cr: np.ndarray  # (H,) mean of the normal Cr distribution
    slot: int  # next memory slot to overwrite
    mut_quality: np.ndarray  # (7,) smoothed success rate per mutation operator
    cx_quality: np.ndarray  # (2,) smoothed success rate per crossover


def _probabilities(quality: np.ndarray, floor: float) -> np.ndarray:
    """Probabilities proportional to quality, each at least ``floor``."""
    k = len(quality)
    q = np.maximum(quality, 0.0)
    total = q.sum()
    share = q / total if total > 0 else np.full(k, 1.0 / k)
    return floor + (1.0 - k * floor) * share


def _improvement_weights(outcome: Outcome) -> np.ndarray:
    """Non-negative weight per trial: 0 for failures; successes that cut the violation share
    (by their share of the violation decrease) the weight of violation-improving successes,
    the others (same phi, lower f) share the rest by their f decrease."""
    s = outcome.success
    w = np.zeros(len(s))
    if not s.any():
        return w
    dphi = np.where(s, outcome.phi_parent - outcome.phi_trial, 0.0)
    by_phi = s & (dphi > 0)
    by_f = s & ~by_phi
    n_s = s.sum()
    for mask, delta in ((by_phi, dphi), (by_f, outcome.f_parent - outcome.f_trial)):
        if mask.any():
            d = np.where(mask, delta, 0.0)
            d = np.where(np.isfinite(d), d, 0.0)
            tot = d.sum()
            part = d / tot if tot > 0 else mask / mask.sum()
            w += part * (mask.sum() / n_s)
    return w


def _rank_credit(outcome: Outcome) -> np.ndarray:
    """Per trial: 0 on failure, else the fraction of all parents the trial Deb-beats."""
    ft, pt = outcome.f_trial[:, None], outcome.phi_trial[:, None]
    fp, pp = outcome.f_parent[None, :], outcome.phi_parent[None, :]
    beats = ((pt < pp) | ((pt == pp) & (ft < fp))).mean(axis=1)
    return np.where(outcome.success, beats, 0.0)


@dataclass(frozen=True)
class AdaptiveConfigurator:
    """SHADE-style success-history adaptation of F and Cr plus success-rate operator choice.

    * F ~ Cauchy(M_F[r], 0.1) (redrawn while <= 0, cut at 1), Cr ~ N(M_Cr[r], 0.1) clipped to
      [0, 1], r uniform over H memory slots. After each generation the slot ``slot`` becomes the
      weighted Lehmer mean of successful F (resp. weighted mean of successful Cr), weights from
      :func:`_improvement_weights` (violation decrease first, objective decrease for ties).
    * Mutation and crossover operators are drawn from probabilities proportional to an
      exponentially smoothed success rate per operator (``rate`` = smoothing), with a ``floor``
      probability each so no operator dies out.
    * Extra (documented): with ``pbest`` > 0 the "best" used by best/1, best/2, current-to-best/1
      and rand-to-best/1 is, per individual, a uniform pick from the top ``pbest`` fraction of
      the population under Deb's ranking (current-to-pbest style), which keeps greedy operators
      from collapsing onto one point.
    """

    memory_size: int = 6
    f_init: float = 0.5
    cr_init: float = 0.8
    f_scale: float = 0.1
    cr_scale: float = 0.1
    rate: float = 0.3
    mut_floor: float = 0.03
    cx_floor: float = 0.1
    pbest: float = 0.0
    credit: str = "success"
    weights: str = "improvement"
    f_mean: str = "lehmer"

    def init(self, state: DEState) -> AdaptiveMemory:
        h = self.memory_size
        return AdaptiveMemory(
            m_f=np.full(h, self.f_init),
            m_cr=np.full(h, self.cr_init),
            slot=0,
            mut_quality=np.full(N_MUTATIONS, 0.5),
            cx_quality=np.full(N_CROSSOVERS, 0.5),
        )

    def configure(self, state: DEState, rng: np.random.Generator) -> Config:
        mem: AdaptiveMemory = state.memory
        if mem is None:
            mem = self.init(state)
        n = state.population
        r = rng.integers(0, len(mem.m_f), size=n)
        F = mem.m_f[r] + self.f_scale * rng.standard_cauchy(n)
        bad = F <= 0
        while bad.any():
            F[bad] = mem.m_f[r[bad]] + self.f_scale * rng.standard_cauchy(int(bad.sum()))
            bad = F <= 0
        F = np.minimum(F, 1.0)
        Cr = np.clip(mem.m_cr[r] + self.cr_scale * rng.standard_normal(n), 0.0, 1.0)
        p_mut = _probabilities(mem.mut_quality, self.mut_floor)
        p_cx = _probabilities(mem.cx_quality, self.cx_floor)
        mutation = rng.choice(N_MUTATIONS, size=n, p=p_mut)
        crossover = rng.choice(N_CROSSOVERS, size=n, p=p_cx)
        guide = None
        if self.pbest > 0:
            top = max(2, int(round(self.pbest * n)))
            order = deb_order(state.f, state.phi)
            guide = order[rng.integers(0, top, size=n)]
        return Config(mutation, crossover, F, Cr, guide)

    def update(self, memory: AdaptiveMemory, outcome: Outcome) -> AdaptiveMemory:
        k = len(outcome.success)
        if k == 0:
            return memory
        cfg = outcome.config
        s = outcome.success.astype(float)
        w = _improvement_weights(outcome)
        q = _rank_credit(outcome) if "rank" in (self.credit, self.weights) else None
        if self.credit == "improvement":
            s = w * k
        elif self.credit == "mixed":
            s = 0.5 * s + 0.5 * w * s.sum()
        elif self.credit == "rank":
            s = q
        if self.weights == "rank":
            w = q
        mut_q = memory.mut_quality.copy()
        cx_q = memory.cx_quality.copy()
        for q, ids, n_ops in (
            (mut_q, cfg.mutation[:k], N_MUTATIONS),
            (cx_q, cfg.crossover[:k], N_CROSSOVERS),
        ):
            used = np.bincount(ids, minlength=n_ops)
            wins = np.bincount(ids, weights=s, minlength=n_ops)
            seen = used > 0
            q[seen] = (1 - self.rate) * q[seen] + self.rate * wins[seen] / used[seen]
        m_f, m_cr, slot = memory.m_f, memory.m_cr, memory.slot
        if w.sum() > 0:
            F, Cr = cfg.F[:k], cfg.Cr[:k]
            m_f, m_cr = m_f.copy(), m_cr.copy()
            w = w / w.sum()
            if self.f_mean == "lehmer":
                m_f[slot] = np.sum(w * F * F) / max(np.sum(w * F), 1e-12)
            else:
                m_f[slot] = np.sum(w * F)
            m_cr[slot] = np.sum(w * Cr)
            slot = (slot + 1) % len(m_f)
        return AdaptiveMemory(m_f, m_cr, slot, mut_q, cx_q)


_REGISTRY = {
    "fixed": FixedConfigurator,
    "random": RandomConfigurator,
    "adaptive": AdaptiveConfigurator,
}


def make_configurator(name: str, **kw: Any) -> Any:
    """Build a configurator by name: "fixed", "random" or "adaptive" (keywords go to it)."""
    try:
        cls = _REGISTRY[name]
    except KeyError:
        raise ValueError(f"unknown configurator {name!r}; choose from {sorted(_REGISTRY)}") from None
    return cls(**kw)
