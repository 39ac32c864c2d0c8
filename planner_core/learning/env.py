"""The optimisation MDP of the paper (Sec. 4.2) as a :class:`gymnasium.Env`.

One step = one DE generation. Action = the per-individual configuration (a
:class:`~planner_core.search.de.core.Config`, a 4-tuple ``(mutation, crossover, F, Cr)`` or a dict
with
those keys). Observation (dict of numpy arrays, N = population, d = dimension):

=============  =========  ===========================================================
key            shape      meaning
=============  =========  ===========================================================
``"X"``        (N, d)     population normalised to the unit box
``"f"``        (N, 2)     (mantissa omega, scaled exponent b / eta) of each f
``"phi"``      (N, 2)     (mantissa omega, scaled exponent b / eta) of each phi
``"progress"`` (1,)       g / G (G = generations the budget allows)
``"context"``  (K,)       the run's memory (:func:`context`, K = :data:`N_CONTEXT`): each
                          (mutation, crossover) arm's recent success rate, stagnation,
                          feasible share of the population
=============  =========  ===========================================================

The context is what the ``adaptive`` configurator keeps in its memory, as features: per arm
(the 14 (mutation, crossover) pairs) an exponential moving average (rate
:data:`FEATURE_RATE`) of the share of its trials that replaced their parent, the generations
since a trial last Deb-beat the best parent (as ``s / (s + STALL_SCALE)``), and the feasible
share of the population. The env keeps it in the DE state's ``memory``
(:class:`FeatureMemory`); a policy configurator keeps the same memory through the
configurator protocol (``init`` / ``update``). A network trained without it (``NetConfig.
context == 0``, e.g. ``lamde-v2``) ignores it.

Mantissa-exponent encoding: ``y = omega * 10**b`` with ``b = floor(log10|y|) + 1`` so
``0.1 <= |omega| < 1``; ``y == 0 -> (0, 0)``; +-inf is encoded as (+-1, 400 / eta), one past
the largest finite double's exponent. ``eta = 10`` by default: objective and violation values
of interest span roughly 1e-10 .. 1e10 (flight times of 1e3..1e4 s, violations from 1e-8 up to
the collision offset mu + nu * metres), which then map to scaled exponents in [-1, 1].

Reward: :func:`reward` (the paper's Eq. reward) on the Deb-best (phi, f) before and after the
step, with feasibility tolerance ``delta = 1e-8`` by default (violations below it count as
feasible for the reward only; the DE's selection still compares phi exactly).

Per-individual credit (``info["credit"]``, (N,)): each trial's own outcome against its
parent, :func:`trial_credit` (scale-free: relative violation or objective decrease, a
feasibility gain ranked above any objective gain; 0 for a trial that did not replace its
parent); ``info["parent_feasible"]`` (N,) says which parents were feasible, and
``info["population_credit"]`` is the same credit of the generation's Deb-best change (best
before -> best after). The PPO learner's per-individual mode
(:class:`planner_core.learning.policy.ppo.PPOConfig` ``credit``) uses them; ``reward`` stays
the paper's.

Episode end: ``terminated`` is True once the evaluation budget is spent. Time is part of the
observation (g / G), so the budget's end is a true terminal state of this MDP, not a time
limit imposed from outside; ``truncated`` is always False (Gymnasium's semantics).

Spaces (Gymnasium): ``observation_space`` is a ``Dict`` of ``Box`` es with the shapes above
(X in [0, 1]; mantissa in [-1, 1]; scaled exponent in [-324 / eta, 400 / eta], the range of
finite doubles and the +-inf code; progress in [0, 1]); ``action_space`` is a ``Dict`` with
``mutation`` ``MultiDiscrete([7] * N)``, ``crossover`` ``MultiDiscrete([2] * N)``, ``F`` and
``Cr`` ``Box(0, 1, (N,))``. Both depend on the problem's dimension d and the population N, so
they are declared for the current problem and population: at construction when a problem is
given, and again at every ``reset`` (a vector env needs every sub-env to keep the same d and N).
The env is registered as ``"lamde/Optimization-v0"`` (``gymnasium.make(ENV_ID, problem=p)``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import gymnasium
import numpy as np
from gymnasium import spaces

from planner_core import defaults as _defaults
from planner_core.model.formulas import deb_best, deb_better
from planner_core.search.de.core import ask, evaluate, init, outcome, tell
from planner_core.search.de.operators import N_CROSSOVERS, N_MUTATIONS
from planner_core.search.de.types import BoxProblem, Config, DEState, Outcome

DEFAULT_ETA = _defaults.ETA
DEFAULT_DELTA = _defaults.DELTA
_INF_EXPONENT = 400.0  # beyond the largest finite double exponent (309)
_MIN_EXPONENT = -324.0  # b of the smallest subnormal double (4.9e-324), after rounding fix-ups
#: the id under which :class:`OptimizationEnv` is registered with Gymnasium
ENV_ID = "lamde/Optimization-v0"
_BELOW_ONE = float(np.nextafter(1.0, 0.0))


def mantissa_exponent(y: np.ndarray, eta: float = DEFAULT_ETA) -> np.ndarray:
    """Encode values as (omega, b / eta) pairs (see module doc): y = omega * 10**b with
    0.1 <= |omega| < 1; 0 -> (0, 0); +-inf -> (+-1, 400 / eta).

    Args:
        y: values, any shape (f or phi).
        eta: exponent scale.

    Returns:
        Array of shape ``y.shape + (2,)``: mantissa in [-1, 1], scaled exponent b / eta.
    """
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


#: arms of the context features: the (mutation, crossover) pairs, arm = N_CROSSOVERS * m + c
N_ARMS = N_MUTATIONS * N_CROSSOVERS
#: length of the observation's "context" vector: per-arm success, stagnation, feasible share
N_CONTEXT = N_ARMS + 2
#: moving-average rate of the per-arm success features (adaptive's ``rate``)
FEATURE_RATE = 0.2
#: stagnation s enters the context as s / (s + STALL_SCALE) (0 when improving, -> 1)
STALL_SCALE = 10.0
#: per-arm success before an arm has been tried (no evidence either way)
SUCCESS_PRIOR = 0.5


class FeatureMemory(NamedTuple):
    """The run's memory behind the observation's context (arrays are never mutated)."""

    arm_success: np.ndarray  # (N_ARMS,) moving average of each arm's trial success share
    stall: int = 0  # generations since a trial last Deb-beat the best parent


def initial_features() -> FeatureMemory:
    """The context memory of a run before its first generation.

    Returns:
        Every arm's success at ``SUCCESS_PRIOR``, ``stall`` 0.
    """
    return FeatureMemory(np.full(N_ARMS, SUCCESS_PRIOR), 0)


def update_features(
    memory: FeatureMemory,
    mutation: np.ndarray,
    crossover: np.ndarray,
    success: np.ndarray,
    improved: bool,
) -> FeatureMemory:
    """The memory after one generation (the rule of ``adaptive``'s memory, on success shares).

    Args:
        memory: the memory before the generation.
        mutation, crossover: (k,) operator ids of the k trials.
        success: (k,) bool, the trial replaced its parent (Deb's rule).
        improved: some trial Deb-beat the best parent.

    Returns:
        The next memory: each arm used this generation moves its success share by
        ``FEATURE_RATE`` towards this generation's; ``stall`` is reset or counts up.
    """
    arm = np.asarray(mutation, dtype=np.intp) * N_CROSSOVERS + np.asarray(crossover, np.intp)
    used = np.bincount(arm, minlength=N_ARMS)
    won = np.bincount(arm, weights=np.asarray(success, dtype=float), minlength=N_ARMS)
    seen = used > 0
    rate = memory.arm_success.copy()
    rate[seen] += FEATURE_RATE * (won[seen] / used[seen] - rate[seen])
    return FeatureMemory(rate, 0 if improved else memory.stall + 1)


def next_features(memory: FeatureMemory, out: Outcome) -> FeatureMemory:
    """:func:`update_features` from a generation's :class:`Outcome` (the env's step and the
    policy configurator's ``update`` both call this; "improved" is adaptive's rule: some trial
    Deb-beats the best of the generation's parents).

    Args:
        memory: the memory before the generation.
        out: the generation's outcome (its first k configuration entries are the k trials').

    Returns:
        The next memory; `memory` itself when the generation had no trials.
    """
    k = len(out.success)
    if k == 0:
        return memory
    b = deb_best(out.f_parent, out.phi_parent)
    improved = bool(deb_better(out.f_trial, out.phi_trial, out.f_parent[b],
                               out.phi_parent[b]).any())
    return update_features(memory, np.asarray(out.config.mutation)[:k],
                           np.asarray(out.config.crossover)[:k], out.success, improved)


def context(state: DEState, memory: FeatureMemory | None = None) -> np.ndarray:
    """The observation's context vector (N_CONTEXT,), all entries in [0, 1].

    Args:
        state: the DE state (its feasible share is read).
        memory: the context memory; None reads ``state.memory`` when it is a
            :class:`FeatureMemory` and otherwise uses :func:`initial_features`.

    Returns:
        ``[arm_success (N_ARMS), stall / (stall + STALL_SCALE), feasible_fraction]``.
    """
    if memory is None:
        memory = state.memory if isinstance(state.memory, FeatureMemory) else initial_features()
    stall = float(memory.stall)
    return np.concatenate([memory.arm_success, [stall / (stall + STALL_SCALE),
                                                state.feasible_fraction]])


def observe(state: DEState, eta: float = DEFAULT_ETA) -> dict[str, np.ndarray]:
    """The paper's state s_g for a DE state (pure; also usable by a policy configurator),
    with the context of :func:`context` (from ``state.memory`` when it is a FeatureMemory).

    Args:
        state: the DE state (population X in the unit box, f, phi, generation).
        eta: exponent scale of :func:`mantissa_exponent`.

    Returns:
        {"X": (N, d) copy, "f": (N, 2), "phi": (N, 2), "progress": (1,) g / G (1 when G = 0),
        "context": (N_CONTEXT,)} (module doc's table).
    """
    G = state.max_generations
    return {
        "X": np.array(state.X),
        "f": mantissa_exponent(state.f, eta),
        "phi": mantissa_exponent(state.phi, eta),
        "progress": np.array([state.generation / G if G > 0 else 1.0]),
        "context": context(state),
    }


def trial_credit(
    f_parent: np.ndarray,
    phi_parent: np.ndarray,
    f_trial: np.ndarray,
    phi_trial: np.ndarray,
    delta: float = DEFAULT_DELTA,
) -> np.ndarray:
    """Per-individual credit of each trial against its parent, scale-free, in [0, 2].

    * the trial does not Deb-beat its parent: 0 (the parent stays);
    * infeasible parent (phi_p > delta): ``1 + (phi_p - phi_t) / phi_p`` (in (1, 2]; 2 when the
      trial is feasible), so any violation gain ranks above any objective gain;
    * feasible parent: the relative objective decrease ``(f_p - f_t) / |f_p|``, at most 1.

    Args:
        f_parent, phi_parent, f_trial, phi_trial: (k,) arrays (objective, total violation).
        delta: feasibility tolerance (as :func:`reward`).

    Returns:
        (k,) float credits. Source: the per-individual credit of issue 34 (the paper's Eq.
        reward's cases, per trial instead of per population best).
    """
    fp, pp = np.asarray(f_parent, float), np.asarray(phi_parent, float)
    ft, pt = np.asarray(f_trial, float), np.asarray(phi_trial, float)
    win = deb_better(ft, pt, fp, pp)
    out = np.zeros(fp.shape)
    infeasible = pp > delta
    with np.errstate(divide="ignore", invalid="ignore"):
        gain_phi = np.where(pt <= delta, 1.0, (pp - pt) / pp)
        gain_f = (fp - ft) / np.abs(fp)
    gain_phi = np.where(np.isfinite(gain_phi), np.clip(gain_phi, 0.0, 1.0), 1.0)
    gain_f = np.where(np.isfinite(gain_f), np.clip(gain_f, 0.0, 1.0), 0.0)
    out[win & infeasible] = 1.0 + gain_phi[win & infeasible]
    out[win & ~infeasible] = gain_f[win & ~infeasible]
    return out


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
       decrease is positive when f < 0).

    Args:
        phi_prev: the best's total violation at g-1.
        f_prev: the best's objective at g-1.
        phi_cur: the best's total violation at g.
        f_cur: the best's objective at g.
        progress: g / G.
        delta: feasibility tolerance (violations below it count as feasible here only).

    Returns:
        The reward; 0 for a zero or infinite denominator (phi_prev in case 1, f_prev in
        case 3).
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
    """Accept a Config, a (mutation, crossover, F, Cr) sequence or a dict with those keys.

    Args:
        action: the per-individual configuration, one of those forms.

    Returns:
        The :class:`Config` (`action` itself when it is one).

    Raises:
        KeyError: a mapping without one of the four keys.
        ValueError: a sequence that is not of four items.
    """
    if isinstance(action, Config):
        return action
    if isinstance(action, Mapping):
        return Config(action["mutation"], action["crossover"], action["F"], action["Cr"])
    mutation, crossover, F, Cr = action
    return Config(mutation, crossover, F, Cr)


class OptimizationEnv(gymnasium.Env):
    """The paper's optimisation MDP over the DE core, a :class:`gymnasium.Env`.

    ``reset(seed, options={"problem": p, "population": N, "budget": B})`` starts a run;
    options override the constructor's defaults (``planner_core.defaults``) and re-declare the
    spaces. ``step(action)`` runs one generation. Seeding is Gymnasium's: ``reset(seed=s)``
    re-seeds :attr:`np_random`, from which each episode draws its DE run seed, so one seed
    fixes this and every later episode (same streams as ``np.random.default_rng(s)``).

    Attributes: ``problem``, ``population``, ``budget``, ``eta``, ``delta``, ``state`` (the
    current :class:`~planner_core.search.de.core.DEState`, None before the first reset),
    ``observation_space`` and ``action_space`` (absent until a problem is known).
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        problem: BoxProblem | None = None,
        *,
        population: int = _defaults.POPULATION,
        budget: int = _defaults.BUDGET,
        eta: float = DEFAULT_ETA,
        delta: float = DEFAULT_DELTA,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None:
            raise ValueError(f"render_mode: this env draws nothing, got {render_mode!r}")
        self.render_mode = render_mode
        self.problem = problem
        self.population = population
        self.budget = budget
        self.eta = eta
        self.delta = delta
        self.state: DEState | None = None
        if problem is not None:
            self._declare_spaces()

    def _declare_spaces(self) -> None:
        """Observation and action spaces for the current problem's dimension and population."""
        n, d = int(self.population), int(np.asarray(self.problem.lower).shape[0])
        code = spaces.Box(
            low=np.tile([-1.0, _MIN_EXPONENT / self.eta], (n, 1)),
            high=np.tile([1.0, _INF_EXPONENT / self.eta], (n, 1)),
            dtype=np.float64,
        )
        self.observation_space = spaces.Dict(
            {
                "X": spaces.Box(0.0, 1.0, (n, d), dtype=np.float64),
                "f": code,
                "phi": code,
                "progress": spaces.Box(0.0, 1.0, (1,), dtype=np.float64),
                "context": spaces.Box(0.0, 1.0, (N_CONTEXT,), dtype=np.float64),
            }
        )
        self.action_space = spaces.Dict(
            {
                "mutation": spaces.MultiDiscrete(np.full(n, N_MUTATIONS)),
                "crossover": spaces.MultiDiscrete(np.full(n, N_CROSSOVERS)),
                "F": spaces.Box(0.0, 1.0, (n,), dtype=np.float64),
                "Cr": spaces.Box(0.0, 1.0, (n,), dtype=np.float64),
            }
        )

    def reset(
        self, *, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start a new run; a given seed makes this and every later episode reproducible.

        Args:
            seed: re-seeds :attr:`np_random` (None: keep its stream).
            options: "problem", "population", "budget", each overriding the env's own.

        Returns:
            (observation, info): :func:`observe` of the initial population, and its "generation",
            "evaluations", "best_f", "best_phi", "feasible_fraction".

        Raises:
            ValueError: a missing problem, an unknown option, or a population/budget outside
                ``planner_core.defaults``' ranges (the message names the field).
        """
        super().reset(seed=seed)
        options = dict(options or {})
        problem = options.pop("problem", self.problem)
        if problem is None:
            raise ValueError("no problem: pass options={'problem': ...} or give one to the env")
        population = options.pop("population", self.population)
        budget = options.pop("budget", self.budget)
        if options:
            raise ValueError(f"unknown reset options {sorted(options)}")
        _defaults.check_run_args(population=population, budget=budget)
        self.problem, self.population, self.budget = problem, int(population), int(budget)
        self._declare_spaces()
        run_seed = int(self.np_random.integers(0, 2**63 - 1))
        state = init(self.problem, run_seed, self.population, self.budget)
        self.state = dataclasses.replace(state, memory=initial_features())
        return observe(self.state, self.eta), self._info(self.state)

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """One DE generation under ``action`` -> (obs, reward, terminated, truncated, info).

        Args:
            action: the per-individual configuration (:func:`as_config`'s forms), (N,) entries.

        Returns:
            (obs, reward, terminated, truncated, info): :func:`observe` after the generation;
            :func:`reward` on the Deb-best before and after; True once the budget is spent; always
            False; the reset's info plus "credit" (N,) (:func:`trial_credit`, 0 past the trials),
            "parent_feasible" (N,) bool and "population_credit" (float).

        Raises:
            RuntimeError: called before reset(), or after the episode is over (budget spent).
        """
        state = self.state
        if state is None:
            raise RuntimeError("call reset() before step()")
        if state.done:
            raise RuntimeError("episode is over (budget spent); call reset()")
        config = as_config(action)
        trials = ask(state, config)
        f, phi = evaluate(self.problem, trials)
        new = tell(state, trials, f, phi)
        out = outcome(state, config, trials, f, phi)
        k = len(out.success)
        memory = state.memory if isinstance(state.memory, FeatureMemory) else initial_features()
        self.state = dataclasses.replace(new, memory=next_features(memory, out))
        credit = np.zeros(state.population)
        credit[:k] = trial_credit(out.f_parent, out.phi_parent, out.f_trial, out.phi_trial,
                                  self.delta)
        r = reward(
            state.best_phi,
            state.best_f,
            new.best_phi,
            new.best_f,
            new.generation / max(new.max_generations, 1),
            self.delta,
        )
        info = self._info(new)
        info["credit"] = credit
        info["parent_feasible"] = state.phi <= self.delta
        info["population_credit"] = float(trial_credit(
            [state.best_f], [state.best_phi], [new.best_f], [new.best_phi], self.delta)[0])
        return observe(self.state, self.eta), r, bool(new.done), False, info

    @staticmethod
    def _info(state: DEState) -> dict[str, Any]:
        return {
            "generation": state.generation,
            "evaluations": state.evaluations,
            "best_f": state.best_f,
            "best_phi": state.best_phi,
            "feasible_fraction": state.feasible_fraction,
        }


if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="planner_core.learning.env:OptimizationEnv")
