"""Ask/tell Differential Evolution over one immutable state value, with Deb's feasibility rule.

The search runs in the unit box: ``x = lower + u * (upper - lower)``; trial vectors are clamped
to [0, 1] (the paper's value clamping). The randomness of generation g is a pure function of
``(state.seed, g)``: a PCG64 stream (:class:`Streams`, :func:`generation_rng`). Its
first raw words are ask's (how many depends only on the population and dimension, not on the
configuration); a configurator draws from the same generator after them. So ``ask`` is pure,
``step`` gives the same trials as ``configure`` then ``ask``, and a run is reproducible bit for
bit from its seed.

This module is the core (init / ask / tell / step over one state value, Deb's rule from
`planner_core.model.formulas`); it takes configurator objects and knows no registry: `de.loop.run`
resolves
names. Values live in `de.types`, random streams in `de.rng`.

Budget: the initial population (N evaluations) counts. Each generation evaluates
``k = min(N, budget - evaluations)`` trials; when ``k < N`` (the last generation) only
individuals ``0..k-1`` (population order) produce trials, the others are carried unchanged.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner_core.defaults import BUDGET, MIN_POPULATION, POPULATION
from planner_core.model.formulas import deb_best, deb_better
from planner_core.search.de import fast
from planner_core.search.de.operators import (
    crossover_words,
    donor_words,
)
from planner_core.search.de.rng import Streams, generation_rng
from planner_core.search.de.types import BoxProblem, Config, Configurator, DEState, Outcome

__all__ = [
    "ask", "ask_words", "evaluate", "init", "outcome", "sanitise_evaluation", "step", "tell",
    "to_problem", "to_unit", "trial_count", "validate_config",
]  # fmt: skip


# --------------------------------------------------------------------------- evaluation results


def sanitise_evaluation(f: Any, phi: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A problem's `evaluate` results made safe for Deb's rule: NaN -> +inf, so that a broken
    evaluation never wins a comparison (the DE's and the pipeline's `Evaluator`'s one rule).

    Args:
        f: the n objective values (any shape of n numbers).
        phi: the n constraint violations.
        n: how many solutions were evaluated.

    Returns:
        f and phi as float arrays (n,); copied only when a NaN must be replaced (the caller's
        arrays are never written).

    Raises:
        ValueError: f or phi does not hold n values.
    """
    f = np.asarray(f, dtype=float).reshape(-1)
    phi = np.asarray(phi, dtype=float).reshape(-1)
    if f.shape != (n,) or phi.shape != (n,):
        raise ValueError(f"evaluate returned shapes {f.shape}, {phi.shape}; expected ({n},)")
    if np.isnan(f).any():
        f = np.where(np.isnan(f), np.inf, f)
    if np.isnan(phi).any():
        phi = np.where(np.isnan(phi), np.inf, phi)
    return f, phi


_KEEP = object()  # _select's default: keep the configurator memory


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


# --------------------------------------------------------------------------- ask / tell


def ask_words(state: DEState, rng: np.random.Generator | None = None) -> np.ndarray:
    """The raw 64-bit words ask splits into donors and crossover draws: the first
    ``donor_words(k) + crossover_words(k, d)`` of the generation's generator.

    Args:
        state: the state before the generation (k = :func:`trial_count`, d its dimension).
        rng: when given, that generator, fresh (None: :func:`generation_rng` of the state).

    Returns:
        (donor_words(k) + crossover_words(k, d),) uint64 words.
    """
    k, d = trial_count(state), state.dim
    rng = generation_rng(state) if rng is None else rng
    return rng.bit_generator.random_raw(donor_words(k) + crossover_words(k, d))


def to_problem(problem: BoxProblem, U: np.ndarray) -> np.ndarray:
    """Map unit-box points to the problem's bounds: lower + u * (upper - lower).

    Args:
        problem: its `lower` and `upper` (d,) read.
        U: unit-box points (..., d).

    Returns:
        Problem-space points, U's shape.
    """
    lower = np.asarray(problem.lower, dtype=float)
    out = np.multiply(U, np.asarray(problem.upper, dtype=float) - lower)
    out += lower
    return out


def to_unit(problem: BoxProblem, X: np.ndarray) -> np.ndarray:
    """Map problem-space points into the unit box, clamped (a zero-width bound maps to 0).

    Args:
        problem: its `lower` and `upper` (d,) read.
        X: problem-space points (..., d).

    Returns:
        Unit-box points in [0, 1], X's shape.
    """
    lower = np.asarray(problem.lower, dtype=float)
    span = np.asarray(problem.upper, dtype=float) - lower
    U = (np.asarray(X, dtype=float) - lower) / np.where(span > 0, span, 1.0)
    return np.clip(np.where(span > 0, U, 0.0), 0.0, 1.0)


