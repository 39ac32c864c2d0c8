"""The optimisation MDP of the paper (Sec. 4.2) as a Gymnasium-style environment.

One step = one DE generation. Action = the per-individual configuration (a
:class:`~planner_core.de.core.Config`, a 4-tuple ``(mutation, crossover, F, Cr)`` or a dict with
those keys). Observation (dict of numpy arrays, N = population, d = dimension):

=============  =========  ===========================================================
key            shape      meaning
=============  =========  ===========================================================
``"X"``        (N, d)     population normalised to the unit box
``"f"``        (N, 2)     (mantissa omega, scaled exponent b / eta) of each f
``"phi"``      (N, 2)     (mantissa omega, scaled exponent b / eta) of each phi
``"progress"`` (1,)       g / G (G = generations the budget allows)
=============  =========  ===========================================================

Mantissa-exponent encoding: ``y = omega * 10**b`` with ``b = floor(log10|y|) + 1`` so
``0.1 <= |omega| < 1``; ``y == 0 -> (0, 0)``; +-inf is encoded as (+-1, 400 / eta), one past
the largest finite double's exponent. ``eta = 10`` by default: objective and violation values
of interest span roughly 1e-10 .. 1e10 (flight times of 1e3..1e4 s, violations from 1e-8 up to
the collision offset mu + nu * metres), which then map to scaled exponents in [-1, 1].

Reward: :func:`reward` (the paper's Eq. reward) on the Deb-best (phi, f) before and after the
step, with feasibility tolerance ``delta = 1e-8`` by default (violations below it count as
feasible for the reward only; the DE's selection still compares phi exactly).

Episode end: ``terminated`` is True once the evaluation budget is spent. Time is part of the
observation (g / G), so the budget's end is a true terminal state of this MDP, not a time
limit imposed from outside; ``truncated`` is always False (Gymnasium's semantics).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from planner_core.de.core import ask, evaluate, init, tell
from planner_core.de.types import BoxProblem, Config, DEState

DEFAULT_ETA = 10.0
DEFAULT_DELTA = 1e-8
_INF_EXPONENT = 400.0  # beyond the largest finite double exponent (309)
_BELOW_ONE = float(np.nextafter(1.0, 0.0))


def mantissa_exponent(y: np.ndarray, eta: float = DEFAULT_ETA) -> np.ndarray:
    """Encode values as (omega, b / eta) pairs, shape ``y.shape + (2,)`` (see module doc)."""
    y = np.asarray(y, dtype=float)
    out = np.zeros(y.shape + (2,))
    a = np.abs(y)
    finite = np.isfinite(y) & (a > 0)
    if finite.any():
        af = a[finite]
        b = np.floor(np.log10(af)) + 1.0
        omega = af / 10.0**b
        # log10 and 10**b round near powers of ten: move one decade if needed, then clip the
        # last-ulp leftovers so that 0.1 <= |omega| < 1 holds exactly.
        hi = omega >= 1.0
        omega[hi] /= 10.0
        b[hi] += 1.0
        lo = omega < 0.1
        omega[lo] *= 10.0
        b[lo] -= 1.0
        omega = np.clip(omega, 0.1, _BELOW_ONE)
        out[finite, 0] = np.sign(y[finite]) * omega
        out[finite, 1] = b / eta
    inf = np.isinf(y)
    out[inf, 0] = np.sign(y[inf])
    out[inf, 1] = _INF_EXPONENT / eta
    return out


def observe(state: DEState, eta: float = DEFAULT_ETA) -> dict[str, np.ndarray]:
    """The paper's state s_g for a DE state (pure; also usable by a policy configurator)."""
    G = state.max_generations
    return {
        "X": np.array(state.X),
        "f": mantissa_exponent(state.f, eta),
        "phi": mantissa_exponent(state.phi, eta),
        "progress": np.array([state.generation / G if G > 0 else 1.0]),
    }


