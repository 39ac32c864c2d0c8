"""`plan(map, ...) -> Plan`: the public planning call (map -> problem -> pipeline -> Plan)."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from lamde_mission.result import Plan
from planner_core import defaults as _defaults

__all__ = ["plan", "plan_fleet", "CONFIGURATORS", "INIT_MODES", "kernels_cached"]

#: configurator names accepted by `plan` (from `planner_core.defaults`); the adaptive DE is the
#: default until a trained policy beats it on unseen maps
CONFIGURATORS = _defaults.CONFIGURATORS
#: start modes accepted by `plan` (planner_core.search.init_modes), the default first
INIT_MODES = _defaults.INIT_MODES


def kernels_cached() -> bool:
    """Whether numba's disk cache holds the planner's kernels (a fresh install, or an empty
    `NUMBA_CACHE_DIR`, has none: the first `plan` then compiles them, which takes a while;
    later processes load them).

    Probes the cache index of the open-path solver, which only the warm-up compiles: loading
    a map compiles two geometry kernels first, so "any kernel cached" announced "loading" on a
    first run. Falls back to any cached kernel under the package if numba's cache layout
    differs.

    Returns:
        True when the open-path solver's cache index exists (or, on the fallback, any `.nbi`
        index under `planner_core`).
    """
    try:
        from planner_core.model.routing.tour import open_path

        return Path(open_path._cache._cache_file._index_path).exists()
    except (ImportError, AttributeError, TypeError):
        import planner_core

        return any(Path(planner_core.__file__).parent.rglob("*.nbi"))


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
    time_limit: float | None = None,
    config: Any = None,
    progress: Callable[[Any], None] | None = None,
    on_compile: Callable[[], None] | None = None,
    scheduler: str | Any = "default",
    corner_slots: int | str = "auto",
    on_setup: Callable[[str | None], None] | None = None,
    on_setup_progress: Callable[[str, float], None] | None = None,
) -> Plan:
    """Plan hover points and hover times for `map`; same seed and budget, same plan.

    One flight, whatever the map's battery: for a map with `uav.battery` (or
    `uav.endurance_s`) or a `fleet`, `plan_fleet` plans the sorties a battery can fly.

    Runs the declared pipeline (`planner_core.pipeline.DEFAULT_PIPELINE`: constructive plans,
    their descents, the DE, the LP polish, the final stage on the incumbent and on a second
    structure, then improving rounds, or the repair while infeasible) through one counted
    evaluator; the plan is the Deb-best of everything evaluated, made on
    `Map.planning_map()` (obstacles inflated by `safety.clearance`, required data raised by
    `safety.data_margin`), and `breakdown` is on that map.

    Args:
        map: a map file path, its JSON as a dict, or a `planner_core.Map`.
        seed: random seed, >= 0.
        budget: evaluations in all, from the population to
            `planner_core.defaults.MAX_BUDGET`; every stage's are counted.
        population: the DE's population N (6 to 10,000, `defaults.MAX_POPULATION`).
        configurator: "adaptive" (default), "fixed", "random", "lamde" (the shipped learned
            policy) or a configurator object.
        init: "seeded" (the problem's sensor-aware starts) or "uniform" (the paper's protocol).
        memetic: "auto" (on for the uniform start), "on" or "off": the DE's memetic step.
        starts: constructive plans put into the DE's initial population (0: none).
        descent: False turns off the descents and every stage after the polish.
        variable_length: False flies all I_max points (LAMDE-F).
        polish: False turns off the LP polish and every stage after it.
        time_limit: seconds (> 0) after which the improving stages stop and the best plan so
            far is returned (the one-time kernel compile is not counted); a time limit trades
            determinism for a deadline. None: the budget alone ends the run.
        config: a `planner_core.pipeline.PlanConfig` holding all of the above (then the
            keyword settings are ignored).
        progress: called after every evaluation batch with a
            `planner_core.pipeline.Progress` (stage, evaluations, budget, best_f, best_phi,
            seconds).
        on_compile: called once before the kernels are compiled or loaded (the CLI's notice).
        on_setup: called with the name of each setup stage as it starts (reading and inflating
            the map; the visibility graph and the corner-slot rule) and with None as it ends
            (the CLI's progress lines). Setup is not cut by `time_limit`: the planner needs its
            result; it grows with the obstacles (a 10 km map of 5,000 small rectangles and 50
            sensors: see docs/planning.md).
        on_setup_progress: called during a setup stage that can tell how far it is with what
            it is doing and the fraction of it done: ("the visibility graph", f), f increasing
            to 1.0 (`build_visibility_graph`'s `progress`: node pairs tested, after each block
            of ~4 million; a minute at 2,000 campus footprints). None: nothing.
        scheduler: the improving stage's scheduler (issue 34's LAMDE-S seam,
            `planner_core.pipeline.schedule`): "default" (today's rounds), a static schedule's
            name (`schedule.SCHEDULES`: a fixed cycle of macro-actions), "lamde-s" (the
            learned selector of a schedule, `planner_core.learning.schedule_select`),
            "lamde-s-ppo" (the policy trained by PPO, `planner_core.learning.schedule_policy`)
            or a `Scheduler` object; a non-default one is recorded as `config["scheduler"]`,
            and the schedule a learned one chose (lamde-s) as `config["scheduler_choice"]`.
        corner_slots: K > 0: detour corners do not count against I_max (issue 31; docs/
            missions.md): the encoding gets K extra slots and at most I_max points with t > 0
            are feasible, the others (0 s) are corners, written as NAV_WAYPOINT. 0: the
            paper's model, every point a slot. "auto" (default): K from the map
            (`planner_core.model.corner_slots.auto_corner_slots`: the blocked legs of the
            seeder's plans within I_max; 0 on the paper's suite maps, 4 on campus-500).
            The K planned with is recorded as `config["corner_slots"]` (and
            `config["corner_slots_rule"]` = "auto" when the rule chose it).

    Returns:
        The `Plan`, with `stages` (per stage: evaluations, seconds, f before and after) and
        `timings` (seconds): compile (loading or compiling the kernels, the first call in
        a process), setup (reading the map, its margins, building the problem and choosing
        "auto" corner slots), planning (the pipeline's stages), evaluation (the part of
        planning spent in the counted evaluator) and total (the whole call: compile + setup +
        planning and the plan's breakdown).

    Raises:
        ValueError: one line naming the field ("population: must be an integer >= 6, got 5")
            for any setting outside its range (`planner_core.defaults`), or corner_slots
            neither "auto" nor an integer >= 0 (or > 0 with variable_length False).
        planner_core.MapError: a bad map.
    """
    from planner_core.model.corner_slots import AUTO, check_corner_slots, problem_for
    from planner_core.model.mapio import load_map
    from planner_core.pipeline import PlanConfig, run_pipeline
    from planner_core.pipeline.schedule import make_scheduler, scheduler_name
    from planner_core.pipeline.warmup import warm_up, warmed

    if config is None:
        config = PlanConfig(seed=seed, budget=budget, population=population,
                            configurator=configurator, init=init, memetic=memetic,
                            starts=starts, descent=descent, variable_length=variable_length,
                            polish=polish, time_limit=time_limit)
    elif not isinstance(config, PlanConfig):
        raise ValueError(f"config: must be a PlanConfig, got {type(config).__name__}")
    make_scheduler(scheduler)  # "scheduler: must be one of ...", before any work
    # "corner_slots: must be 'auto' or ...", before any work
    if check_corner_slots(corner_slots) != AUTO and corner_slots and not config.variable_length:
        raise ValueError("corner_slots: fixed-length mode flies every slot; use 0 or 'auto'")
    default_schedule = isinstance(scheduler, str) and scheduler == "default"
    def stage(name: str | None) -> None:
        if on_setup is not None:
            on_setup(name)

    t_start = time.perf_counter()
    stage("reading the map and inflating its obstacles")
    m = load_map(map)
    # safety margins (clearance, data margin) are a transformation of the map: the model is the
    # paper's, on the inflated map (the same map when both margins are 0)
    planning_map = m.planning_map()
    stage(None)
    t_setup = time.perf_counter() - t_start
    if on_compile is not None and not warmed(config.configurator):
        on_compile()
    t_compile = warm_up(config.configurator)
    t0 = time.perf_counter()
    # "auto" corner slots are resolved from the planning map (after the kernels load: the rule
    # draws seeder plans) before the problem is built (K = 0: the paper's Problem)
    stage("building the visibility graph round the obstacles and choosing the corner slots")
    graph_progress = (None if on_setup_progress is None
                      else lambda f: on_setup_progress("the visibility graph", f))
    problem, k_corner = problem_for(planning_map, variable_length=config.variable_length,
                                    corner_slots=corner_slots, progress=graph_progress)
    stage(None)
    t_setup += time.perf_counter() - t0
    result = run_pipeline(problem, config, progress=progress,
                          scheduler=None if default_schedule else scheduler)
    best = problem.breakdown(result.x)
    settings = result.state.config.to_dict()  # as run: a scheduler may set the DE's share
    if not default_schedule:
        settings["scheduler"] = scheduler_name(scheduler)
        if result.state.schedule is not None:  # the template a learned scheduler chose
            settings["scheduler_choice"] = result.state.schedule
    if isinstance(corner_slots, str):  # "auto" (checked above): the K it resolved to
        settings["corner_slots"] = k_corner
        settings["corner_slots_rule"] = AUTO
    elif k_corner:
        settings["corner_slots"] = k_corner
    wall = time.perf_counter() - t_start
    ev_seconds = sum(s.evaluate_seconds for s in result.stages)
    return Plan(
        map_name=m.name,
        hover_points=np.array(best["hover_points"], dtype=float).reshape(-1, 2),
        hover_times=np.array(best["hover_times"], dtype=float),
        f=best["f"],
        phi=best["phi"],
        feasible=best["phi"] == 0.0,
        breakdown=best,
        evaluations=result.evaluations,
        wall_time=wall,
        history=result.trace,
        seed=config.seed,
        configurator=config.configurator_name,
        variable_length=config.variable_length,
        polish=result.state.polish,
        timings={
            "compile": t_compile,
            "setup": t_setup,
            "planning": result.seconds,
            "evaluation": ev_seconds,
            "total": wall,
        },
        stages=result.stages,
        config=settings,
        stopped=result.stopped,
    )


def check_fleet_map(m: Any) -> None:
    """Refuse a map the sortie planner cannot plan (`plan_fleet` and `plan MAP -o DIR/` call it
    before any work).

    Args:
        m: a loaded map (`planner_core.model.mapio.Map`).

    Raises:
        ValueError: one line naming the field: neither `uav.battery` nor `fleet` given, or
            `radio.access` "scheduled" (the LP across sorties, `planner_core.fleet.lp`, bounds
            each point's rates by C3, the paper's simultaneous uplink; the scheduled model's
            per-sensor data variables are not in it).
    """
    if not (m.has_battery or m.has_fleet):
        raise ValueError("uav.battery: the map has no battery and no fleet; plan() plans its "
                         "one flight")
    if m.spec.radio.access != "simultaneous":
        raise ValueError(f"radio.access: {m.spec.radio.access!r} is not planned as sorties yet "
                         "(the sortie planner models the paper's simultaneous access); give "
                         "'simultaneous' or plan one flight without uav.battery and fleet")


def plan_fleet(
    map: str | Path | dict | Any,  # noqa: A002 - as `plan`
    *,
    seed: int = _defaults.SEED,
    budget: int = _defaults.BUDGET,
    goal: str | None = None,
    sortie_budget: int | None = None,
    rounds: int | None = None,
    config: Any = None,
    progress: Callable[..., None] | None = None,
) -> Any:
    """Plan the sorties and vehicles for a map with a battery or a fleet (issue 33); same
    seed, same plan.

    `planner_core.fleet.plan_fleet`: the single flight by the declared pipeline, cut into
    battery-sized sorties with depot choice (route first, cluster second) and a cluster-first
    start, then rounds of sortie re-plans by the pipeline, merges, transfers and re-splits,
    every change scored by the hover-time LP across sorties (docs/sorties.md). Write the result
    with `lamde_mission.sorties.write_sortie_dir` (what `lamde-mission plan MAP -o DIR/` does).

    Args:
        map: a map file path, its JSON as a dict, or a `planner_core.Map`, with a battery
            (`uav.battery` or `uav.endurance_s`) or a `fleet`.
        seed: random seed, >= 0.
        budget: evaluations of the single flight's pipeline, an integer in [population,
            `planner_core.defaults.MAX_BUDGET`].
        goal: "total" (the paper's f summed over sorties + swap_s per swap) or "makespan"
            (the longest vehicle's time); None: the map's `objective.goal`.
        sortie_budget: evaluations of each pipeline run on one sortie's or depot's sensors,
            an integer in [population, `planner_core.defaults.MAX_BUDGET`] (default
            `planner_core.fleet.search.SORTIE_BUDGET`).
        rounds: improving rounds at most (default `planner_core.fleet.search.ROUNDS`).
        config: a `planner_core.pipeline.PlanConfig` for the pipeline runs (then seed and
            budget are its own).
        progress: called with a line (str) saying what the search does next, at each phase,
            and with `step=True` at each move of a round (`planner_core.fleet.plan_fleet`);
            None: nothing said.

    Returns:
        A `planner_core.fleet.FleetResult`: `plan` (the `FleetPlan`: vehicles x sorties, on
        the planning map), `peer` (the route-first cluster-second plan of the same single
        flight), `single` (that flight's hover points and times).

    Raises:
        ValueError: one line naming the field: a setting out of range, a map with neither
            battery nor fleet, `radio.access` "scheduled" (not planned as sorties), an unknown
            goal, or no sorties that fit the battery.
        planner_core.MapError: a bad map.
    """
    from planner_core.fleet import search
    from planner_core.model.mapio import load_map
    from planner_core.pipeline import PlanConfig
    from planner_core.pipeline.warmup import warm_up

    m = load_map(map)
    check_fleet_map(m)
    if goal is not None and goal not in _defaults.GOALS:
        raise ValueError(f"goal: must be one of {', '.join(_defaults.GOALS)}, got {goal!r}")
    if config is None:
        config = PlanConfig(seed=seed, budget=budget)
    elif not isinstance(config, PlanConfig):
        raise ValueError(f"config: must be a PlanConfig, got {type(config).__name__}")
    sb = search.SORTIE_BUDGET if sortie_budget is None else sortie_budget
    _defaults.check_budget(sb, config.population, "sortie_budget")
    r = search.ROUNDS if rounds is None else int(rounds)
    if r < 0:
        raise ValueError(f"rounds: must be >= 0, got {r}")
    warm_up(config.configurator)
    result = search.plan_fleet(m, config, goal=goal, sortie_budget=sb, rounds=r,
                               progress=progress)
    if (goal or m.goal) != "makespan" or len(result.plan.vehicles) < 2:
        return result
    return _fewer_vehicles(m, result, lambda k: search.plan_fleet(
        m, config, goal=goal, sortie_budget=sb, rounds=r, progress=progress, uavs=k),
        progress)


#: with the makespan goal, fewer vehicles are planned too when the vehicles' staggered
#: launches (`lamde_mission.launches.stagger`: a vehicle waits until it meets none launched
#: before it in the air and hears no sensor one of them hears) make the fleet's makespan more
#: than this share longer than the sortie planner's, which plans each vehicle as if it flew
#: alone: 3 UAVs on examples/maps/fleet-demo.json flew 494.5 s (launches at +160 and +260 s)
#: where the plan of 2 flies 344.0 s
STAGGER_SLACK = 0.1
#: plans of fewer vehicles tried at most (each a whole sortie planner's run)
FEWER_TRIES = 3


def _fewer_vehicles(m: Any, result: Any, plan_k: Callable[[int], Any],
                    progress: Callable[..., None] | None) -> Any:
    """The plan of `result` (makespan goal, two vehicles or more) or one of fewer vehicles,
    whichever the operator flies soonest with the launches staggered (`sorties.launch_check`:
    the fleet's makespan as the written directory gives it) and whose verdicts pass where the
    first plan's do. Only when staggering lengthens the plan's makespan by more than
    `STAGGER_SLACK`: then k = V - 1, V - 2, ... vehicles (`plan_k(k)`, on the map's own pads)
    are tried, at most `FEWER_TRIES`, while each flies sooner than the best so far. A
    heuristic ends the tries early: once the best plan's flying, hovering and swaps shared
    among k vehicles (`total_time / k`) take as long as its makespan, fewer vehicles are
    unlikely to finish sooner. The plan returned says in its notes what was tried (`plan`
    prints them) and counts every run's evaluations. A map without an origin is judged at
    (0, 0) (the stagger does not depend on where the map lies). Cost: up to `FEWER_TRIES`
    sortie planner runs, and a storage and replay of every sortie per plan judged.

    Args:
        m: the map; result: the sortie planner's `FleetResult` for it.
        plan_k: plans the map flying at most k vehicles (a `FleetResult`).
        progress: the sortie planner's progress callback, or None.

    Returns:
        A `FleetResult`.
    """
    from dataclasses import replace

    from lamde_mission.sorties import launch_check
    from planner_core.textio import counted

    at = m if m.spec.origin is not None else m.with_origin(0.0, 0.0)

    def flown(plan: Any) -> tuple[float, bool]:
        check = launch_check(plan, at)
        return check.fleet_makespan[0], check.passed

    best, (best_s, passed) = result, flown(result.plan)
    n = len(result.plan.vehicles)
    planned = result.plan.makespan
    if best_s <= planned * (1.0 + STAGGER_SLACK):
        return result
    notes = [f"makespan: {n} vehicles fly {best_s:.1f} s with staggered launches (planned "
             f"{planned:.1f} s as if each flew alone)"]
    spent = result.plan.evaluations  # every run's, the plans not kept too
    for k in range(n - 1, max(0, n - 1 - FEWER_TRIES), -1):
        if best.plan.total_time / k >= best_s:
            notes.append(f"makespan: {counted(k, 'vehicle')} not tried (the work shared among "
                         f"them would take {best.plan.total_time / k:.1f} s)")
            break
        if progress is not None:
            progress(f"the launches make {n} vehicles' makespan {best_s:,.1f} s: planning "
                     f"{k} vehicles")
        try:
            r = plan_k(k)
        except ValueError as exc:  # no plan of k vehicles: the plans so far stand
            notes.append(f"makespan: {counted(k, 'vehicle')} not planned ({exc})")
            break
        spent += r.plan.evaluations
        got, ok = flown(r.plan)
        notes.append(f"makespan: {counted(k, 'vehicle')} fly {got:.1f} s"
                     + ("" if ok or not passed else " (a verdict fails: not kept)"))
        if not (got < best_s and (ok or not passed)):
            break
        best, best_s = r, got
    best.plan = replace(best.plan, notes=(*best.plan.notes, *notes), evaluations=spent)
    return best