def init(
    problem: BoxProblem, seed: int, population: int = POPULATION, budget: int = BUDGET
) -> DEState:
    """Initial population in the unit box, evaluated (these N evaluations count).

    Uniform, unless the problem offers `initial_population(rng, n)` (problem-space points,
    e.g. the UAV problem's sensor-aware starts); those are clamped into the box.

    Args:
        problem: the problem (`lower`, `upper`, `evaluate`, optional `initial_population`).
        seed: the run's seed, >= 0.
        population: N, >= `MIN_POPULATION`.
        budget: evaluations in all, >= N.

    Returns:
        The `DEState` at generation 0 (N evaluations, no configurator memory).

    Raises:
        ValueError: population < `MIN_POPULATION`, budget < population, a negative seed,
            an `initial_population` of another shape than (N, d), or `evaluate` results
            that do not hold N values.
    """
    if population < MIN_POPULATION:
        raise ValueError(f"population must be >= {MIN_POPULATION}, got {population}")
    if budget < population:
        raise ValueError(f"budget {budget} smaller than the population {population}")
    seed = int(seed)
    if seed < 0:
        raise ValueError("seed must be a non-negative integer")
    d = int(np.asarray(problem.lower).shape[0])
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(2**32,))))
    sampler = getattr(problem, "initial_population", None)
    if sampler is None:
        X = rng.random((population, d))
    else:
        X = to_unit(problem, sampler(rng, population))
        if X.shape != (population, d):
            raise ValueError(f"initial_population gave shape {X.shape}, not ({population}, {d})")
    f, phi = sanitise_evaluation(*problem.evaluate(to_problem(problem, X)), population)
    return DEState(
        X=_frozen(X),
        f=_frozen(f.copy()),
        phi=_frozen(phi.copy()),
        best=deb_best(f, phi),
        generation=0,
        evaluations=population,
        budget=int(budget),
        seed=seed,
    )


def trial_count(state: DEState) -> int:
    """How many trials the next generation evaluates.

    Args:
        state: the state before the generation.

    Returns:
        k = min(N, budget - evaluations), >= 0.
    """
    return max(0, min(state.population, state.budget - state.evaluations))


def validate_config(config: Config, n: int) -> Config:
    """Coerce a configuration to (n,) arrays of ids and rates. The values are checked where they
    are used (`fast.ask`): ids in range, F and Cr not NaN (and clipped to [0, 1]).

    Args:
        config: the configuration (array-likes).
        n: the population size.

    Returns:
        A `Config`: mutation and crossover (n,) intp, F and Cr (n,) float.

    Raises:
        ValueError: a field that does not hold n values.
    """
    mut = np.asarray(config.mutation, dtype=np.intp).reshape(-1)
    cx = np.asarray(config.crossover, dtype=np.intp).reshape(-1)
    F = np.asarray(config.F, dtype=float).reshape(-1)
    Cr = np.asarray(config.Cr, dtype=float).reshape(-1)
    for name, a in (("mutation", mut), ("crossover", cx), ("F", F), ("Cr", Cr)):
        if a.shape != (n,):
            raise ValueError(f"config.{name} has shape {a.shape}, expected ({n},)")
    return Config(mut, cx, F, Cr)


def ask(state: DEState, config: Config, words: np.ndarray | None = None) -> np.ndarray:
    """Trial vectors (k, d) in the unit box for individuals 0..k-1 (k = :func:`trial_count`).

    Args:
        state: the state before the generation.
        config: the generation's `Config` ((N,) fields).
        words: :func:`ask_words` of this state, when the caller already drew them (None:
            drawn here).

    Returns:
        (k, d) trials clamped to [0, 1]; (0, d) when the budget is spent.

    Raises:
        ValueError: a config field that does not hold N values, an id out of range, a NaN
            F or Cr, `words` of the wrong length, or N < 6 (`fast.ask`).
    """
    return _ask(state, config, words)


def _ask(
    state: DEState,
    config: Config,
    words: np.ndarray | None,
    problem: BoxProblem | None = None,
) -> Any:
    """`ask`; given ``problem``, also the trials mapped to its box (one pass, as to_problem)."""
    k = trial_count(state)
    n, d = state.X.shape
    if k == 0:
        return np.empty((0, d)) if problem is None else (np.empty((0, d)), np.empty((0, d)))
    config = validate_config(config, n)
    bounds = None
    if problem is not None:
        lower = np.asarray(problem.lower, dtype=float)
        bounds = (lower, np.asarray(problem.upper, dtype=float) - lower)
    # the compiled twin of draw_donors, draw_crossover, then clip(crossover(x, mutate(...)))
    # from operators.py: the same draws and trials, bit for bit (tests/test_de_fast.py)
    return fast.ask(
        ask_words(state) if words is None else words, state.X, config.mutation[:k],
        config.F[:k], state.best, config.crossover[:k], config.Cr[:k], bounds,
    )  # fmt: skip


