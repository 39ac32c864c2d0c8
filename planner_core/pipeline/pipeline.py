"""The planning pipeline, declared once: the stages in order with their budget rules, and the
loop that runs them over one state and one counted evaluator.

```
stage            share of the budget (config names; planner_core.defaults)
constructive     start_candidates + SEEDER_PLANS      one evaluation per plan
start descents   2 x descents x descent_trials        the best of each kind descended
de               de_share x min(budget, 10,000)       reserved: its population; yields
polish           ELITE (16)                           reserved
finish           descent + restructure + kick trials  on the incumbent
other structure  other_trials                         a plan of another number of points
improve          the rest, while feasible             kicks, structural search, restarts
repair           the rest, while infeasible           the DE again with the memetic repair
```

Each stage gets its share, never what a later stage reserves (the DE's population, the
polish's LP plans), so a small budget shrinks the constructive plans and descents first; the
DE also yields to the later stages' shares (the final stage's), down to its population; what
a stage leaves unspent flows to `improve` (or `repair`), the stages that turn budget into a
better plan. The answer is the evaluator's incumbent: the Deb-best of everything evaluated.

With a time limit the evaluator refuses evaluations once it has passed: the stage running
stops there, no later stage starts, and the incumbent is returned. The same budget and seed
give the same plan; a time limit trades that determinism for a deadline (where the clock
stops the run depends on the machine).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner_core.pipeline.config import PlanConfig
from planner_core.pipeline.evaluator import Evaluator, Progress, StageRecord, TimeLimitReached
from planner_core.pipeline.stages import (
    ConstructivePlans,
    DifferentialEvolution,
    FinishIncumbent,
    Improve,
    OtherStructure,
    PlanState,
    Polish,
    Pool,
    Repair,
    Stage,
    StartDescents,
)

__all__ = ["DEFAULT_PIPELINE", "WINDOW_PIPELINE", "PipelineResult", "PipelineRun", "allotment",
           "run_pipeline", "with_scheduler"]

#: the default pipeline, in the order it runs (the module docstring's table)
DEFAULT_PIPELINE: tuple[Stage, ...] = (
    ConstructivePlans(),
    StartDescents(),
    DifferentialEvolution(),
    Polish(),
    FinishIncumbent(),
    OtherStructure(),
    Improve(),
    Repair(),
)

#: a window's run (`planner_core.pipeline.windows`): the default pipeline whose constructive
#: stage builds no seeder plans
WINDOW_PIPELINE: tuple[Stage, ...] = tuple(
    ConstructivePlans(seeder=0) if isinstance(s, ConstructivePlans) else s
    for s in DEFAULT_PIPELINE)


@dataclass(frozen=True)
class PipelineResult:
    """A run's answer and its record.

    Attributes:
        x: (d,) the incumbent's decision vector (problem space); f, phi its scores.
        evaluations: evaluations spent in all (the evaluator's count).
        stages: one `StageRecord` per stage that ran, in order.
        trace: the Deb incumbent after every improvement, as (evaluations, best_f, best_phi)
            arrays.
        state: the final `PlanState` (pool, DE result, polish record, notes).
        stopped: "time limit" when the clock ended the run, else "".
        seconds: wall time of the run (s).
    """

    x: np.ndarray
    f: float
    phi: float
    evaluations: int
    stages: tuple[StageRecord, ...]
    trace: dict[str, np.ndarray]
    state: PlanState
    stopped: str
    seconds: float


def allotment(stage: Stage, later: Sequence[Stage], config: PlanConfig, left: int) -> int:
    """Evaluations `stage` gets with `left` of the budget unspent: its share (all of `left`
    for None), never what the `later` stages reserve; a stage that `yields` (the DE) also
    leaves the later stages' own shares, down to its reserve.

    Args:
        stage: the stage about to run.
        later: the stages after it, in order.
        config: the run's settings (the stages' `share` and `reserve` read it).
        left: evaluations of the budget unspent.

    Returns:
        The stage's allotment (evaluations), >= 0.
    """
    free = left - sum(s.reserve(config) for s in later)
    want = stage.share(config)
    n = free if want is None else min(int(want), free)
    if stage.yields:
        rest = left - sum(s.share(config) or 0 for s in later)
        n = max(min(n, rest), min(stage.reserve(config), free))
    return max(0, n)


def _thin(ev: Evaluator) -> dict[str, np.ndarray]:
    """The Deb trace at each change of the incumbent and at its end."""
    t = ev.trace("deb")
    if not len(t.evaluations):
        return {"evaluations": t.evaluations, "best_f": t.best_f, "best_phi": t.best_phi}
    change = np.ones(len(t.evaluations), dtype=bool)
    change[1:] = (np.diff(t.best_f) != 0) | (np.diff(t.best_phi) != 0)
    change[-1] = True
    return {"evaluations": t.evaluations[change], "best_f": t.best_f[change],
            "best_phi": t.best_phi[change]}


def with_scheduler(pipeline: Sequence[Stage], scheduler: Any) -> tuple[Stage, ...]:
    """`pipeline` with its `improve` stage choosing macro-actions by `scheduler`.

    Args:
        pipeline: the stages in order.
        scheduler: a registry name, a `schedule.Scheduler`, or None (the pipeline unchanged).

    Returns:
        The stages, each `Improve` replaced by `Improve(scheduler)`.

    Raises:
        ValueError: one line naming `scheduler` for an unknown name (as
            `schedule.make_scheduler`, which checks it before any work).
    """
    if scheduler is None:
        return tuple(pipeline)
    from planner_core.pipeline.schedule import make_scheduler

    make_scheduler(scheduler)  # checked before any work
    return tuple(Improve(scheduler) if isinstance(s, Improve) else s for s in pipeline)


class PipelineRun:
    """One run of a pipeline, stage by stage: `run_pipeline` runs it through; the scheduling
    env (`planner_core.learning.schedule_env`) stops it before a stage (`advance(until)`),
    opens that stage's allotment (`enter`), steps it from outside, then closes it (`leave`)
    and runs the rest. Args as `run_pipeline`'s. A stage with `configure(problem, config)`
    (the improving stage, for its scheduler: `schedule.configured`) may change the config
    before the first stage; the run keeps the one it ran with (`state.config`)."""

    def __init__(self, problem: Any, config: PlanConfig, *, pipeline: Sequence[Stage],
                 evaluator: Evaluator | None,
                 progress: Callable[[Progress], None] | None) -> None:
        from planner_core.search.init_modes import with_init

        for stage in pipeline:
            hook = getattr(stage, "configure", None)
            if hook is not None:
                config = hook(problem, config)
        if evaluator is None:
            evaluator = Evaluator(with_init(problem, config.init), config.budget,
                                  time_limit=config.time_limit, progress=progress)
        elif evaluator.count != 0 or evaluator.budget != config.budget:
            raise ValueError("evaluator: must be fresh and carry the config's budget")
        self.ev, self.config, self.problem = evaluator, config, problem
        self.t0 = time.perf_counter()
        d = int(np.asarray(problem.lower).shape[0])
        self.state = PlanState(problem=problem, config=config, pool=Pool.empty(d),
                               injected=np.zeros((0, d)))
        self.stopped = ""
        self.stages = list(pipeline)
        self.i = 0  # the next stage to run
        self._open: Any = None

    def _allot(self) -> int:
        """The next stage's allotment, 0 when it does not apply; marks a passed time limit."""
        ev, stage = self.ev, self.stages[self.i]
        if ev.expired and ev.has_best:
            self.stopped = "time limit"
            return 0
        n = allotment(stage, self.stages[self.i + 1:], self.config, ev.budget - ev.count)
        return n if n > 0 and stage.applies(self.state, ev) else 0

    def advance(self, until: str | None = None) -> None:
        """Run the stages in order up to (not including) the first named `until`.

        Stops early when the time limit has passed (`stopped` "time limit").

        Args:
            until: a stage's `name` (None: all).
        """
        while self.i < len(self.stages) and not self.stopped:
            stage = self.stages[self.i]
            if until is not None and stage.name == until:
                return
            n = self._allot()
            if self.stopped:
                return
            self.i += 1
            if n <= 0:
                continue
            try:
                with self.ev.stage(stage.name, n):
                    self.state = stage.run(self.state, self.ev)
            except TimeLimitReached:
                self.stopped = "time limit"

    def enter(self) -> bool:
        """Open the next stage's allotment without running it.

        Returns:
            True when opened; False, and the stage passed, when it gets nothing or does not
            apply (or the time limit has passed: the run stopped, the stage not passed).
        """
        n = self._allot()
        if self.stopped:
            return False
        self.i += 1
        if n <= 0:
            return False
        self._open = self.ev.stage(self.stages[self.i - 1].name, n)
        self._open.__enter__()
        return True

    def leave(self, state: PlanState, stopped: str = "") -> None:
        """Close the stage `enter` opened, with its final state.

        Args:
            state: the stage's final `PlanState` (the run's from here on).
            stopped: "time limit" when the clock ended it, else "".
        """
        self.state = state
        if self._open is not None:
            self._open.__exit__(None, None, None)
            self._open = None
        if stopped:
            self.stopped = stopped

    def fork(self, scheduler: Any = None, config: PlanConfig | None = None) -> PipelineRun:
        """An independent copy of this run between stages (the evaluator, state and stages
        copied, the problem shared): the schedule benchmark runs the stages before `improve`
        once per map and seed, then each schedule from there. Same as running the whole
        pipeline with that scheduler, to the bit (tests/test_schedule.py). With the budget
        and seed unchanged and only settings of stages not yet run changed (the DE's
        `de_share` before the DE), the same plan as a whole run with that config (the split
        benchmark forks before the DE). A scheduler's `configure` is not asked here: the
        caller passes what it returns.

        Args:
            scheduler: the copy's `improve` stage chooses by it (None: as it was).
            config: the copy's config from here on (None: this run's).

        Returns:
            The copy, its clock (`t0`) restarted.

        Raises:
            RuntimeError: a stage is open (`enter` without `leave`).
            ValueError: `config` with another budget than the run's evaluator, or another
                `de_share` once the DE has run; an unknown scheduler (`with_scheduler`).
        """
        import copy

        if self._open is not None:
            raise RuntimeError("fork: a stage is open")
        if config is not None and config.budget != self.ev.budget:
            raise ValueError("config: a fork keeps the run's budget")
        ran = {s.name for s in self.stages[:self.i]}
        if config is not None and "de" in ran and config.de_share != self.config.de_share:
            raise ValueError("config: de_share changes nothing once the DE has run; fork "
                             "before it (advance(until='de'))")
        memo = {id(self.problem): self.problem}
        twin = copy.deepcopy(self, memo)
        twin.stages = list(with_scheduler(twin.stages, scheduler))
        if config is not None:
            twin.config = config
            twin.state = twin.state.replace(config=config)
        twin.t0 = time.perf_counter()
        return twin

    def result(self) -> PipelineResult:
        """The run's result.

        Returns:
            The `PipelineResult` (x, f, phi: the evaluator's Deb-best; seconds since the run
            or fork was made).

        Raises:
            RuntimeError: nothing has been evaluated (`Evaluator.best`).
        """
        ev = self.ev
        x, f, phi = ev.best("deb")
        return PipelineResult(x=x, f=float(f), phi=float(phi), evaluations=ev.count,
                              stages=tuple(ev.records), trace=_thin(ev), state=self.state,
                              stopped=self.stopped, seconds=time.perf_counter() - self.t0)


