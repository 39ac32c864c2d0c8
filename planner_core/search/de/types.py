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

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


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
        return int(self.X.shape[0])

    @property
    def dim(self) -> int:
        return int(self.X.shape[1])

    @property
    def max_generations(self) -> int:
        """G: the number of generations the budget allows after the initial population."""
        return max_generations(self.population, self.budget)

    @property
    def done(self) -> bool:
        return self.evaluations >= self.budget

    @property
    def best_f(self) -> float:
        return float(self.f[self.best])

    @property
    def best_phi(self) -> float:
        return float(self.phi[self.best])

    @property
    def feasible_fraction(self) -> float:
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
        return self.phi == 0.0


class Configurator(Protocol):
    """Chooses the per-individual configuration; may learn through an immutable memory value.

    ``init(state)`` returns the initial memory (None if stateless), ``configure(state, rng)``
    reads ``state.memory`` and returns a :class:`Config`, ``update(memory, outcome)`` returns the
    next memory. The core never looks inside the memory.
    """

    def init(self, state: DEState) -> Any: ...

    def configure(self, state: DEState, rng: np.random.Generator) -> Config: ...

    def update(self, memory: Any, outcome: Outcome) -> Any: ...


def max_generations(population: int, budget: int) -> int:
    """G = ceil((budget - N) / N): generations after the initial population."""
    return max(0, math.ceil((budget - population) / population))