def tell(state: DEState, trials: np.ndarray, f: np.ndarray, phi: np.ndarray) -> DEState:
    """Deb selection of trials against parents 0..k-1.

    Args:
        state: the state before the generation.
        trials: (k, d) unit-box trials.
        f: their objectives (k values).
        phi: their violations (k values).

    Returns:
        A new `DEState` one generation on (k more evaluations), each winning trial in its
        parent's place.

    Raises:
        ValueError: f or phi does not hold k values.
    """
    k = trials.shape[0]
    f_t, phi_t = sanitise_evaluation(f, phi, k)
    return _select(state, trials, f_t, phi_t, deb_better(f_t, phi_t, state.f[:k], state.phi[:k]))


def _select(
    state: DEState,
    trials: np.ndarray,
    f_t: np.ndarray,
    phi_t: np.ndarray,
    win: np.ndarray,
    memory: Any = _KEEP,
) -> DEState:
    """`tell` after the Deb comparison: replace the winning parents, one generation on
    (``memory``: the next state's configurator memory, by default the current one)."""
    k = trials.shape[0]
    X, fn, phin = state.X.copy(), state.f.copy(), state.phi.copy()
    np.copyto(X[:k], trials, where=win[:, None])
    np.copyto(fn[:k], f_t, where=win)
    np.copyto(phin[:k], phi_t, where=win)
    return DEState(
        X=_frozen(X),
        f=_frozen(fn),
        phi=_frozen(phin),
        best=deb_best(fn, phin),
        generation=state.generation + 1,
        evaluations=state.evaluations + k,
        budget=state.budget,
        seed=state.seed,
        memory=state.memory if memory is _KEEP else memory,
    )


def outcome(
    state: DEState, config: Config, trials: np.ndarray, f: np.ndarray, phi: np.ndarray
) -> Outcome:
    """The generation's outcome for ``update`` hooks.

    Args:
        state: the state before ``tell``.
        config: the generation's `Config` (all N rows).
        trials: (k, d) unit-box trials.
        f: their objectives (k values; NaN read as inf).
        phi: their violations (k values; NaN read as inf).

    Returns:
        The `Outcome` (its `success`: the trial Deb-beats its parent).

    Raises:
        ValueError: f or phi does not hold k values.
    """
    k = trials.shape[0]
    f_t, phi_t = sanitise_evaluation(f, phi, k)
    f_p, phi_p = state.f[:k], state.phi[:k]
    return Outcome(
        config=config,
        parents=state.X[:k],
        trials=trials,
        f_parent=f_p,
        phi_parent=phi_p,
        f_trial=f_t,
        phi_trial=phi_t,
        success=deb_better(f_t, phi_t, f_p, phi_p),
        evaluations=state.evaluations + k,
        budget=state.budget,
    )


def evaluate(problem: BoxProblem, trials: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Evaluate unit-box trials on the problem (mapped to its bounds).

    Args:
        problem: the problem.
        trials: (k, d) unit-box points.

    Returns:
        The problem's (f, phi) as it returns them (not sanitised); two empty arrays for
        k = 0.
    """
    if trials.shape[0] == 0:
        return np.empty(0), np.empty(0)
    return problem.evaluate(to_problem(problem, trials))


def step(
    state: DEState,
    problem: BoxProblem,
    configurator: Configurator,
    streams: Streams | None = None,
) -> tuple[DEState, Outcome]:
    """One generation: configure, ask, evaluate, tell, and feed the outcome to the configurator.

    The generator handed to ``configure`` is valid during that call only.

    Args:
        state: the state before the generation.
        problem: the problem (its `evaluate` called once with the k trials; not for k = 0).
        configurator: the configurator (`configure`, `update`).
        streams: a :class:`Streams` of ``state.seed`` to reuse across generations (same
            result, less overhead; None or another seed's: a new one).

    Returns:
        (the next `DEState`, carrying `update`'s memory; the generation's `Outcome`).

    Raises:
        ValueError: as :func:`ask`, or evaluate results that do not hold k values.
    """
    if streams is None or streams.seed != state.seed:
        streams = Streams(state.seed)
    rng = streams.rng(state.generation)
    words = ask_words(state, rng)  # ask's words come first, the configurator draws after them
    config = configurator.configure(state, rng)
    trials, points = _ask(state, config, words, problem)
    f, phi = problem.evaluate(points) if len(points) else (np.empty(0), np.empty(0))
    out = outcome(state, config, trials, f, phi)
    # the outcome already holds the sanitised values and Deb's verdict: select with them
    memory = configurator.update(state.memory, out)
    return _select(state, trials, out.f_trial, out.phi_trial, out.success, memory), out