def run_pipeline(
    problem: Any,
    config: PlanConfig,
    *,
    pipeline: Sequence[Stage] = DEFAULT_PIPELINE,
    evaluator: Evaluator | None = None,
    progress: Callable[[Progress], None] | None = None,
    scheduler: Any = None,
) -> PipelineResult:
    """Run `pipeline` on the UAV problem `problem` (`planner_core.model.problem.Problem`) with
    `config`.

    Args:
        problem: the problem the stages decode and encode with.
        config: every setting of the run (budget, seed, shares, time limit).
        pipeline: the stages in order (default `DEFAULT_PIPELINE`).
        evaluator: a fresh `Evaluator` with `config.budget` to count through (the benchmark
            passes its own); None: one over `problem` in `config.init`'s start mode, with
            `config.time_limit` and `progress`.
        progress: called after every evaluate call with a `Progress` (stage, evaluations,
            budget, incumbent f and phi, seconds).
        scheduler: the improving stage's scheduler (`planner_core.pipeline.schedule`: a
            registry name or a `Scheduler`); None: the pipeline's own (the default).

    Returns:
        The `PipelineResult`; its x is the Deb-best of everything evaluated.

    Raises:
        ValueError: an evaluator that is not fresh or carries another budget; an unknown
            scheduler.
    """
    run = PipelineRun(problem, config, pipeline=with_scheduler(pipeline, scheduler),
                      evaluator=evaluator, progress=progress)
    run.advance()
    return run.result()
