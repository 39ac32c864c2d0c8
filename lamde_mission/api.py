"""`plan(map, ...) -> Plan`: the public planning call (map -> problem -> DE -> polish -> Plan)."""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from lamde_mission.result import Plan
from planner_core import defaults as _defaults
from planner_core.model.formulas import deb_better, deb_not_worse

__all__ = ["plan", "CONFIGURATORS", "INIT_MODES"]

#: configurator names accepted by `plan` (from `planner_core.defaults`); the adaptive DE is the
#: default until a trained policy beats it on unseen maps
CONFIGURATORS = _defaults.CONFIGURATORS
#: start modes accepted by `plan` (planner_core.search.init_modes), the default first
INIT_MODES = _defaults.INIT_MODES


class _TimedProblem:
    """Wraps a problem to add up the wall time spent in `evaluate` and in building the initial
    population (the rest of the DE's time is optimiser work)."""

    def __init__(self, problem: Any):
        self.problem = problem
        self.lower = problem.lower
        self.upper = problem.upper
        self.seconds = 0.0
        self.seeding_seconds = 0.0
        if hasattr(problem, "initial_population"):
            self.initial_population = self._initial_population

    def _initial_population(self, rng: np.random.Generator, n: int) -> np.ndarray:
        t0 = time.perf_counter()
        out = self.problem.initial_population(rng, n)
        self.seeding_seconds += time.perf_counter() - t0
        return out

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t0 = time.perf_counter()
        out = self.problem.evaluate(X)
        self.seconds += time.perf_counter() - t0
        return out


_WARM: set[str] = set()


def kernels_cached() -> bool:
    """Whether numba has compiled kernels cached on disk (a fresh install has none: the first
    `plan` then compiles them, which takes a while; later processes load them)."""
    from pathlib import Path

    import planner_core

    return any(Path(planner_core.__file__).parent.rglob("*.nbi"))


def _warm_up(problem: Any, configurator: Any, run: Callable[..., Any]) -> float:
    """Compile (or load from the disk cache) every kernel the run will call, once per process
    and configurator, with a throw-away run of one generation; its wall time is reported as
    `timings["compile"]`, not as optimisation. The real run is untouched (it draws from its own
    seeded generator; the problem keeps no state but a cache)."""
    key = configurator if isinstance(configurator, str) else type(configurator).__name__
    if key in _WARM or not isinstance(configurator, str):
        return 0.0
    t0 = time.perf_counter()
    n = _defaults.MIN_POPULATION
    run(problem, configurator=configurator, seed=0, population=n, budget=3 * n)
    _WARM.add(key)
    return time.perf_counter() - t0