def reward(
    phi_prev: float,
    f_prev: float,
    phi_cur: float,
    f_cur: float,
    progress: float,
    delta: float = DEFAULT_DELTA,
) -> float:
    """The paper's three-case reward (Eq. reward) from the best (phi, f) at g-1 and g.

    1. ``phi_cur > delta``: relative violation decrease (phi_prev - phi_cur) / phi_prev.
    2. ``phi_prev > delta >= phi_cur``: bonus 1 + exp(-g/G) for entering the feasible region.
    3. both <= delta: relative objective decrease (f_prev - f_cur) / |f_prev| (|.| so that a
       decrease is positive when f < 0). A zero or infinite denominator gives 0.
    """
    if phi_cur > delta:
        if phi_prev == 0 or not math.isfinite(phi_prev):
            return 0.0
        return float((phi_prev - phi_cur) / phi_prev)
    if phi_prev > delta:
        return 1.0 + math.exp(-progress)
    denom = abs(f_prev)
    if denom == 0 or not math.isfinite(denom):
        return 0.0
    return float((f_prev - f_cur) / denom)


def as_config(action: Any) -> Config:
    """Accept a Config, a (mutation, crossover, F, Cr) sequence or a dict with those keys."""
    if isinstance(action, Config):
        return action
    if isinstance(action, Mapping):
        return Config(action["mutation"], action["crossover"], action["F"], action["Cr"])
    mutation, crossover, F, Cr = action
    return Config(mutation, crossover, F, Cr)


class OptimizationEnv:
    """Gymnasium-style env over the DE core (no gymnasium dependency).

    ``reset(seed, options={"problem": p, "population": N, "budget": B})`` starts a run;
    options override the constructor's defaults. ``step(action)`` runs one generation.
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        problem: BoxProblem | None = None,
        *,
        population: int = 100,
        budget: int = 10_000,
        eta: float = DEFAULT_ETA,
        delta: float = DEFAULT_DELTA,
    ) -> None:
        self.problem = problem
        self.population = population
        self.budget = budget
        self.eta = eta
        self.delta = delta
        self.state: DEState | None = None
        self._seeder = np.random.default_rng()

    def reset(
        self, *, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start a new run; a given seed makes this and every later episode reproducible."""
        options = dict(options or {})
        if seed is not None:
            self._seeder = np.random.default_rng(seed)
        self.problem = options.pop("problem", self.problem)
        if self.problem is None:
            raise ValueError("no problem: pass options={'problem': ...} or give one to the env")
        self.population = int(options.pop("population", self.population))
        self.budget = int(options.pop("budget", self.budget))
        if options:
            raise ValueError(f"unknown reset options {sorted(options)}")
        run_seed = int(self._seeder.integers(0, 2**63 - 1))
        self.state = init(self.problem, run_seed, self.population, self.budget)
        return observe(self.state, self.eta), self._info(self.state)

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """One DE generation under ``action`` -> (obs, reward, terminated, truncated, info)."""
        state = self.state
        if state is None:
            raise RuntimeError("call reset() before step()")
        if state.done:
            raise RuntimeError("episode is over (budget spent); call reset()")
        trials = ask(state, as_config(action))
        f, phi = evaluate(self.problem, trials)
        new = tell(state, trials, f, phi)
        self.state = dataclasses.replace(new, memory=state.memory)
        r = reward(
            state.best_phi,
            state.best_f,
            new.best_phi,
            new.best_f,
            new.generation / max(new.max_generations, 1),
            self.delta,
        )
        return observe(new, self.eta), r, new.done, False, self._info(new)

    @staticmethod
    def _info(state: DEState) -> dict[str, Any]:
        return {
            "generation": state.generation,
            "evaluations": state.evaluations,
            "best_f": state.best_f,
            "best_phi": state.best_phi,
            "feasible_fraction": state.feasible_fraction,
        }
