"""One budget accounting for every optimiser: a problem wrapper that counts evaluated rows.

`BudgetedProblem` refuses any `evaluate` call that would go past the budget (so no optimiser can
overspend by accident), and keeps two incumbents as it goes: the best under Deb's rule (phi
first, then f) and the best under the penalised score f + 10 * phi. The convergence trace records
both after every call, so each optimiser reports the incumbent its own selection uses.
"""

from __future__ import annotations

from typing import Any, Literal, NamedTuple

import numpy as np

from planner_core.model.formulas import deb_best, deb_better, penalised_score

__all__ = ["BudgetExceeded", "BudgetedProblem", "Criterion", "Trace", "as_budgeted"]

Criterion = Literal["deb", "penalised"]


class BudgetExceeded(RuntimeError):
    """An optimiser asked for more evaluations than its budget allows (a bug in that optimiser)."""


class Trace(NamedTuple):
    """Convergence: after `evaluations[k]` evaluations the incumbent had `best_f[k]`,
    `best_phi[k]`."""

    evaluations: np.ndarray
    best_f: np.ndarray
    best_phi: np.ndarray

    @property
    def best_score(self) -> np.ndarray:
        """The incumbent's penalised score f + 10 * phi along the run."""
        return penalised_score(self.best_f, self.best_phi)


def _sanitise(v: Any, n: int) -> np.ndarray:
    a = np.array(v, dtype=float).reshape(-1)
    if a.shape != (n,):
        raise ValueError(f"evaluate returned shape {a.shape}, expected ({n},)")
    a[np.isnan(a)] = np.inf
    return a


class BudgetedProblem:
    """Wraps a problem (`lower`, `upper`, `evaluate`) with an evaluation counter and incumbents."""

    def __init__(self, problem: Any, budget: int):
        if int(budget) < 1:
            raise ValueError(f"budget must be a positive integer, got {budget!r}")
        self.problem = problem
        self.budget = int(budget)
        self.lower = np.asarray(problem.lower, dtype=float)
        self.upper = np.asarray(problem.upper, dtype=float)
        self.count = 0
        self._best: dict[str, tuple[np.ndarray | None, float, float]] = {
            "deb": (None, np.inf, np.inf),
            "penalised": (None, np.inf, np.inf),
        }
        self._trace: dict[str, list[tuple[int, float, float]]] = {"deb": [], "penalised": []}

    def __getattr__(self, name: str) -> Any:
        # everything else (map, dim, variable_length, breakdown, ...) comes from the problem
        if name == "problem":
            raise AttributeError(name)
        return getattr(self.problem, name)

    @property
    def remaining(self) -> int:
        """Evaluations still allowed."""
        return self.budget - self.count

    @property
    def exhausted(self) -> bool:
        return self.count >= self.budget

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Evaluate rows of X (problem space); raises BudgetExceeded instead of overspending."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n = X.shape[0]
        if n > self.remaining:
            raise BudgetExceeded(
                f"{n} evaluations requested with {self.remaining} of {self.budget} left"
            )
        if n == 0:
            return np.empty(0), np.empty(0)
        f, phi = self.problem.evaluate(X)
        f, phi = _sanitise(f, n), _sanitise(phi, n)
        self.count += n
        self._update(X, f, phi)
        return f, phi

    def _update(self, X: np.ndarray, f: np.ndarray, phi: np.ndarray) -> None:
        i = deb_best(f, phi)
        _, bf, bp = self._best["deb"]
        if deb_better(f[i], phi[i], bf, bp):
            self._best["deb"] = (X[i].copy(), float(f[i]), float(phi[i]))
        score = penalised_score(f, phi)
        j = int(np.argmin(score))
        _, bf, bp = self._best["penalised"]
        if score[j] < penalised_score(bf, bp):
            self._best["penalised"] = (X[j].copy(), float(f[j]), float(phi[j]))
        for key, (_, bf, bp) in self._best.items():
            self._trace[key].append((self.count, bf, bp))

    def best(self, criterion: Criterion) -> tuple[np.ndarray, float, float]:
        """The incumbent (x in problem space, f, phi) under Deb's rule or the penalised score."""
        x, f, phi = self._best[criterion]
        if x is None:
            raise RuntimeError("nothing has been evaluated yet")
        return x.copy(), f, phi

    def trace(self, criterion: Criterion) -> Trace:
        """The incumbent after every evaluate call, under the given criterion."""
        rows = self._trace[criterion]
        return Trace(
            evaluations=np.array([r[0] for r in rows], dtype=np.int64),
            best_f=np.array([r[1] for r in rows], dtype=float),
            best_phi=np.array([r[2] for r in rows], dtype=float),
        )


def as_budgeted(problem: Any, budget: int) -> BudgetedProblem:
    """`problem` itself when it already is a fresh BudgetedProblem with this budget, else a wrap."""
    if isinstance(problem, BudgetedProblem):
        if problem.budget != int(budget) or problem.count != 0:
            raise ValueError("a BudgetedProblem must be fresh and carry the same budget")
        return problem
    return BudgetedProblem(problem, budget)
