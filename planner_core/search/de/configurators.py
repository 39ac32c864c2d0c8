"""Configurators: who picks (mutation, crossover, F, Cr) per individual each generation.

Protocol (see :class:`planner_core.search.de.core.Configurator`): ``init(state) -> memory``,
``configure(state, rng) -> Config`` (reads ``state.memory``), ``update(memory, outcome) ->
memory``. Memory values are immutable, so a configurator object can be shared between runs
and a run is reproducible from its seed alone.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from planner_core.model.formulas import deb_best, deb_better
from planner_core.search.de.operators import (
    N_CROSSOVERS,
    N_MUTATIONS,
    crossover_index,
    mutation_index,
)
from planner_core.search.de.types import Config, DEState, Outcome


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
        """No memory (stateless).

        Args:
            state: the run's initial state (unused).

        Returns:
            None.
        """
        return None

    def configure(self, state: DEState, rng: np.random.Generator) -> Config:
        """The fixed configuration for every individual.

        Args:
            state: the run's state (its population N read).
            rng: the generation's generator (unused).

        Returns:
            A `Config` of (N,) arrays: the mutation and crossover ids, F and Cr.
        """
        n = state.population
        return Config(
            _full(n, mutation_index(self.mutation), np.intp),
            _full(n, crossover_index(self.crossover), np.intp),
            _full(n, self.F),
            _full(n, self.Cr),
        )

    def update(self, memory: Any, outcome: Outcome) -> None:
        """Nothing to learn.

        Args:
            memory: the current memory (unused).
            outcome: the generation's outcome (unused).

        Returns:
            None.
        """
        return None


@dataclass(frozen=True)
class RandomConfigurator:
    """Uniform operators, F and Cr uniform in [0, 1]: the untrained-policy baseline."""

    def init(self, state: DEState) -> None:
        """No memory (stateless).

        Args:
            state: the run's initial state (unused).

        Returns:
            None.
        """
        return None

    def configure(self, state: DEState, rng: np.random.Generator) -> Config:
        """A uniform draw per individual.

        Args:
            state: the run's state (its population N read).
            rng: the generation's generator: mutation ids, crossover ids, F, Cr, in order.

        Returns:
            A `Config` of (N,) arrays: mutation ids in 0..6, crossover ids in 0..1, F and Cr
            in [0, 1).
        """
        n = state.population
        return Config(
            rng.integers(0, N_MUTATIONS, size=n),
            rng.integers(0, N_CROSSOVERS, size=n),
            rng.random(n),
            rng.random(n),
        )

    def update(self, memory: Any, outcome: Outcome) -> None:
        """Nothing to learn.

        Args:
            memory: the current memory (unused).
            outcome: the generation's outcome (unused).

        Returns:
            None.
        """
        return None


ARMS: np.ndarray = np.array([(m, c) for m in range(N_MUTATIONS) for c in range(N_CROSSOVERS)])
"""The 14 (mutation, crossover) pairs the adaptive configurator chooses among; arm = 2 m + c."""
_GREEDY_ARM = 1 * N_CROSSOVERS + 1  # best/1 with exponential crossover


class AdaptiveMemory(NamedTuple):
    """Memory of :class:`AdaptiveConfigurator`, one entry per arm (arrays are never mutated)."""

    m_f: np.ndarray  # (14,) centre of the F distribution
    m_cr: np.ndarray  # (14,) centre of the Cr distribution
    quality: np.ndarray  # (14,) smoothed mean credit per trial
    stall: int = 0  # generations since a trial last beat the best parent


def rank_credit(outcome: Outcome) -> np.ndarray:
    """Per trial: 0 if it failed, else the fraction of the generation's parents it Deb-beats.

    Scale-free (mixes violation and objective progress without units) and rewards trials that
    land near the top of the population more than trials that merely beat a poor parent.

    Args:
        outcome: the generation's outcome (k trials, the parents compared against).

    Returns:
        (k,) float credits in [0, 1].
    """
    ft, pt = outcome.f_trial[:, None], outcome.phi_trial[:, None]
    fp, pp = outcome.f_parent[None, :], outcome.phi_parent[None, :]
    beats = deb_better(ft, pt, fp, pp).mean(axis=1)
    return np.where(outcome.success, beats, 0.0)


@dataclass(frozen=True)
class AdaptiveConfigurator:
    """Strategy-portfolio DE (SaDE/SHADE family) with stall-triggered intensification.

    * Arms are the 14 (mutation, crossover) pairs. Each arm keeps its own centre for F and Cr
      (exponential crossover needs a much higher Cr than binomial for the same number of genes).
    * Per individual: arm ~ probabilities proportional to each arm's quality (``floor`` each),
      F ~ N(M_F[arm], ``f_sd``) clipped to [0.02, 1], Cr ~ N(M_Cr[arm], ``cr_sd``) clipped to
      [0, 1].
    * Credit (:func:`rank_credit`): a successful trial scores the fraction of parents it beats.
      Quality = exponential moving average (``rate``) of an arm's mean credit per use; F and Cr
      centres move (``lr``) towards the credit-weighted mean of the arm's successful values.
    * Intensification: when no trial has beaten the best parent for ``stall`` generations, a
      share ``intensify * min(1, stall / stall_gens)`` of the draws goes to best/1 with
      exponential crossover: a perturbed contiguous block of the Deb-best copied into a parent.
      It gets UAV runs off violation plateaus (a hover point is a contiguous 4-gene block), and
      it stays off while the best keeps improving, so it does not collapse the population early.
    """

    f_init: float = 0.3
    cr_bin: float = 0.5
    cr_exp: float = 0.9
    f_sd: float = 0.1
    cr_sd: float = 0.1
    rate: float = 0.2
    lr: float = 0.1
    floor: float = 0.02
    intensify: float = 0.5
    stall_gens: float = 5.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.floor * len(ARMS) <= 1.0:
            raise ValueError("floor * 14 must lie in [0, 1]")
        if not 0.0 <= self.intensify <= 1.0:
            raise ValueError("intensify must lie in [0, 1]")
        if self.stall_gens <= 0:
            raise ValueError("stall_gens must be positive")

    def init(self, state: DEState) -> AdaptiveMemory:
        """The first memory.

        Args:
            state: the run's initial state (unused).

        Returns:
            An `AdaptiveMemory`: every arm's F centre `f_init`, Cr centre `cr_bin` (binomial)
            or `cr_exp` (exponential), quality 0.1, stall 0.
        """
        a = len(ARMS)
        return AdaptiveMemory(
            m_f=np.full(a, self.f_init),
            m_cr=np.where(ARMS[:, 1] == 0, self.cr_bin, self.cr_exp),
            quality=np.full(a, 0.1),
        )

    def probabilities(self, memory: AdaptiveMemory) -> np.ndarray:
        """Arm probabilities for the next generation (class docstring: quality shares with
        a floor, plus the stall-driven share of best/1/exp).

        Args:
            memory: the current memory.

        Returns:
            (14,) probabilities summing to 1, indexed by arm = 2 m + c.
        """
        a = len(ARMS)
        q = np.maximum(memory.quality, 0.0)
        share = q / q.sum() if q.sum() > 0 else np.full(a, 1.0 / a)
        greedy = self.intensify * min(1.0, memory.stall / self.stall_gens)
        p = (1.0 - greedy) * (self.floor + (1.0 - a * self.floor) * share)
        p[_GREEDY_ARM] += greedy
        return p

    def configure(self, state: DEState, rng: np.random.Generator) -> Config:
        """Draw each individual's arm, F and Cr (compiled; equal bit for bit to
        :meth:`configure_reference`).

        Args:
            state: the run's state (population N; `memory`, `init`'s when None).
            rng: the generation's generator: N uniforms, then (2, N) standard normals.

        Returns:
            A `Config` of (N,) arrays; F in [0.02, 1], Cr in [0, 1].
        """
        mem: AdaptiveMemory = state.memory if state.memory is not None else self.init(state)
        n = state.population
        u = rng.random(n)
        z = rng.standard_normal((2, n))
        mutation, crossover = np.empty(n, dtype=np.intp), np.empty(n, dtype=np.intp)
        F, Cr = np.empty(n), np.empty(n)
        _draw(self.probabilities(mem), u, z, mem.m_f, mem.m_cr, self.f_sd, self.cr_sd, ARMS,
              mutation, crossover, F, Cr)  # fmt: skip
        return Config(mutation, crossover, F, Cr)

    def configure_reference(self, state: DEState, rng: np.random.Generator) -> Config:
        """:meth:`configure` in plain numpy: the readable statement of the draw, kept for tests.

        One uniform per individual picks its arm by inverse CDF, two normals its F and Cr.

        Args:
            state: the run's state (population N; `memory`, `init`'s when None).
            rng: the generation's generator: N uniforms, then (2, N) standard normals.

        Returns:
            A `Config` of (N,) arrays; F in [0.02, 1], Cr in [0, 1].
        """
        mem: AdaptiveMemory = state.memory if state.memory is not None else self.init(state)
        n = state.population
        cdf = np.cumsum(self.probabilities(mem))
        arm = np.searchsorted(cdf, rng.random(n) * cdf[-1], side="right")
        arm = np.minimum(arm, len(ARMS) - 1)
        z = rng.standard_normal((2, n))
        F = np.minimum(np.maximum(mem.m_f[arm] + self.f_sd * z[0], 0.02), 1.0)
        Cr = np.minimum(np.maximum(mem.m_cr[arm] + self.cr_sd * z[1], 0.0), 1.0)
        return Config(ARMS[arm, 0], ARMS[arm, 1], F, Cr)

    def update(self, memory: AdaptiveMemory, outcome: Outcome) -> AdaptiveMemory:
        """The next memory (compiled; equal bit for bit to :meth:`update_reference`).

        Args:
            memory: the current memory (never written).
            outcome: the generation's outcome (its first k config rows made the k trials).

        Returns:
            A new `AdaptiveMemory` (stall 0 when a trial Deb-beat the best parent, else + 1);
            `memory` itself when there were no trials.
        """
        k = len(outcome.success)
        if k == 0:
            return memory
        cfg = outcome.config
        quality, m_f, m_cr = memory.quality.copy(), memory.m_f.copy(), memory.m_cr.copy()
        improved = _update(
            np.asarray(cfg.mutation[:k] * N_CROSSOVERS + cfg.crossover[:k], dtype=np.intp),
            np.asarray(outcome.success, dtype=np.bool_),
            np.asarray(outcome.f_trial, dtype=float), np.asarray(outcome.phi_trial, dtype=float),
            np.asarray(outcome.f_parent, dtype=float), np.asarray(outcome.phi_parent, dtype=float),
            np.asarray(cfg.F[:k], dtype=float), np.asarray(cfg.Cr[:k], dtype=float),
            self.rate, self.lr, quality, m_f, m_cr,
        )  # fmt: skip
        return AdaptiveMemory(m_f, m_cr, quality, 0 if improved else memory.stall + 1)

    def update_reference(self, memory: AdaptiveMemory, outcome: Outcome) -> AdaptiveMemory:
        """:meth:`update` in plain numpy: the readable statement of the rule, kept for tests.

        Args:
            memory: the current memory (never written).
            outcome: the generation's outcome (its first k config rows made the k trials).

        Returns:
            A new `AdaptiveMemory`; `memory` itself when there were no trials.
        """
        k = len(outcome.success)
        if k == 0:
            return memory
        a = len(ARMS)
        cfg = outcome.config
        arm = cfg.mutation[:k] * N_CROSSOVERS + cfg.crossover[:k]
        credit = rank_credit(outcome)
        used = np.bincount(arm, minlength=a)
        gain = np.bincount(arm, weights=credit, minlength=a)
        seen = used > 0
        quality = memory.quality.copy()
        quality[seen] += self.rate * (gain[seen] / used[seen] - quality[seen])
        m_f, m_cr = memory.m_f.copy(), memory.m_cr.copy()
        won = gain > 0
        mean_f = np.bincount(arm, weights=credit * cfg.F[:k], minlength=a)[won] / gain[won]
        mean_cr = np.bincount(arm, weights=credit * cfg.Cr[:k], minlength=a)[won] / gain[won]
        m_f[won] += self.lr * (mean_f - m_f[won])
        m_cr[won] += self.lr * (mean_cr - m_cr[won])
        b = deb_best(outcome.f_parent, outcome.phi_parent)
        fb, pb = outcome.f_parent[b], outcome.phi_parent[b]
        improved = bool(deb_better(outcome.f_trial, outcome.phi_trial, fb, pb).any())
        return AdaptiveMemory(m_f, m_cr, quality, 0 if improved else memory.stall + 1)


@njit(cache=True, fastmath=False)
def _draw(p, u, z, m_f, m_cr, f_sd, cr_sd, arms, mutation, crossover, F, Cr):  # pragma: no cover
    """:meth:`AdaptiveConfigurator.configure_reference`, compiled; writes the four outputs."""
    a = p.shape[0]
    cdf = np.cumsum(p)
    for i in range(u.shape[0]):
        x = u[i] * cdf[a - 1]
        arm = 0  # the first arm whose cdf exceeds x (searchsorted, side "right")
        while arm < a - 1 and cdf[arm] <= x:
            arm += 1
        mutation[i] = arms[arm, 0]
        crossover[i] = arms[arm, 1]
        F[i] = min(max(m_f[arm] + f_sd * z[0, i], 0.02), 1.0)
        Cr[i] = min(max(m_cr[arm] + cr_sd * z[1, i], 0.0), 1.0)


@njit(cache=True, fastmath=False)
def _update(  # pragma: no cover
    arm, success, f_t, phi_t, f_p, phi_p, F, Cr, rate, lr, quality, m_f, m_cr
):
    """:meth:`AdaptiveConfigurator.update_reference`, compiled; writes quality, m_f, m_cr."""
    a = quality.shape[0]
    k = arm.shape[0]
    n = f_p.shape[0]
    used = np.zeros(a)
    gain = np.zeros(a)
    gain_f = np.zeros(a)
    gain_cr = np.zeros(a)
    b = 0  # Deb-best parent, first index on ties (as core.deb_best)
    for i in range(1, n):
        if phi_p[i] < phi_p[b] or (phi_p[i] == phi_p[b] and f_p[i] < f_p[b]):
            b = i
    improved = False
    for i in range(k):
        ft, pt = f_t[i], phi_t[i]
        used[arm[i]] += 1.0
        if pt < phi_p[b] or (pt == phi_p[b] and ft < f_p[b]):
            improved = True
        if not success[i]:
            continue
        beats = 0  # rank credit: the fraction of the generation's parents this trial Deb-beats
        for c in range(n):
            if pt < phi_p[c] or (pt == phi_p[c] and ft < f_p[c]):
                beats += 1
        credit = beats / n
        gain[arm[i]] += credit
        gain_f[arm[i]] += credit * F[i]
        gain_cr[arm[i]] += credit * Cr[i]
    for j in range(a):
        if used[j] > 0:
            quality[j] += rate * (gain[j] / used[j] - quality[j])
        if gain[j] > 0:
            m_f[j] += lr * (gain_f[j] / gain[j] - m_f[j])
            m_cr[j] += lr * (gain_cr[j] / gain[j] - m_cr[j])
    return improved


#: configurators by name: a class, or "module:attribute" of one that lives above the DE (the
#: learned policy depends on the DE and the env, so the DE names it without importing it, as the
#: baselines registry names its optimisers); planner_core.defaults.CONFIGURATORS lists the names
_REGISTRY: dict[str, Any] = {
    "fixed": FixedConfigurator,
    "random": RandomConfigurator,
    "adaptive": AdaptiveConfigurator,
    "lamde": "planner_core.learning.policy:PolicyConfigurator",
}


def make_configurator(name: str, **kw: Any) -> Any:
    """Build a configurator by name.

    Args:
        name: "fixed", "random", "adaptive" or "lamde" (the shipped policy checkpoint,
            planner_core.learning.policy; numpy only).
        **kw: keywords for its constructor.

    Returns:
        The configurator object.

    Raises:
        ValueError: an unknown name, or a value the configurator refuses (e.g. F outside
            [0, 1]).
        TypeError: a keyword the configurator does not take.
    """
    try:
        cls = _REGISTRY[name]
    except KeyError:
        raise ValueError(
            f"unknown configurator {name!r}; choose from {sorted(_REGISTRY)}"
        ) from None
    if isinstance(cls, str):
        module, attr = cls.split(":")
        cls = getattr(importlib.import_module(module), attr)
    return cls(**kw)
