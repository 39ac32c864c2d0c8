"""The DE's values: what it needs from a problem, the configuration (the paper's action), the
run state, a generation's outcome, and the configurator protocol. No behaviour beyond
properties, so the core, the run loop and the configurators all import from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol

import numpy as np

__all__ = [
    "BoxProblem",
    "Config",
    "Configurator",
    "DEState",
    "History",
    "Outcome",
    "Progress",
    "Result",
    "max_generations",
]


class BoxProblem(Protocol):
    """What the DE needs from a problem (the UAV Problem and synthetic problems both fit).

    Optional hook: ``initial_population(rng, n) -> (n, d)`` problem-space starting points (not
    evaluated by the hook); :func:`init` uses it with the run's own seeded generator.
    """

    lower: np.ndarray
    upper: np.ndarray

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Score points.

        Args:
            X: points (n, d) in problem space.

        Returns:
            (f (n,), phi (n,)): objective and constraint violation (0: feasible).
        """
        ...


class Config(NamedTuple):
    """Per-individual configuration (the paper's action): each field has shape (N,).

    ``mutation`` ids 0..6 (see operators.MUTATIONS), ``crossover`` 0 = bin / 1 = exp,
    ``F`` and ``Cr`` in [0, 1] (values outside are clipped).
    """

    mutation: np.ndarray
    crossover: np.ndarray
    F: np.ndarray
    Cr: np.ndarray


@dataclass(frozen=True, eq=False)
class DEState:
    """Everything a DE run is: population in the unit box, its f and phi (read-only arrays),
    Deb-best index, counters, the run's seed and budget, and opaque configurator memory."""

    X: np.ndarray
    f: np.ndarray
    phi: np.ndarray
    best: int
    generation: int
    evaluations: int
    budget: int
    seed: int
    memory: Any = None

    @property
    def population(self) -> int:
        """N.

        Returns:
            The population size, rows of X.
        """
        return int(self.X.shape[0])

    @property
    def dim(self) -> int:
        """d.

        Returns:
            The dimension, columns of X.
        """
        return int(self.X.shape[1])

    @property
    def max_generations(self) -> int:
        """G: the number of generations the budget allows after the initial population.

        Returns:
            `max_generations(population, budget)`.
        """
        return max_generations(self.population, self.budget)

    @property
    def done(self) -> bool:
        """Whether the budget is spent.

        Returns:
            True when evaluations >= budget.
        """
        return self.evaluations >= self.budget

    @property
    def best_f(self) -> float:
        """The Deb-best individual's objective.

        Returns:
            f[best].
        """
        return float(self.f[self.best])

    @property
    def best_phi(self) -> float:
        """The Deb-best individual's violation.

        Returns:
            phi[best].
        """
        return float(self.phi[self.best])

    @property
    def feasible_fraction(self) -> float:
        """The share of the population that is feasible.

        Returns:
            Individuals with phi == 0 over N, in [0, 1].
        """
        return float(np.count_nonzero(self.phi == 0.0)) / self.population


class Outcome(NamedTuple):
    """What one generation did, for configurators that learn (rows = the k trials)."""

    config: Config  # the configuration used (all N rows; only the first k produced trials)
    parents: np.ndarray  # (k, d) unit-box parents
    trials: np.ndarray  # (k, d) unit-box trials
    f_parent: np.ndarray
    phi_parent: np.ndarray
    f_trial: np.ndarray
    phi_trial: np.ndarray
    success: np.ndarray  # (k,) bool: the trial replaced its parent (Deb's rule)
    evaluations: int  # after this generation
    budget: int


class Progress(NamedTuple):
    """Small record handed to ``run``'s callback once per generation (0 = initial population)."""

    generation: int
    evaluations: int
    budget: int
    best_f: float
    best_phi: float
    feasible_fraction: float


class History(NamedTuple):
    """Per-generation trace, entry 0 = initial population; arrays of length generations + 1."""

    evaluations: np.ndarray
    best_f: np.ndarray
    best_phi: np.ndarray
    feasible_fraction: np.ndarray


@dataclass(frozen=True)
class Result:
    """Outcome of :func:`run`: best solution in problem space with its f and phi."""

    x: np.ndarray
    f: float
    phi: float
    evaluations: int
    generations: int
    history: History
    state: DEState

    @property
    def feasible(self) -> bool:
        """Whether the best solution is feasible.

        Returns:
            True when phi == 0.
        """
        return self.phi == 0.0


class Configurator(Protocol):
    """Chooses the per-individual configuration; may learn through an immutable memory value.

    ``init(state)`` returns the initial memory (None if stateless), ``configure(state, rng)``
    reads ``state.memory`` and returns a :class:`Config`, ``update(memory, outcome)`` returns the
    next memory. The core never looks inside the memory.
    """

    def init(self, state: DEState) -> Any:
        """The initial memory.

        Args:
            state: the run's initial state (population evaluated, no memory yet).

        Returns:
            The memory value (None if stateless).
        """
        ...

    def configure(self, state: DEState, rng: np.random.Generator) -> Config:
        """The generation's configuration.

        Args:
            state: the run's state (`memory` read).
            rng: the generation's generator, after ask's words (valid during the call only).

        Returns:
            A `Config` of (N,) arrays.
        """
        ...

    def update(self, memory: Any, outcome: Outcome) -> Any:
        """Learn from a generation.

        Args:
            memory: the current memory (never mutated).
            outcome: what the generation did.

        Returns:
            The next memory.
        """
        ...


def max_generations(population: int, budget: int) -> int:
    """G = ceil((budget - N) / N): generations after the initial population.

    Args:
        population: N, > 0.
        budget: evaluations in all.

    Returns:
        G, >= 0.
    """
    return max(0, math.ceil((budget - population) / population))
