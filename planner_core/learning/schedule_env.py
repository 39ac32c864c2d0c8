"""LAMDE-S's MDP (issue 34, part 1): the improving phase's macro-decisions as a
:class:`gymnasium.Env`, registered as ``"lamde/Schedule-v0"``.

An episode is one plan. `reset` draws a map (from `maps`, else a generated paper-size map,
`planner_core.suite.generate_map`, from the reset seed) and a plan seed, and runs the default
pipeline (`planner_core.pipeline.PipelineRun`) up to its `improve` stage; a map whose improving
stage would not run (the incumbent infeasible, or no budget left for it) is skipped for the
next draw. Each `step` runs one macro-action (`planner_core.pipeline.schedule.ACTIONS`, the
discrete action's index) through the run's one counted evaluator; "stop", or no budget left for
another action, closes the stage and runs the rest of the pipeline (`repair` when a population
or more is left), and the episode terminates with the plan in `result`.

Observation: `N_FEATURES` float32 scalars (`FEATURES` names them): budget and time left as
fractions, the incumbent against the best constructive plan and against the stage's start,
phi and its C3/C4/C5 parts (`Problem.breakdown`), short sensors, points / I_max, the pool's
distinct structures (numbers of hover points among its feasible plans) and the gaps of the
next two to the incumbent, per action its recent gain per evaluation and its use, stagnation
counters, and map descriptors (sensors, obstacles, area, I_max).

Reward: the share of the initial gap closed, (f_before - f_after) / gap per step, with gap =
f at the stage's start minus the reference f: with `reference="default"` the default
scheduler's f on the same map, seed and budget (run once and cached), so following the default
sums to 1; with "percent" the gap is 1 % of the starting f. At the end -`INFEASIBLE_PENALTY`
when the plan is infeasible. Following `DefaultScheduler`'s choices (after its
`reset(problem, config)`, which picks its rounds by the problem's size) reproduces the default
plan to the bit (tests/test_schedule_env.py), except where the default plans windows (a
uniform layout with the large rounds once they stall; `windows` is outside the env's actions):
there `DefaultScheduler(plan_windows=False)` is what the env can follow, the large rounds to
the end.

The features are `ScheduleFeatures`'s, computed from the `schedule.Observation` a scheduler
sees, so that a learned scheduler (`planner_core.learning.schedule_policy`) reads in `plan` what
it was trained on here.

Cost: a reset costs the pipeline up to `improve` (constructive plans, descents, the DE, the
polish, the finishes; once per map and seed with `cache`), plus, with the default reference,
the rest of a default plan from a copy of that prefix once per map and seed; a step costs its
action (`planner_core.pipeline.schedule`) and one breakdown.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

__all__ = ["ENV_ID", "FEATURES", "INFEASIBLE_PENALTY", "N_FEATURES", "NoImprovingStageError",
           "ScheduleEnv", "ScheduleFeatures"]

#: the id under which `ScheduleEnv` is registered with Gymnasium
ENV_ID = "lamde/Schedule-v0"
#: reward at the end of an episode whose plan is infeasible
INFEASIBLE_PENALTY = 1.0
#: maps drawn at most per reset before giving up (each skipped when improve would not run)
MAX_DRAWS = 20


class NoImprovingStageError(RuntimeError):
    """The map given to `ScheduleEnv.reset` leaves its improving stage nothing to do: the
    incumbent is infeasible when the stage starts, or no budget is left for it (the budget is
    too small for the stages before it)."""


#: weight of the newest gain in each action's running mean of gain per evaluation
EMA = 0.5


def _action_names() -> tuple[str, ...]:
    from planner_core.pipeline.schedule import ACTIONS

    return ACTIONS


_MOVES = tuple(a for a in _action_names() if a != "stop")
#: the observation's features, in order
FEATURES: tuple[str, ...] = (
    "budget_left", "stage_left", "time_left", "f_vs_constructive", "f_vs_stage_start",
    "phi", "c3", "c4", "c5", "short_sensors", "points_over_imax", "structures",
    "gap_second_structure", "gap_third_structure", "structures_finished", "restart_available",
    "step", "idle", "since_improvement",
    *(f"gain_{a}" for a in _MOVES), *(f"use_{a}" for a in _MOVES),
    "sensors", "obstacles", "area_km2", "imax",
)
N_FEATURES = len(FEATURES)


def _log(v: float) -> float:
    return float(np.log1p(max(float(v), 0.0)))


class ScheduleEnv(gymnasium.Env):
    """The scheduling MDP over one plan's improving phase (module docstring).

    Args:
        maps: map files, parsed maps or `Map`s to draw from (uniformly by the reset seed);
            None: generated maps (`planner_core.suite.generate_map`, 5,000 m, density 0-7).
        budget: evaluations per plan, >= the population.
        population: the DE's population N (None: the default).
        config: a `PlanConfig` whose other settings the plans use (its seed and, when given,
            budget and population replaced); None: the defaults.
        reference: "default" (the default scheduler's f on the same map and seed) or
            "percent" (1 % of the stage's starting f).
        cache: keep each (map, plan seed)'s pipeline up to `improve` and start its episodes
            from copies (`PipelineRun.fork`, the same episode to the bit): a trainer that
            revisits its cases pays the prefix once (memory: one run's state per case).

    Raises:
        ValueError: one line naming the field for a bad reference or budget.
    """

    metadata = {"render_modes": []}

    def __init__(self, maps: Sequence[Any] | None = None, *, budget: int = 10_000,
                 population: int | None = None, reference: str = "default",
                 config: Any = None, cache: bool = False) -> None:
        from planner_core import defaults as D
        from planner_core.pipeline import PlanConfig

        if reference not in ("default", "percent"):
            raise ValueError(f"reference: must be 'default' or 'percent', got {reference!r}")
        base = PlanConfig() if config is None else config
        self._base = base.replace(budget=budget,
                                  population=D.POPULATION if population is None else population)
        self.maps = None if maps is None else list(maps)
        if self.maps is not None and not self.maps:
            raise ValueError("maps: must hold at least one map, got none")
        self.reference = reference
        self.action_space = spaces.Discrete(len(_action_names()))
        self.observation_space = spaces.Box(-np.inf, np.inf, (N_FEATURES,), np.float32)
        self._problems: dict[Any, Any] = {}
        self._refs: dict[tuple[Any, int], float] = {}
        self.cache = bool(cache)
        self._prefixes: dict[tuple[Any, int], Any] = {}
        self.run: Any = None
        self.improve: Any = None
        self.result: Any = None

    # ------------------------------------------------------------------ episodes
    def _problem(self, key: Any, source: Any) -> Any:
        from planner_core.model.mapio import load_map
        from planner_core.model.problem import Problem

        if key not in self._problems:
            self._problems[key] = Problem(load_map(source).planning_map())
        return self._problems[key]

    def _draw(self, rng: np.random.Generator, options: dict[str, Any]) -> tuple[Any, Any]:
        if "map" in options:
            src = options["map"]
            key = options.get("key") or (str(src) if isinstance(src, str | Path) else id(src))
            return key, src
        if self.maps is not None:
            i = int(rng.integers(len(self.maps)))
            src = self.maps[i]
            return i, src
        from planner_core.suite import generate_map

        density, seed = int(rng.integers(8)), int(rng.integers(2**31 - 1))
        return ("gen", density, seed), generate_map(5000, density, seed)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Draw a map and a plan seed, run the pipeline up to `improve`.

        Args:
            seed: the episode's seed (map and plan seed drawn from it).
            options: "map" (a map to use), "key" (its name in the caches; default: its path,
                else the object's id), "plan_seed" (the plan's seed, >= 0).

        Returns:
            (observation (N_FEATURES,) float32, info with "map", "plan_seed", "f_start",
            "f_reference").

        Raises:
            NoImprovingStageError: the map given in `options` leaves the improving stage
                nothing to do.
            RuntimeError: no drawn map let the improving stage run in `MAX_DRAWS` draws.
        """
        from planner_core.pipeline.pipeline import DEFAULT_PIPELINE, PipelineRun
        from planner_core.pipeline.schedule import ImproveRun

        super().reset(seed=seed)
        options = dict(options or {})
        rng = self.np_random
        for _ in range(MAX_DRAWS):
            key, src = self._draw(rng, options)
            plan_seed = int(options.get("plan_seed", rng.integers(2**31 - 1)))
            problem = self._problem(key, src)
            cfg = self._base.replace(seed=plan_seed)
            prefix = self._prefixes.get((key, plan_seed))
            if prefix is None:
                prefix = PipelineRun(problem, cfg, pipeline=DEFAULT_PIPELINE, evaluator=None,
                                     progress=None)
                prefix.advance(until="improve")
                if self.cache:
                    self._prefixes[(key, plan_seed)] = prefix
            if prefix.i < len(prefix.stages):
                if self.reference == "default" and (key, plan_seed) not in self._refs:
                    # the default's f from this prefix: the same as a whole default plan
                    twin = prefix.fork()
                    twin.advance()
                    self._refs[(key, plan_seed)] = float(twin.result().f)
                run = prefix.fork() if self.cache else prefix
                if run.enter():
                    break
            if "map" in options:
                raise NoImprovingStageError(
                    f"map {key}: its improving stage does not run at plan seed {plan_seed} and "
                    f"budget {cfg.budget} (the incumbent is infeasible when it starts, or the "
                    "stages before it spend the whole budget: a larger budget leaves it some)")
        else:
            raise RuntimeError(f"no drawn map let the improving stage run in {MAX_DRAWS} draws")
        self.run, self.problem, self.key, self.cfg = run, problem, key, cfg
        self.improve = ImproveRun(run.state, run.ev)
        self.result = None
        self._tracker = ScheduleFeatures(problem, cfg)
        obs = self._tracker(self.improve.observe())
        self.f_start = float(self._tracker.f_start)
        self.stage_budget = self._tracker.stage_budget
        self.f_scale = self._tracker.f_scale
        if self.reference == "default":
            ref = self._refs[(key, plan_seed)]
            self.gap = max(self.f_start - ref, 1e-9 * max(abs(self.f_start), 1.0))
        else:
            ref = self.f_start
            self.gap = 0.01 * max(abs(self.f_start), 1e-9)
        self.f_reference = ref
        info = {"map": key, "plan_seed": plan_seed, "f_start": self.f_start,
                "f_reference": ref}
        return obs, info

    def step(self, action: int | np.integer) -> tuple[np.ndarray, float, bool, bool,
                                                       dict[str, Any]]:
        """Run one macro-action (`ACTIONS[action]`).

        Args:
            action: index into `ACTIONS` ("stop" ends the stage).

        Returns:
            (observation, reward, terminated, truncated (always False), info with "action",
            "evaluations" and, at the end, "f", "phi").

        Raises:
            RuntimeError: a step before `reset` or after the episode ended.
        """
        if self.improve is None or self.result is not None:
            raise RuntimeError("step: call reset() first (the episode has ended)")
        name = _action_names()[int(action)]
        info: dict[str, Any] = {"action": name, "evaluations": 0}
        reward = 0.0
        from planner_core.pipeline import TimeLimitReached

        stopped = ""
        if name != "stop":
            try:
                rec = self.improve.act(name)
            except TimeLimitReached:
                stopped, rec = "time limit", None
            if rec is not None:
                info["evaluations"] = rec.evaluations
                reward = (rec.f_before - rec.f_after) / self.gap
        done = name == "stop" or bool(stopped) or not self.improve.can_continue
        if done:
            self.run.leave(self.improve.state, stopped)
            self.run.advance()
            self.result = self.run.result()
            info.update(f=self.result.f, phi=self.result.phi)
            if self.result.phi > 0:
                reward -= INFEASIBLE_PENALTY
        return self._features(), float(reward), done, False, info

    # ------------------------------------------------------------------ features
    def observation(self) -> Any:
        """The structured `schedule.Observation` a `Scheduler` would see now.

        Returns:
            The improving stage's current `schedule.Observation`.
        """
        return self.improve.observe()

    def _features(self) -> np.ndarray:
        return self._tracker(self.improve.observe())


class ScheduleFeatures:
    """The observation vector (`FEATURES`, (N_FEATURES,) float32) from what a `Scheduler`
    sees (`schedule.Observation`): the env's observation and a learned scheduler's input, one
    definition for both.

    Call it on each observation of one improving stage, in order: the first fixes the stage's
    start (f, evaluations left, the best feasible pool f as the per-map scale); each call reads
    the step records added since the last one (each action's gain per 1,000 evaluations in
    percent of the starting f, as a running mean with weight `EMA`, its uses, the actions since
    the last gain).

    Args:
        problem: the run's `Problem`; config: its `PlanConfig` (for the time limit).

    Cost: one `Problem.breakdown` (O(I x J)) of the incumbent and of each pool plan not read
    before (up to 12 structures) per call.
    """

    def __init__(self, problem: Any, config: Any) -> None:
        self.problem, self.config = problem, config
        self.f_start: float | None = None
        self._gain = dict.fromkeys(_MOVES, 0.0)
        self._uses = dict.fromkeys(_MOVES, 0)
        self._since = 0
        self._seen = 0
        self._npoints: dict[int, int] = {}

    def __call__(self, obs: Any) -> np.ndarray:
        from planner_core.pipeline.schedule import IDLE_ROUNDS, pool_structures

        problem, state = self.problem, obs.state
        pool = state.pool
        if self.f_start is None:
            self.f_start, self.stage_budget = float(obs.f), max(int(obs.remaining), 1)
            feas = pool.f[pool.phi == 0] if len(pool) else np.zeros(0)
            self.f_scale = float(feas.min()) if len(feas) else self.f_start
        for rec in obs.history[self._seen:]:
            if rec.action in self._gain:
                gain = rec.f_before - rec.f_after
                per = gain / self.f_start * 100.0 / max(rec.evaluations, 1) * 1000.0
                self._gain[rec.action] = EMA * per + (1 - EMA) * self._gain[rec.action]
                self._uses[rec.action] += 1
                self._since = 0 if gain > 0 else self._since + 1
        self._seen = len(obs.history)
        f = float(obs.f)
        x = obs.x if obs.x is not None else np.zeros(problem.dim)
        b = problem.breakdown(np.asarray(x, dtype=float))
        imax = max(problem.n_points, 1)
        short = sum(1 for v in b["shortfall"].values() if v > 0)
        n_sensors = max(len(b["shortfall"]), 1)
        best_by_n = pool_structures(problem, pool, limit=12, cache=self._npoints)
        gaps = sorted(v for k, v in best_by_n.items() if k != b["n_hover"])
        gaps = [(g - f) / max(abs(f), 1e-9) * 100.0 for g in gaps] + [0.0, 0.0]
        finished = len(set(best_by_n) & set(state.finished)) / max(len(best_by_n), 1)
        other = any(n > 0 and n not in state.finished for n in best_by_n)
        tl = getattr(self.config, "time_limit", None)
        time_left = 1.0 if tl is None else max(1.0 - obs.elapsed / tl, 0.0)
        n_obst = problem.map.spec.obstacles.count
        steps = max(obs.step, 1)
        v = [
            obs.remaining / max(obs.budget, 1),
            obs.remaining / self.stage_budget,
            time_left,
            (f / max(self.f_scale, 1e-9) - 1.0) * 100.0,
            (f / max(self.f_start, 1e-9) - 1.0) * 100.0,
            _log(obs.phi), _log(b["v3"]), _log(b["v4"]), _log(b["v5"]),
            short / n_sensors,
            b["n_hover"] / imax,
            len(best_by_n) / 12.0,
            gaps[0], gaps[1],
            finished,
            float(other),
            obs.step / 100.0,
            obs.idle / IDLE_ROUNDS,
            self._since / 10.0,
            *(self._gain[a] for a in _MOVES),
            *(self._uses[a] / steps for a in _MOVES),
            n_sensors / 100.0,
            n_obst / 50.0,
            problem.map.width * problem.map.height / 1e6 / 100.0,
            imax / 50.0,
        ]
        return np.asarray(v, dtype=np.float32)


if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="planner_core.learning.schedule_env:ScheduleEnv")