def _deb_not_worse(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """True when breakdown `a` is at least as good as `b` under Deb's ranking."""
    return bool(deb_not_worse(a["f"], a["phi"], b["f"], b["phi"]))


def plan(
    map: str | Path | dict | Any,  # noqa: A002 - the issue's public signature
    *,
    seed: int = _defaults.SEED,
    budget: int = _defaults.BUDGET,
    population: int = _defaults.POPULATION,
    configurator: str | Any = _defaults.CONFIGURATOR,
    init: str = _defaults.INIT,
    memetic: str = _defaults.MEMETIC,
    starts: int = _defaults.STARTS,
    descent: bool = True,
    variable_length: bool = True,
    polish: bool = True,
    progress: Callable[[Any], None] | None = None,
) -> Plan:
    """Plan hover points and hover times for `map` (a path, dict or Map); same seed, same plan.

    `progress` is called once per generation with a record holding generation, evaluations,
    budget, best_f, best_phi and feasible_fraction. The plan is made on `Map.planning_map()`:
    obstacles inflated by the map's `safety.clearance`, required data raised by its
    `safety.data_margin` (the map itself when both are 0); `breakdown` is on that map. With
    `polish`, the hover times of the final population's `planner_core.search.polish.ELITE` Deb-best
    individuals are re-solved by the LP of `planner_core.search.polish`; the Deb-best of those is
    kept
    if not worse than the DE's best under Deb's rule. `configurator`: "adaptive" (default),
    "fixed", "random", "lamde" (the shipped learned policy, planner_core.learning.policy) or a
    configurator object. `init`: "seeded" (the problem's sensor-aware starts, default) or
    "uniform" (the paper's protocol: uniform in the box). `memetic`: "auto" (default: on for
    the uniform start, off for the seeded one), "on" or "off": the memetic step on the elite
    every 10 generations (`planner_core.search.refine`: 2-opt, LP hover times, removals, and for an
    infeasible elite a point above each unserved sensor and its blocked legs re-routed); its
    evaluations count against the budget. `starts`: how many constructive plans
    (`planner_core.search.construct`: greedy set covers and a k-means sweep of hover sites, an
    open-path order on obstacle-aware flight times, visibility-graph detours, LP hover times)
    go into the DE's initial population, the Deb-best of the first
    `planner_core.defaults.START_CANDIDATES` built (0: none). Every evaluation counts against
    `budget`: the constructive plans scored, the DE, and the polish's LP plans (the DE runs on
    what is left), so `evaluations` <= budget (budget + 1 when budget equals the population:
    the DE has only its start population and the polish its one LP plan). `descent`: the
    hover-point descent with exact LP hover times (`planner_core.search.descent`) on the
    `planner_core.defaults.DESCENTS` best constructive and seeder plans before the DE (each at
    most `DESCENT_TRIALS` evaluations) and, with `polish`, on the final plan after the polish
    (`planner_core.search.final.finish`: descent, structural search, kicks; at most
    `DESCENT_TRIALS` + `RESTRUCTURE_TRIALS` + `KICK_TRIALS` evaluations), and the same on the
    best of the starts kept for the DE with fewer (else more) hover points (at most
    `OTHER_TRIALS` more, which the final plan gets when there is none; the better plan is
    kept; it runs only when at least `DESCENT_TRIALS` are left for it), the final stage at
    most a tenth of the budget less the population and the polish's plans, all counted in the
    budget; an infeasible final plan is not descended and leaves that share unspent.
    Defaults and valid ranges: `planner_core.defaults`.

    Raises ValueError with one line naming the field ("population: must be an integer >= 6,
    got 5") for a population below the minimum, a budget below the population or an unknown
    configurator name; `planner_core.MapError` for a bad map.
    """
    from planner_core.model.mapio import load_map
    from planner_core.model.problem import Problem
    from planner_core.search.de import run
    from planner_core.search.init_modes import with_init
    from planner_core.search.refine import refine as memetic_refine
    from planner_core.search.refine import use_memetic

    _defaults.check_run_args(population=population, budget=budget, configurator=configurator,
                             init=init, memetic=memetic, starts=starts)
    t_start = time.perf_counter()
    m = load_map(map)
    # safety margins (clearance, data margin) are a transformation of the map: the model is the
    # paper's, on the inflated map (the same map when both margins are 0)
    problem = Problem(m.planning_map(), variable_length=variable_length)
    t_compile = _warm_up(problem, configurator, run)
    timed = _TimedProblem(with_init(problem, init))
    refine = None
    if use_memetic(memetic, timed):  # timed has the seeding hook exactly when init is seeded
        refine = functools.partial(memetic_refine, problem)
    from planner_core.search.construct import start_from_plans
    from planner_core.search.final import final_budget
    from planner_core.search.polish import ELITE

    # the budget holds everything: the constructive plans scored, the DE, the polish's plans
    reserve = min(ELITE, int(budget) // 4, int(budget) - int(population)) if polish else 0
    room = max(int(budget) - reserve - int(population), 0)
    # the final plan's descent, structural search and kicks: part of the polish
    own = (_defaults.DESCENT_TRIALS + _defaults.RESTRUCTURE_TRIALS + _defaults.KICK_TRIALS
           if descent and polish else 0)
    final = final_budget(room, own + _defaults.OTHER_TRIALS if own else 0)
    room -= final
    t0 = time.perf_counter()
    opt, spent = start_from_plans(problem, timed, int(seed), starts=int(starts),
                                  candidates=min(_defaults.START_CANDIDATES, room),
                                  descents=_defaults.DESCENTS if descent else 0,
                                  trials=_defaults.DESCENT_TRIALS, room=room)
    t_starts = time.perf_counter() - t0 - timed.seconds  # construction, not its evaluations
    callback = progress
    if progress is not None and spent:
        def callback(p: Any) -> None:  # the run's evaluations, the constructive plans included
            progress(p._replace(evaluations=p.evaluations + spent, budget=int(budget)))

    t0 = time.perf_counter()
    seconds0 = timed.seconds
    result = run(
        opt,
        configurator=configurator,
        seed=int(seed),
        population=int(population),
        budget=int(budget) - reserve - final - spent,
        callback=callback,
        refine=refine,
    )
    t_optimise = time.perf_counter() - t0
    t_run_eval = timed.seconds - seconds0
    best = problem.breakdown(result.x)
    chosen = best
    polish_info = None
    t_polish = 0.0
    polished = 0
    if polish:
        from planner_core.model.formulas import deb_best
        from planner_core.search.de.core import to_problem
        from planner_core.search.polish import polish_elite

        t1 = time.perf_counter()
        # the LP for the final population's elite, not only its Deb-best (docs/search.md)
        st = result.state
        xs, pols = polish_elite(problem, to_problem(problem, st.X), st.f, st.phi,
                                max(reserve, 1))
        polished = len(xs)
        fs, phis = problem.evaluate(xs)
        c = deb_best(fs, phis)
        pol = pols[c]
        after = problem.breakdown(xs[c])
        accepted = _deb_not_worse(after, best)
        if accepted:
            chosen = after
        t_polish = time.perf_counter() - t1
        polish_info = {
            "f_before": best["f"],
            "phi_before": best["phi"],
            "f_after": after["f"],
            "phi_after": after["phi"],
            "accepted": accepted,
            "dropped_points": list(pol.dropped),
            "c3_violation": pol.c3_violation,
            "c4_achievable": pol.feasible_c4,
            "unserved": [u["message"] for u in pol.unserved],
            "solver": pol.solver,
        }
    t_descent = 0.0
    descended = 0
    if final and chosen["phi"] == 0.0:
        from planner_core.search.final import final_stage

        t1 = time.perf_counter()
        # the final plan's hover points moved with exact LP hover times, then its structure
        x = problem.encode(chosen["hover_points"], chosen["hover_times"])
        f_before = float(chosen["f"])
        # and the best start of another structure with what the final plan's own share
        # leaves (all of it for the final plan when the starts hold no other structure)
        r = final_stage(problem, x, problem.evaluate, final=final, own=own,
                        starts=getattr(opt, "starts", None), seed=int(seed))
        if r is not None:
            descended = r.evaluations
            if deb_better(r.f, r.phi, chosen["f"], chosen["phi"]):
                chosen = problem.breakdown(r.x)
        if polish_info is not None:  # what the final stage did, for the summary
            polish_info["final_f_before"] = f_before
            polish_info["final_f_after"] = float(chosen["f"])
            polish_info["final_evaluations"] = int(descended)
            polish_info["final_other_points"] = 0 if r is None else int(r.other_points)
            polish_info["final_other_won"] = r is not None and bool(r.other_won)
            polish_info["final_other_evaluations"] = 0 if r is None else int(r.other_evaluations)
        t_descent = time.perf_counter() - t1
    wall = time.perf_counter() - t_start
    h = result.history
    name = configurator if isinstance(configurator, str) else type(configurator).__name__
    return Plan(
        map_name=m.name,
        hover_points=np.array(chosen["hover_points"], dtype=float).reshape(-1, 2),
        hover_times=np.array(chosen["hover_times"], dtype=float),
        f=chosen["f"],
        phi=chosen["phi"],
        feasible=chosen["phi"] == 0.0,
        breakdown=chosen,
        evaluations=spent + int(result.evaluations) + polished + descended,
        wall_time=wall,
        history={
            "evaluations": h.evaluations + spent,
            "best_f": h.best_f,
            "best_phi": h.best_phi,
            "feasible_fraction": h.feasible_fraction,
        },
        seed=int(seed),
        configurator=name,
        variable_length=variable_length,
        polish=polish_info,
        timings={
            "evaluation": timed.seconds,
            "seeding": timed.seeding_seconds,
            "optimiser": max(t_optimise - t_run_eval - timed.seeding_seconds, 0.0),
            "starts": t_starts,
            "polish": t_polish,
            "descent": t_descent,
            "compile": t_compile,
            "total": wall,
        },
    )
