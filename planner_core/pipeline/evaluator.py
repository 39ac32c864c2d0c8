"""The one counted evaluator: every evaluation of a plan or a benchmark run goes through it.

`Evaluator` wraps a problem (`lower`, `upper`, `evaluate(X) -> (f, phi)`) and owns the budget
and an optional wall-clock limit (cf. pymoo, where the algorithm's termination and its counted
evaluator are one object):

* it refuses any `evaluate` call that would go past the budget (`BudgetExceeded`: a bug in the
  caller) or past the allotment of the stage running (`stage`);
* once its time limit has passed it refuses further calls with `TimeLimitReached` (after at
  least one row has been evaluated, so there is always an incumbent): the pipeline catches it
  and returns the incumbent;
* it keeps two incumbents as it goes, the best under Deb's rule (phi first, then f) and the
  best under the penalised score f + 10 * phi, and their trace after every call, so a run's
  answer is the best of everything it evaluated and no count is added up by hand;
* it records per stage (`stage(name, allotment)`) the evaluations, the seconds spent inside
  `evaluate` and the incumbent before and after (`records`).

Every attribute it does not define (`map`, `breakdown`, `initial_population`, ...) is the wrapped
problem's. Cost: one Deb comparison per evaluated row on top of the problem's own evaluation.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

import numpy as np

from planner_core.model.formulas import deb_best, deb_better, penalised_score
from planner_core.search.de.core import sanitise_evaluation

__all__ = [
    "BudgetExceeded",
    "Criterion",
    "Evaluator",
    "Progress",
    "StageRecord",
    "TimeLimitReached",
    "Trace",
    "as_evaluator",
]

Criterion = Literal["deb", "penalised"]


class BudgetExceeded(RuntimeError):
    """A caller asked for more evaluations than the budget (or its stage's allotment) allows:
    a bug in that caller, never a user error."""


class TimeLimitReached(RuntimeError):
    """The evaluator's wall-clock limit has passed: no further evaluation is allowed."""


class Trace(NamedTuple):
    """Convergence: after `evaluations[k]` evaluations the incumbent had `best_f[k]`,
    `best_phi[k]`."""

    evaluations: np.ndarray
    best_f: np.ndarray
    best_phi: np.ndarray

    @property
    def best_score(self) -> np.ndarray:
        """The incumbent's penalised score f + 10 * phi along the run.

        Returns:
            (k,) float, one entry per `evaluations` entry.
        """
        return penalised_score(self.best_f, self.best_phi)


class Progress(NamedTuple):
    """What a progress callback receives after every evaluate call: the stage running, the
    evaluations spent of the budget, the Deb incumbent's f and phi (inf before the first
    evaluation), seconds since the start; `detail`: what a stage that works long between
    evaluations has done so far (`Evaluator.report`, e.g. "12/64 plans"), else ""."""

    stage: str
    evaluations: int
    budget: int
    best_f: float
    best_phi: float
    seconds: float
    detail: str = ""


@dataclass(frozen=True)
class StageRecord:
    """One stage of a run: its name, the evaluations it was allotted and spent, its wall time
    (s, everything it did) and the part of it inside `evaluate`, and the Deb incumbent's f and
    phi before and after it; `stopped`: why it ended early ("time limit", or "" when it ran
    to its end)."""

    name: str
    allotted: int
    evaluations: int
    seconds: float
    evaluate_seconds: float
    f_before: float
    phi_before: float
    f_after: float
    phi_after: float
    stopped: str = ""

    @property
    def gain(self) -> float:
        """The stage's improvement of the incumbent's objective.

        Returns:
            f before - f after when both are feasible (s of the objective; 0 when the stage
            found nothing better), nan when either is infeasible.
        """
        if self.phi_before > 0 or self.phi_after > 0:
            return float("nan")
        return float(self.f_before - self.f_after)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields.

        Returns:
            {field: value}; non-finite floats (the f and phi of no incumbent yet) as None.
        """
        out: dict[str, Any] = {}
        for k, v in self.__dict__.items():
            out[k] = None if isinstance(v, float) and not np.isfinite(v) else v
        return out


class Evaluator:
    """Wraps a problem with an evaluation counter, a budget, an optional time limit, incumbents
    and per-stage records (module docstring).

    Args:
        problem: anything with `lower`, `upper` (d,) and `evaluate(X (n, d)) -> (f, phi)`.
        budget: evaluations allowed in all, >= 1.
        time_limit: seconds from construction after which `evaluate` raises
            `TimeLimitReached` (None: no limit).
        progress: called with a `Progress` after every evaluate call (None: nothing).

    Raises:
        ValueError: budget < 1 or a non-positive time limit.
    """

    def __init__(self, problem: Any, budget: int, *, time_limit: float | None = None,
                 progress: Callable[[Progress], None] | None = None):
        if int(budget) < 1:
            raise ValueError(f"budget: must be a positive integer, got {budget!r}")
        if time_limit is not None and not (float(time_limit) > 0.0):
            raise ValueError(f"time_limit: must be a number of seconds > 0, got {time_limit!r}")
        self.problem = problem
        self.budget = int(budget)
        self.lower = np.asarray(problem.lower, dtype=float)
        self.upper = np.asarray(problem.upper, dtype=float)
        self.count = 0
        self.time_limit = None if time_limit is None else float(time_limit)
        self.t0 = time.perf_counter()
        self.progress = progress
        self._best: dict[str, tuple[np.ndarray | None, float, float]] = {
            "deb": (None, np.inf, np.inf),
            "penalised": (None, np.inf, np.inf),
        }
        self._trace: dict[str, list[tuple[int, float, float]]] = {"deb": [], "penalised": []}
        self.records: list[StageRecord] = []
        self.evaluate_seconds = 0.0
        self._stage: str = ""
        self._stage_end: int | None = None  # count at which the running stage's allotment ends

    def __getattr__(self, name: str) -> Any:
        # everything else (map, dim, variable_length, breakdown, ...) comes from the problem
        if name == "problem":
            raise AttributeError(name)
        return getattr(self.problem, name)

    # ------------------------------------------------------------------ budget and clock
    @property
    def remaining(self) -> int:
        """Evaluations still allowed: of the budget, and of the running stage's allotment.

        Returns:
            The smaller of the two, >= 0.
        """
        left = self.budget - self.count
        if self._stage_end is not None:
            left = min(left, self._stage_end - self.count)
        return max(left, 0)

    @property
    def exhausted(self) -> bool:
        """Whether no evaluation is left.

        Returns:
            True when `remaining` is 0 (of the budget or of the stage).
        """
        return self.remaining <= 0

    @property
    def elapsed(self) -> float:
        """The run's clock.

        Returns:
            Seconds since the evaluator was made (`time.perf_counter`).
        """
        return time.perf_counter() - self.t0

    @property
    def expired(self) -> bool:
        """Whether the time limit has passed.

        Returns:
            True once `elapsed` >= `time_limit`; always False without a limit.
        """
        return self.time_limit is not None and self.elapsed >= self.time_limit

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Evaluate plans, counting them against the budget and keeping the incumbents.

        Args:
            X: decision vectors in problem space, (n, d) (one (d,) row is read as (1, d));
                n = 0 evaluates nothing and counts nothing.

        Returns:
            (f, phi): the objective (s, the paper's Eq. 3 weighted time) and the violation
            (Eq. 7) of each row, (n,) each; NaN read as +inf.

        Raises:
            BudgetExceeded: n exceeds `remaining`.
            TimeLimitReached: the time limit has passed and something was evaluated before.
            ValueError: the problem returned f or phi of another shape than (n,).
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        n = X.shape[0]
        self._check_room(n, "requested")
        if n == 0:
            return np.empty(0), np.empty(0)
        if self.count and self.expired:
            raise TimeLimitReached(f"time limit of {self.time_limit:g} s reached")
        t0 = time.perf_counter()
        f, phi = self.problem.evaluate(X)
        self.evaluate_seconds += time.perf_counter() - t0
        # own copies (the problem's arrays are never handed on), NaN -> +inf
        f, phi = sanitise_evaluation(np.array(f, dtype=float), np.array(phi, dtype=float), n)
        self.count += n
        self._update(X, f, phi)
        if self.progress is not None:
            _, bf, bp = self._best["deb"]
            self.progress(Progress(self._stage, self.count, self.budget, bf, bp, self.elapsed))
        return f, phi

    def charge(self, n: int) -> None:
        """Count evaluations made on the run's behalf of another problem: a part of the map
        planned by its own pipeline run (`planner_core.pipeline.windows`), whose plans are not
        this problem's; nothing else changes (incumbents, trace).

        Args:
            n: the evaluations to count (n <= 0 counts nothing).

        Raises:
            BudgetExceeded: n exceeds `remaining`.
        """
        n = int(n)
        self._check_room(n, "charged")
        self.count += max(n, 0)

    def _check_room(self, n: int, verb: str) -> None:
        """Raise `BudgetExceeded` ("{n} evaluations {verb} ...") when n exceeds `remaining`."""
        if n > self.remaining:
            where = f" in stage {self._stage!r}" if self._stage else ""
            raise BudgetExceeded(f"{n} evaluations {verb}{where} with {self.remaining} of "
                                 f"{self.budget} left")

    def _update(self, X: np.ndarray, f: np.ndarray, phi: np.ndarray) -> None:
        if len(f) == 1:  # the descents' one-row calls: the same rules on scalars
            self._update_one(X[0], float(f[0]), float(phi[0]))
            return
        i = deb_best(f, phi)
        bx, bf, bp = self._best["deb"]
        if bx is None or deb_better(f[i], phi[i], bf, bp):
            self._best["deb"] = (X[i].copy(), float(f[i]), float(phi[i]))
        score = penalised_score(f, phi)
        j = int(np.argmin(score))
        bx, bf, bp = self._best["penalised"]
        if bx is None or score[j] < penalised_score(bf, bp):
            self._best["penalised"] = (X[j].copy(), float(f[j]), float(phi[j]))
        for key, (_, bf, bp) in self._best.items():
            self._trace[key].append((self.count, bf, bp))

    def _update_one(self, x: np.ndarray, f: float, phi: float) -> None:
        bx, bf, bp = self._best["deb"]
        if bx is None or deb_better(f, phi, bf, bp):
            self._best["deb"] = (x.copy(), f, phi)
        bx, bf, bp = self._best["penalised"]
        if bx is None or penalised_score(f, phi) < penalised_score(bf, bp):
            self._best["penalised"] = (x.copy(), f, phi)
        for key, (_, bf, bp) in self._best.items():
            self._trace[key].append((self.count, bf, bp))

    # ------------------------------------------------------------------ incumbents
    def report(self, detail: str) -> None:
        """Tell the progress callback (if any) what the running stage has done so far, between
        evaluations: a stage that builds for seconds before it evaluates (the constructive
        plans on hundreds of sensors) calls this after each step. Counts nothing.

        Args:
            detail: what the stage has done, e.g. "12/64 plans" (`Progress.detail`).
        """
        if self.progress is not None:
            _, bf, bp = self._best["deb"]
            bf, bp = (bf, bp) if self.has_best else (math.inf, math.inf)
            self.progress(Progress(self._stage, self.count, self.budget, bf, bp, self.elapsed,
                                   detail))

    @property
    def has_best(self) -> bool:
        """Whether anything has been evaluated.

        Returns:
            True once an evaluated row is the Deb incumbent (any non-empty evaluate call).
        """
        return self._best["deb"][0] is not None

    def best(self, criterion: Criterion = "deb") -> tuple[np.ndarray, float, float]:
        """The best plan evaluated so far.

        Args:
            criterion: "deb" (Deb's rule, paper Eq. 8: phi first, then f) or "penalised"
                (f + 10 * phi, Sec. 5.2).

        Returns:
            (x, f, phi): its decision vector (d,) in problem space (a copy), its objective (s)
            and its violation.

        Raises:
            RuntimeError: no evaluated row has become an incumbent under `criterion` yet.
        """
        x, f, phi = self._best[criterion]
        if x is None:
            raise RuntimeError("nothing has been evaluated yet")
        return x.copy(), f, phi

    def trace(self, criterion: Criterion = "deb") -> Trace:
        """The incumbent after every evaluate call (a call of no rows adds nothing).

        Args:
            criterion: "deb" or "penalised", as for `best`.

        Returns:
            The `Trace`: evaluations (k,) int64 and the incumbent's best_f (k,) s and best_phi
            (k,), one entry per call (inf before any incumbent).
        """
        rows = self._trace[criterion]
        return Trace(
            evaluations=np.array([r[0] for r in rows], dtype=np.int64),
            best_f=np.array([r[1] for r in rows], dtype=float),
            best_phi=np.array([r[2] for r in rows], dtype=float),
        )

    # ------------------------------------------------------------------ stages
    @contextmanager
    def stage(self, name: str, allotted: int) -> Iterator[None]:
        """Run the body as one stage of the run: its evaluations are capped and recorded.

        Stages nest: the outer stage's name and allotment are restored when the body ends.

        Args:
            name: the stage's name (in `Progress.stage`, `StageRecord.name` and the
                `BudgetExceeded` message).
            allotted: the most evaluations the body may make (< 0 counts as 0); the budget's
                `remaining` caps it too.

        Raises:
            TimeLimitReached: from the body, after the stage's `StageRecord` (stopped "time
                limit") is appended to `records`; it is appended however the body ends.
        """
        _, f0, p0 = self._best["deb"]
        c0, e0, t0 = self.count, self.evaluate_seconds, time.perf_counter()
        outer = self._stage, self._stage_end
        self._stage = name
        self._stage_end = self.count + max(int(allotted), 0)
        stopped = ""
        try:
            yield
        except TimeLimitReached:
            stopped = "time limit"
            raise
        finally:
            self._stage, self._stage_end = outer
            _, f1, p1 = self._best["deb"]
            self.records.append(StageRecord(
                name, int(allotted), self.count - c0, time.perf_counter() - t0,
                self.evaluate_seconds - e0, float(f0), float(p0), float(f1), float(p1),
                stopped))


def as_evaluator(problem: Any, budget: int) -> Evaluator:
    """The counted evaluator of a run: `problem` itself when it already is a fresh Evaluator
    with this budget (a caller's clock and progress callback kept), else a new wrap.

    Args:
        problem: a problem (`lower`, `upper`, `evaluate`) or an `Evaluator`.
        budget: the run's evaluations, >= 1.

    Returns:
        The Evaluator.

    Raises:
        ValueError: an Evaluator that has evaluated something or carries another budget, or
            (a wrap) budget < 1.
    """
    if isinstance(problem, Evaluator):
        if problem.budget != int(budget) or problem.count != 0:
            raise ValueError("an Evaluator must be fresh and carry the same budget")
        return problem
    return Evaluator(problem, budget)
