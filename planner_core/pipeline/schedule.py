"""LAMDE-S's seam (issue 34, part 1): the improving phase as named macro-actions, each spending
at most one evaluation quantum through the run's `Evaluator` (a fresh sweep's plans on top,
below), chosen one at a time by a `Scheduler`.

The `improve` stage (`planner_core.pipeline.stages.Improve`) runs an `ImproveRun`: after each
macro-action its scheduler sees an `Observation` (budget left, the incumbent, what each
action spent and gained) and names the next action. The quantum is one finish's evaluations
(`PlanConfig.final_trials`, at least a descent's), capped by what is left; the structural
search and the removal moves spend at most `restructure_trials` each and the quantum
together. A `fresh` sweep (also `restart`'s when the pool has no other plan) scores its new
constructive plans, at most `start_candidates`, before the finish's quantum: such an action
spends up to `start_candidates` + the quantum (the default rounds' `restart` included, so
left as it is: the golden plans). The actions:

* `kicks-300`, `kicks-120`, `kicks-700`: the structural search and removal moves on the
  incumbent when it changed since they last ran, then kicks on it (iterated local search,
  Lourenco, Martin & Stuetzle 2003) with that spread (m) for the rest of the quantum;
* `restructure`: the structural search and the removal moves on the incumbent, no kicks;
* `restart`: `restart-other` when the pool has such a plan, else `fresh`;
* `restart-other`: the whole finish on the Deb-best feasible pool plan of a number of hover
  points not finished yet;
* `fresh`: a fresh constructive sweep (another seed; only with `FRESH_ROOM` quanta left),
  scored into the pool, then the finish on its best plan;
* `rebuild`: destroy-and-repair moves on the incumbent (`planner_core.search.rebuild`: a
  window of 2-5 consecutive hover points replaced by new sites for the sensors it served);
* `de-block`: a block of DE generations (one quantum, at least a population) from the last
  block's population, else the DE's final one, else the pool, with the memetic repair (as
  `Repair`);
* `stop`: end the stage (what is left flows to `repair` when it is a population or more);
* `windows` (outside `ACTIONS`, the action space the shipped learned schedulers were trained
  on): one window of the incumbent's hover points planned again as a map of its own
  (`planner_core.pipeline.windows`), the next window on the next call.

The `DefaultScheduler`, up to the paper's sizes (I_max <= `PAPER_POINTS`), alternates
`kicks-*` (spreads cycling through `SPREADS`) with `restart` and stops after `IDLE_ROUNDS`
actions in a row that spent nothing: the improving rounds before the seam, the same
evaluations and random streams (each action's stream is its index in the stage), so the same
plan to the bit (tests/test_schedule.py against digests recorded before the
refactor; tests/test_golden.py). Larger problems alternate kicks with `rebuild`
(`LARGE_CYCLE`) until the cycle stalls on a uniform layout (`WINDOWS_STALL`,
`Problem.uniform_layout`), then plan windows (`windows`), and beyond `LARGE_SENSORS` sensors it also
gives the DE `LARGE_DE_SHARE` of the budget before the run starts, up to `MID_SENSORS`
`MID_DE_SHARE` (`DefaultScheduler.configure`). A `StaticScheduler` cycles
a fixed sequence (`SCHEDULES`, the registry `lamde-mission plan --scheduler NAME` reads).

Cost: that of the actions; a kick or structural trial one LP (I x J) and the C3/C5 checks
(I x J, I x V); a fresh sweep what `ConstructivePlans` costs (k-means I_max x J, one LP a
plan); a DE block N x I x (J + V) a generation.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from planner_core.model.formulas import deb_order
from planner_core.pipeline.config import PlanConfig
from planner_core.pipeline.evaluator import Evaluator
from planner_core.search.descent import PAPER_POINTS, large_problem
from planner_core.streams import stream_seed

__all__ = [
    "ACTIONS",
    "FRESH_ROOM",
    "IDLE_ROUNDS",
    "LARGE_CYCLE",
    "LARGE_DE_SHARE",
    "LARGE_SENSORS",
    "MID_DE_SHARE",
    "MID_SENSORS",
    "PAPER_POINTS",
    "large_rounds",
    "LEARNED",
    "SCHEDULES",
    "SPREADS",
    "DefaultScheduler",
    "ImproveRun",
    "Observation",
    "Scheduler",
    "StaticScheduler",
    "StepRecord",
    "STALL_ACTIONS",
    "WINDOWS_STALL",
    "WINDOW_TRIES",
    "make_scheduler",
    "pool_structures",
]

#: kick spreads (m) the default cycles through: the final stage's, finer, coarser
SPREADS = (300.0, 120.0, 700.0)
#: a fresh constructive sweep runs only with at least this many quanta left
FRESH_ROOM = 3
#: actions in a row that spent nothing before a scheduler gives up
IDLE_ROUNDS = 3
#: a hard stop for any scheduler: this many actions in a row that spent nothing
MAX_IDLE = 4 * IDLE_ROUNDS

#: the default improving rounds beyond the paper's sizes: kicks alternating with rebuilds
LARGE_CYCLE = ("kicks-300", "rebuild", "kicks-120", "rebuild", "kicks-700", "rebuild")
#: sensors beyond which the default scheduler gives the DE `LARGE_DE_SHARE` of the budget:
#: issue 31's size classes (a plan within 5x T16's time up to 160 sensors, 20x up to 400)
LARGE_SENSORS = 160
#: the DE's share of the budget on maps of more than `LARGE_SENSORS` sensors (in place of the
#: default `de_share`, 0.6): 0, so the DE runs its population (one generation, at least what
#: the DE gets) and the rest goes to the improving rounds; the DE improves nothing there and
#: the improving rounds do (docs/scaling.md, "One DE generation beyond 160 sensors")
LARGE_DE_SHARE = 0.0
#: sensors up to which a map with the large rounds gets `MID_DE_SHARE` from the default
#: scheduler; from there to `LARGE_SENSORS` the default `de_share` stays
MID_SENSORS = 120
#: the DE's share on maps of at most `MID_SENSORS` sensors with the large rounds
MID_DE_SHARE = 0.2

#: on problems with the large rounds the default scheduler turns to `windows` for the rest of
#: the stage once its last `STALL_ACTIONS` actions of `LARGE_CYCLE` lowered f by less than this
#: share per 1,000 evaluations (0.25 %: about what a sweep of windows gained on L02's final
#: plan; docs/scaling.md, "Windows planned again")
WINDOWS_STALL = 0.0025
#: the actions `WINDOWS_STALL` looks back over (a kick, a rebuild, a kick)
STALL_ACTIONS = 3
#: windows tried in a row by one `windows` action while none spends an evaluation
WINDOW_TRIES = 8

KICKS = {f"kicks-{int(s)}": s for s in SPREADS}
#: every macro-action's name, in a fixed order (the env's discrete action index)
ACTIONS: tuple[str, ...] = (*KICKS, "restructure", "restart", "restart-other", "fresh",
                            "de-block", "rebuild", "stop")


def _points(problem: Any, x: np.ndarray) -> int:
    """Hover points flown by plan x (d,)."""
    return len(problem.breakdown(np.asarray(x, dtype=float))["hover_points"])


def pool_structures(problem: Any, pool: Any, *, limit: int | None = None,
                    cache: dict[int, int] | None = None) -> dict[int, float]:
    """The pool's structures: number of hover points -> the best f among its feasible plans of
    that number, the counts in the order their best plans come in Deb order.

    Args:
        problem: the run's `Problem`; pool: its `Pool` (plans X (m, d), f, phi).
        limit: stop after this many distinct counts (None: all).
        cache: pool row -> its number of hover points, read and filled (the pool only grows,
            so a row's count never changes).

    Returns:
        {points: f}; one `Problem.breakdown` (O(I x J)) per feasible plan read.
    """
    out: dict[int, float] = {}
    for i in pool.ordered() if len(pool) else []:
        if pool.phi[i] > 0:
            continue
        if cache is None:
            n = _points(problem, pool.X[i])
        else:
            if i not in cache:
                cache[i] = _points(problem, pool.X[i])
            n = cache[i]
        out.setdefault(n, float(pool.f[i]))
        if limit is not None and len(out) >= limit:
            break
    return out


@dataclass(frozen=True)
class StepRecord:
    """One macro-action taken: its name, evaluations spent, seconds, and the incumbent's f
    and phi before and after."""

    action: str
    evaluations: int
    seconds: float
    f_before: float
    phi_before: float
    f_after: float
    phi_after: float


@dataclass(frozen=True)
class Observation:
    """What a scheduler sees before each macro-action.

    Attributes:
        step: actions taken so far in this stage.
        remaining: evaluations left in the stage; budget: the run's budget.
        quantum: evaluations one action may spend (before the cap by `remaining`; a fresh
            sweep's plans on top, module docstring).
        idle: actions in a row that spent nothing.
        f, phi: the incumbent's scores.
        elapsed: seconds since the run's evaluator was created.
        history: every `StepRecord` of the stage, in order.
        state: the run's `PlanState` (pool, DE result, finished point counts).
        x: the incumbent (d,), problem space (None where a caller builds one by hand).
    """

    step: int
    remaining: int
    budget: int
    quantum: int
    idle: int
    f: float
    phi: float
    elapsed: float
    history: tuple[StepRecord, ...]
    state: Any  # the stages' PlanState
    x: np.ndarray | None = None


@runtime_checkable
class Scheduler(Protocol):
    """Chooses the improving phase's macro-actions: `reset(problem, config)` before a run,
    then `choose(observation) -> action name` (one of `ACTIONS`) until it says "stop" or the
    stage runs out of evaluations. A scheduler may also have `configure(problem, config) ->
    PlanConfig`, asked once before the run's first stage (`configured`): the budget split it
    wants (LAMDE-S's `de_share`); the run keeps and records the config it returns."""

    name: str

    def reset(self, problem: Any, config: PlanConfig) -> None:
        """Prepare for a run (before its first `choose`).

        Args:
            problem: the run's `Problem`.
            config: the run's `PlanConfig`.
        """
        ...

    def choose(self, observation: Observation) -> str:
        """The next macro-action.

        Args:
            observation: what the stage looks like before it.

        Returns:
            An action name: one of `ACTIONS` ("stop" ends the stage).
        """
        ...


def large_rounds(problem: Any) -> bool:
    """Whether the default improving rounds of `problem` are `LARGE_CYCLE`: its I_max (hover
    points, `Problem.hover_limit`; corner slots not counted) exceeds `PAPER_POINTS` (the
    paper's largest, `planner_core.search.descent.large_problem`), and a rebuild can change
    its number of points (variable length, tau > 0). Either access model (`radio.access`):
    in scheduled access the moves are scored by the scheduled hover-time LP
    (`planner_core.search.descent.lp_times`) and screened for C5 alone.

    Args:
        problem: the run's `Problem` (`hover_limit`, `variable_length`, `tau`).

    Returns:
        True when all three hold.
    """
    return large_problem(problem) and bool(problem.variable_length) and float(problem.tau) > 0.0


class DefaultScheduler:
    """The default improving rounds, by the problem's size (`large_rounds`). Up to the paper's
    sizes (I_max <= `PAPER_POINTS`): `kicks-<s>` on even steps (s cycling through `SPREADS`),
    `restart` on odd ones (the rounds before the seam, to the bit). Larger problems:
    `LARGE_CYCLE`, kicks alternating with `rebuild` (destroy-and-repair windows,
    `planner_core.search.rebuild`), no restarts, until its last `STALL_ACTIONS` actions lowered
    f by less than `WINDOWS_STALL` per 1,000 evaluations on a uniform layout
    (`Problem.uniform_layout`: windows were worse than the rounds they replaced on clustered
    fields and corridors, docs/scaling.md, "Windows planned again"); the rest of the stage
    then goes to `windows` (stretches of ~8 hover points planned again by the pipeline,
    `planner_core.pipeline.windows`). Either way it stops after `IDLE_ROUNDS` idle actions.

    Why by size (docs/search.md, "Rebuilding windows"): on the 8 large maps x 3 seeds,
    `LARGE_CYCLE` ends 1.17 % lower than the paper-size rounds (20 of 24 runs lower, 3
    higher) in 1.08x the improving stage's time; on the 16 suite maps x 3 seeds it changes
    the mean by +0.005 % in 1.56x that time (a window of 2-5 points is most of a 5-15-point
    plan). `large_rounds` says which rounds a problem gets."""

    name = "default"
    large = False
    windows = False
    uniform = False

    def __init__(self, *, plan_windows: bool = True) -> None:
        """plan_windows: False keeps to `ACTIONS` (the learned schedulers' action space, e.g.
        their environment's demonstrations): no `windows`, so the rounds run on where the
        default would plan windows."""
        self.plan_windows = bool(plan_windows)

    def configure(self, problem: Any, config: PlanConfig) -> PlanConfig:
        """The run's config: on a map whose rounds are `LARGE_CYCLE` (`large_rounds`), the
        DE's share `LARGE_DE_SHARE` in place of the default `de_share` beyond `LARGE_SENSORS`
        sensors and `MID_DE_SHARE` up to `MID_SENSORS`; any other config as it is (a
        `de_share` other than the default is kept, as is a run without the descent or the
        polish, where the DE gets the rest).

        Why: on the large maps the DE's evaluations improve nothing and the improving rounds'
        do. On each large map beyond 160 sensors and its specs from generator seeds 3001-3003,
        3 seeds each (12 cases a map, `bench_schedule.py --splits`, docs/scheduler.md's
        records) 0.4 in place of 0.6 lowered f by
        0.14 (L03), 1.50 (L05), 1.12 (L06) and 0.79 % (L08) for 1.2-1.45x the CPU; once the
        structural search drew its moves one at a time, 0 in place of 0.4 lowered it by
        0.13-1.26 % more (L03, L05, L06, L08 x seeds 0-4, 5 of 5 lower on L05, L06, L08) for
        1.3-1.6x the CPU, which the maps beyond 160 sensors can afford (issue 31: 20x T16's
        time; L06 18.8x). Up to 160 sensors the target is 5x: L02 (160 sensors) takes 4.2x at
        0.6 and keeps it; on maps of at most `MID_SENSORS` sensors `MID_DE_SHARE` (0.2)
        lowered f by 0.15 (L01), 0.37 (L04) and 0.48 % (L07) at seeds 0-9 for 1.7-2.1x the
        CPU (2.3-3.8x T16). docs/scaling.md, "One DE generation beyond 160 sensors" and "Up
        to 120 sensors: 0.2".

        Args:
            problem: the run's `Problem`; config: its `PlanConfig`.

        Returns:
            A `PlanConfig` (`config` itself when nothing changes).
        """
        from planner_core.defaults import DE_SHARE

        sensors = len(np.asarray(problem.model.sensors).reshape(-1, 2))
        if (config.de_share != DE_SHARE or not (config.descent and config.polish)
                or not large_rounds(problem)):
            return config
        if sensors > LARGE_SENSORS:
            return config.replace(de_share=LARGE_DE_SHARE)
        if sensors <= MID_SENSORS:
            return config.replace(de_share=MID_DE_SHARE)
        return config

    def reset(self, problem: Any, config: PlanConfig) -> None:
        """Read the problem: `large_rounds(problem)`, and whether it may plan windows (the
        rounds large, `plan_windows` on and the sensors' layout uniform,
        `Problem.uniform_layout`); no windows yet.

        Args:
            problem: the run's `Problem` (its sensors and map).
            config: the run's `PlanConfig` (unused).
        """
        self.large = large_rounds(problem)
        self.windows = False
        self.uniform = self.plan_windows and self.large and problem.uniform_layout

    def choose(self, observation: Observation) -> str:
        """The next action (see the class docstring).

        Args:
            observation: the stage before it (`idle`, `step`, `history` read).

        Returns:
            "stop" after `IDLE_ROUNDS` idle actions; large rounds: "windows" once stalled
            on a uniform layout (back to the cycle for good when a windows action spent
            nothing), else `LARGE_CYCLE[step % len(LARGE_CYCLE)]`; otherwise "restart" on
            odd steps, "kicks-<s>" on even ones (s cycling through `SPREADS`).
        """
        if observation.idle >= IDLE_ROUNDS:
            return "stop"
        k = observation.step
        if self.large:
            last = observation.history[-1] if observation.history else None
            if self.windows and last is not None and last.evaluations == 0:
                # a windows action found nothing to plan (every window refused, or too few
                # evaluations or seconds left for one): the rounds take the rest
                self.windows = self.uniform = False
            self.windows = self.windows or (self.uniform and _stalled(observation.history))
            return "windows" if self.windows else LARGE_CYCLE[k % len(LARGE_CYCLE)]
        if k % 2:
            return "restart"
        return f"kicks-{int(SPREADS[(k // 2) % len(SPREADS)])}"


def _stalled(history: Sequence[StepRecord]) -> bool:
    """Whether the last `STALL_ACTIONS` actions (feasible before and after) lowered f by less
    than `WINDOWS_STALL` of it per 1,000 evaluations they spent (`windows` actions left
    out)."""
    last = [r for r in history if r.action != "windows"][-STALL_ACTIONS:]
    if len(last) < STALL_ACTIONS or last[0].phi_before > 0 or last[-1].phi_after > 0:
        return False
    spent = sum(r.evaluations for r in last)
    if spent <= 0:
        return False
    gain = (last[0].f_before - last[-1].f_after) / max(abs(last[-1].f_after), 1e-12)
    return gain * 1000.0 / spent < WINDOWS_STALL


class StaticScheduler:
    """A fixed cyclic sequence of macro-actions; stops after `IDLE_ROUNDS` idle actions.

    Args:
        name: the schedule's registry name.
        sequence: action names (each in `ACTIONS`, not "stop"), cycled.

    Raises:
        ValueError: an unknown or empty sequence.
    """

    def __init__(self, name: str, sequence: Sequence[str]) -> None:
        seq = tuple(sequence)
        bad = [a for a in seq if a not in ACTIONS or a == "stop"]
        if not seq or bad:
            raise ValueError(f"scheduler: a static schedule needs actions from {ACTIONS[:-1]}, "
                             f"got {bad or 'none'}")
        self.name, self.sequence = name, seq

    def reset(self, problem: Any, config: PlanConfig) -> None:
        """Nothing to reset (stateless).

        Args:
            problem: the run's `Problem` (unused).
            config: the run's `PlanConfig` (unused).
        """

    def choose(self, observation: Observation) -> str:
        """The sequence's next action, or "stop" after `IDLE_ROUNDS` idle actions.

        Args:
            observation: the stage before it (`idle`, `step` read).

        Returns:
            "stop", or `sequence[step % len(sequence)]`.
        """
        if observation.idle >= IDLE_ROUNDS:
            return "stop"
        return self.sequence[observation.step % len(self.sequence)]

    def __repr__(self) -> str:
        return f"StaticScheduler({self.name!r}, {self.sequence!r})"


#: static schedules by name ("default" is `DefaultScheduler`, the same as "alternate")
SCHEDULES: dict[str, tuple[str, ...]] = {
    "alternate": ("kicks-300", "restart", "kicks-120", "restart", "kicks-700", "restart"),
    "kicks-heavy": ("kicks-300", "kicks-120", "kicks-700", "restart"),
    "kicks-only": ("kicks-300", "kicks-120", "kicks-700"),
    "fine-kicks": ("kicks-120", "restart", "kicks-300", "restart"),
    "coarse-kicks": ("kicks-700", "restart", "kicks-300", "restart"),
    "restructure-heavy": ("restructure", "kicks-300", "restart", "restructure", "kicks-120",
                          "restart"),
    "restarts-heavy": ("kicks-300", "restart", "restart", "kicks-120", "restart", "restart"),
    "fresh-heavy": ("kicks-300", "fresh", "kicks-120", "restart-other"),
    "de-block-heavy": ("kicks-300", "de-block", "kicks-120", "restart"),
    "kicks-rebuild": LARGE_CYCLE,
}


#: learned schedulers by name -> "module:class" (imported when asked for)
LEARNED: dict[str, str] = {
    "lamde-s": "planner_core.learning.schedule_select:SelectorScheduler",
    "lamde-s-ppo": "planner_core.learning.schedule_policy:PolicyScheduler",
}


def scheduler_names() -> tuple[str, ...]:
    """Every registry name.

    Returns:
        "default", the static schedules (`SCHEDULES`), then the learned ones (`LEARNED`).
    """
    return ("default", *SCHEDULES, *LEARNED)


def make_scheduler(spec: str | Scheduler | None) -> Scheduler:
    """A scheduler from its spec.

    Args:
        spec: a registry name (`scheduler_names()`), a learned one's name with its checkpoint
            folder ("lamde-s-ppo:DIR", "lamde-s:DIR"; the shipped one without), an object,
            or None (default).

    Returns:
        A `DefaultScheduler` for None or "default", a `StaticScheduler` for a static
        schedule's name, the learned class's instance (imported when asked for), or `spec`
        itself for an object.

    Raises:
        ValueError: one line naming `scheduler` for an unknown name or a non-scheduler, or
            `checkpoint` for a folder that does not load.
    """
    if spec is None or spec == "default":
        return DefaultScheduler()
    name, colon, folder = spec.partition(":") if isinstance(spec, str) else ("", "", "")
    if name in LEARNED and colon and not folder.strip():
        raise ValueError(f"scheduler: {spec!r} names no checkpoint folder after the colon "
                         f"(the shipped one is plain {name!r})")
    if name in LEARNED:
        import importlib

        module, cls = LEARNED[name].split(":")
        learned = getattr(importlib.import_module(module), cls)
        return learned.from_checkpoint(folder) if folder else learned()
    if isinstance(spec, str):
        if spec not in SCHEDULES:
            forms = ", ".join(f"{n}:DIR" for n in LEARNED)
            raise ValueError(f"scheduler: must be one of {', '.join(scheduler_names())} (or "
                             f"{forms}: a learned one from its checkpoint folder DIR), got "
                             f"{spec!r}")
        return StaticScheduler(spec, SCHEDULES[spec])
    if not isinstance(spec, Scheduler):
        raise ValueError(f"scheduler: must be a name or have reset() and choose(), got "
                         f"{type(spec).__name__}")
    return spec


def configured(spec: str | Scheduler | None, problem: Any, config: PlanConfig) -> PlanConfig:
    """The config a run with scheduler `spec` runs with: what the scheduler's optional
    `configure(problem, config)` returns (a `PlanConfig`; LAMDE-S's DE share, chosen from the
    map before any stage runs), or for a scheduler without one (a static schedule,
    lamde-s-ppo) the default's (`DefaultScheduler.configure`: the DE's share beyond
    `LARGE_SENSORS` sensors and up to `MID_SENSORS`), so that only a scheduler that chooses
    the split changes it.

    Args:
        spec: the scheduler, as `make_scheduler` reads it.
        problem: the run's `Problem`.
        config: the config asked for.

    Returns:
        The `PlanConfig` the run keeps.

    Raises:
        ValueError: as `make_scheduler`; or `configure` returned no `PlanConfig`.
    """
    hook = getattr(make_scheduler(spec), "configure", None)
    if hook is None:
        hook = DefaultScheduler().configure
    out = hook(problem, config)
    if not isinstance(out, PlanConfig):
        raise ValueError(f"scheduler: configure() must return a PlanConfig, got "
                         f"{type(out).__name__}")
    return out


def scheduler_name(spec: str | Scheduler | None) -> str:
    """The registry name of a scheduler spec.

    Args:
        spec: a name, a scheduler object or None.

    Returns:
        "default" for None, `spec` for a name (as given, checkpoint folder included), an
        object's `name` (its class name without one).
    """
    if spec is None:
        return "default"
    return spec if isinstance(spec, str) else str(getattr(spec, "name", type(spec).__name__))


@dataclass
class ImproveRun:
    """The improving phase of one run, one macro-action at a time (`act`), over the run's
    `PlanState` and `Evaluator` (inside the `improve` stage's allotment).

    Args:
        state: the run's state when the stage starts (updated by the actions: fresh plans join
            the pool, finished point counts).
        ev: the run's evaluator.
    """

    state: Any  # the stages' PlanState
    ev: Evaluator
    step: int = 0
    idle: int = 0
    history: list[StepRecord] = field(default_factory=list)
    _searched: bytes = b""
    _restarted: set[bytes] = field(default_factory=set)
    _fresh: int = 0
    _de_state: Any = None
    _rebuilder: Any = None
    _window: int = 0

    def __post_init__(self) -> None:
        # the finish ran its structural search on the incumbent
        self._searched = self.ev.best()[0].tobytes()

    @property
    def quantum(self) -> int:
        """Evaluations one action may spend: one finish's, at least a descent's.

        Returns:
            max(`final_trials`, `descent_trials`) of the state's config.
        """
        cfg = self.state.config
        return max(cfg.final_trials, cfg.descent_trials)

    @property
    def can_continue(self) -> bool:
        """Whether another action may run.

        Returns:
            True with at least a descent's trials left and fewer than `MAX_IDLE` idle actions
            in a row.
        """
        return self.ev.remaining >= self.state.config.descent_trials and self.idle < MAX_IDLE

    def observe(self) -> Observation:
        """What the scheduler sees before the next action.

        Returns:
            The `Observation` (the evaluator's Deb incumbent as f, phi and x).
        """
        x, f, phi = self.ev.best()
        return Observation(step=self.step, remaining=self.ev.remaining,
                           budget=self.ev.budget, quantum=self.quantum, idle=self.idle,
                           f=float(f), phi=float(phi), elapsed=self.ev.elapsed,
                           history=tuple(self.history), state=self.state, x=x)

    def act(self, action: str) -> StepRecord:
        """Run one macro-action.

        Args:
            action: its name: one of `ACTIONS` but "stop", or "windows".

        Returns:
            Its `StepRecord`.

        Raises:
            ValueError: an unknown action.
            planner_core.pipeline.TimeLimitReached: the run's clock ran out (propagates).
        """
        run = {"restructure": self._restructure, "restart": self._restart,
               "restart-other": self._restart_other, "fresh": self._fresh_restart,
               "de-block": self._de_block, "rebuild": self._rebuild,
               "windows": self._windows}.get(action)
        if action in KICKS:
            run = functools.partial(self._kicks, KICKS[action])
        if run is None:
            raise ValueError(f"action: must be one of {', '.join(ACTIONS[:-1])}, windows, got "
                             f"{action!r}")
        ev = self.ev
        c0, t0 = ev.count, time.perf_counter()
        _, f0, p0 = ev.best()
        run(min(self.quantum, ev.remaining))
        _, f1, p1 = ev.best()
        rec = StepRecord(action, ev.count - c0, time.perf_counter() - t0, float(f0), float(p0),
                         float(f1), float(p1))
        self.history.append(rec)
        self.idle = self.idle + 1 if ev.count == c0 else 0
        self.step += 1
        return rec

    # ------------------------------------------------------------------ the actions
    def _structural(self, trials: int) -> None:
        """The structural search, then the removal moves, on the incumbent: at most
        `restructure_trials` evaluations each and `trials` (the action's quantum) together."""
        from planner_core.search.structure import MOVES, restructure

        ev, cfg = self.ev, self.state.config
        c0 = ev.count
        self._searched = ev.best()[0].tobytes()
        for moves in (MOVES, ("removal",)):
            left = min(cfg.restructure_trials, trials - (ev.count - c0), ev.remaining)
            restructure(self.state.problem, ev.best()[0], ev.evaluate, trials=left, moves=moves)

    def _kicks(self, spread: float, trials: int) -> None:
        from planner_core.search.structure import kicks

        ev, c0 = self.ev, self.ev.count
        if ev.best()[0].tobytes() != self._searched:
            self._structural(trials)
        left = trials - (ev.count - c0)
        if left > 0:
            kicks(self.state.problem, ev.best()[0], ev.evaluate, trials=left,
                  seed=self.state.config.seed, spread=spread, stream=self.step + 1)

    def _rebuild(self, trials: int) -> None:
        from planner_core.search.rebuild import Rebuilder, rebuild

        if self._rebuilder is None:
            self._rebuilder = Rebuilder(self.state.problem)
        rebuild(self.state.problem, self.ev.best()[0], self.ev.evaluate, trials=trials,
                seed=self.state.config.seed, stream=self.step + 1, rebuilder=self._rebuilder)

    def _windows(self, trials: int) -> None:
        from planner_core.pipeline.windows import replan_window

        cfg, ev = self.state.config, self.ev
        c0 = ev.count
        for t in range(WINDOW_TRIES):  # windows with nothing to do spend nothing: the next
            if ev.count != c0 or ev.expired:
                break
            seed = stream_seed(cfg.seed, "window", self.step, t)
            self._window, _ = replan_window(self.state.problem, ev, index=self._window,
                                            trials=trials, seed=seed >> 1)

    def _restructure(self, trials: int) -> None:
        self._structural(trials)

    def _finish(self, y: np.ndarray | None, trials: int) -> None:
        from planner_core.search.final import finish

        if y is None:
            return
        cfg, problem = self.state.config, self.state.problem
        self._restarted.add(y.tobytes())
        finish(problem, y, self.ev.evaluate, trials=min(trials, self.ev.remaining),
               seed=cfg.seed + self.step, descent_trials=cfg.descent_trials,
               restructure_trials=cfg.restructure_trials)
        self.state = self.state.replace(finished=self.state.finished | {_points(problem, y)})

    def _other(self) -> np.ndarray | None:
        """The Deb-best feasible unrestarted pool plan of an unfinished number of points."""
        state, pool = self.state, self.state.pool
        for i in pool.ordered():
            if pool.phi[i] > 0 or pool.X[i].tobytes() in self._restarted:
                continue
            n = _points(state.problem, pool.X[i])
            if n > 0 and n not in state.finished:
                return pool.X[i]
        return None

    def _sweep(self) -> np.ndarray | None:
        """A fresh constructive sweep scored into the pool (with `FRESH_ROOM` quanta left);
        its Deb-best plan when feasible."""
        from planner_core.search.construct import candidate_plans

        state, ev, cfg = self.state, self.ev, self.state.config
        pool, problem = state.pool, state.problem
        # a fresh sweep costs what the constructive stage costs: only with room for several
        # rounds after it
        if ev.remaining < FRESH_ROOM * max(cfg.final_trials, 1):
            return None
        self._fresh += 1
        seed = stream_seed(cfg.seed, "fresh", self._fresh)
        X, _ = candidate_plans(problem, seed, cfg.start_candidates, order=cfg.order,
                               stop=lambda: ev.expired)
        seen = {r.tobytes() for r in pool.X}
        X = np.asarray([r for r in X if r.tobytes() not in seen]).reshape(-1, pool.X.shape[1])
        X = X[:max(min(len(X), ev.remaining - cfg.descent_trials), 0)]
        if not len(X):
            return None
        f, phi = ev.evaluate(X)
        self.state = state.replace(pool=pool.add(X, f, phi, "fresh"))
        best = deb_order(f, phi)[0]
        return None if phi[best] > 0 else X[best]

    def _restart(self, trials: int) -> None:
        y = self._other()
        self._finish(self._sweep() if y is None else y, trials)

    def _restart_other(self, trials: int) -> None:
        self._finish(self._other(), trials)

    def _fresh_restart(self, trials: int) -> None:
        self._finish(self._sweep(), trials)

    def _de_block(self, trials: int) -> None:
        from planner_core.search.construct import InjectedPopulation
        from planner_core.search.de import run
        from planner_core.search.de.core import to_problem
        from planner_core.search.refine import refine

        state, ev, cfg = self.state, self.ev, self.state.config
        n = cfg.population
        if trials < n:
            return
        st = self._de_state if self._de_state is not None else (
            state.de.state if state.de is not None else None)
        if st is not None:
            rows = to_problem(ev, st.X[deb_order(st.f, st.phi)])
        else:
            rows = state.pool.X[state.pool.ordered()]
        rows = np.vstack([ev.best()[0][None, :], rows])[:n]
        seed = stream_seed(cfg.seed, "de-block", self.step)
        result = run(InjectedPopulation(ev, rows), configurator=cfg.configurator, seed=seed,
                     population=n, budget=trials,
                     refine=functools.partial(refine, state.problem))
        self._de_state = result.state

    # ------------------------------------------------------------------ the loop
    def run(self, scheduler: Scheduler) -> Any:
        """Ask `scheduler` for actions until it says "stop" or `can_continue` is false.

        Args:
            scheduler: reset with the state's problem and config first.

        Returns:
            The final `PlanState` (its `actions` the actions taken; `schedule` a selector's
            template where the scheduler has one).

        Raises:
            ValueError: the scheduler named an unknown action (`act`).
            planner_core.pipeline.TimeLimitReached: the run's clock ran out (propagates).
        """
        scheduler.reset(self.state.problem, self.state.config)
        while self.can_continue:
            action = scheduler.choose(self.observe())
            if action == "stop":
                break
            self.act(action)
        chosen = getattr(scheduler, "template", None)  # a selector's pick (lamde-s)
        if chosen is not None:
            self.state = self.state.replace(schedule=str(chosen))
        return self.state.replace(actions=tuple(r.action for r in self.history))
