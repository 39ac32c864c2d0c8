"""The stages of a plan, each a small object with a name, a budget rule and `run(state,
evaluator) -> state` (the `Stage` protocol); `planner_core.pipeline.pipeline` declares their
order and shares.

A stage reads the run's `PlanState`, evaluates only through the `Evaluator` (which refuses
anything beyond the stage's allotment and keeps the incumbent: the best of everything
evaluated), and returns a new state. No stage calls another stage. J sensors, I hover points
(<= I_max), V obstacle vertices; each stage's docstring says how its cost grows.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from planner_core.model.formulas import deb_order
from planner_core.pipeline.config import PlanConfig
from planner_core.pipeline.evaluator import Evaluator
from planner_core.pipeline.schedule import _points
from planner_core.streams import stream_seed

__all__ = [
    "ConstructivePlans",
    "DifferentialEvolution",
    "FinishIncumbent",
    "Improve",
    "OtherStructure",
    "PlanState",
    "Polish",
    "Pool",
    "Repair",
    "Stage",
    "StartDescents",
]


@dataclass(frozen=True)
class Pool:
    """Plans scored so far outside the DE (constructive, seeder, descended): X (m, d) problem
    space, f (m,), phi (m,), and each row's kind ("constructive", "seeder", "descended",
    "fresh")."""

    X: np.ndarray
    f: np.ndarray
    phi: np.ndarray
    kinds: tuple[str, ...] = ()

    @classmethod
    def empty(cls, d: int) -> Pool:
        """A pool with no plans.

        Args:
            d: the decision vectors' length.

        Returns:
            The `Pool`, X (0, d).
        """
        return cls(np.zeros((0, d)), np.zeros(0), np.zeros(0), ())

    def add(self, X: np.ndarray, f: np.ndarray, phi: np.ndarray, kind: str) -> Pool:
        """A new pool with scored plans appended (this one unchanged).

        Args:
            X: the plans, (k, d) problem space (read as (-1, d)).
            f: their objectives (k,), s.
            phi: their violations (k,).
            kind: all k rows' kind ("constructive", "seeder", "descended", "fresh").

        Returns:
            The `Pool` of m + k rows.
        """
        X = np.asarray(X, dtype=float).reshape(-1, self.X.shape[1])
        return Pool(np.vstack([self.X, X]), np.concatenate([self.f, np.asarray(f, float)]),
                    np.concatenate([self.phi, np.asarray(phi, float)]),
                    self.kinds + (kind,) * len(X))

    def of_kind(self, kind: str) -> np.ndarray:
        """Row indices of the plans of one kind, in order.

        Args:
            kind: "constructive", "seeder", "descended" or "fresh".

        Returns:
            (k,) int64 row indices (empty for a kind the pool lacks).
        """
        return np.flatnonzero(np.array(self.kinds) == kind)

    def ordered(self) -> np.ndarray:
        """Row indices, Deb-best first.

        Returns:
            (m,) int row indices (`deb_order` of f, phi); empty for an empty pool.
        """
        return deb_order(self.f, self.phi) if len(self.f) else np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.f)


@dataclass(frozen=True)
class PlanState:
    """What the stages hand on: the UAV problem (`planner_core.model.problem.Problem`: decode,
    encode, breakdown), the run's config, the pool of scored plans, the rows injected into the
    DE's initial population, the DE's result, the polish's record, the point counts whose
    best plan was already finished, the schedule a learned scheduler chose for the
    improving stage (`--scheduler lamde-s`: the template it follows; None otherwise) and the
    macro-actions the improving stage took, in order."""

    problem: Any
    config: PlanConfig
    pool: Pool
    injected: np.ndarray
    de: Any = None
    polish: dict[str, Any] | None = None
    finished: frozenset[int] = frozenset()
    schedule: str | None = None
    actions: tuple[str, ...] = ()

    def replace(self, **changes: Any) -> PlanState:
        """A copy with some fields changed.

        Args:
            **changes: field name -> new value.

        Returns:
            The new `PlanState`.

        Raises:
            TypeError: a name that is no field.
        """
        return dataclasses.replace(self, **changes)


class Stage(Protocol):
    """One stage: `name`; `share(config)` its evaluations (None: whatever is left when it
    runs); `reserve(config)` what earlier stages must leave for it; `applies(state,
    evaluator)` whether it runs; `run(state, evaluator) -> state`. A stage with a true
    `yields` attribute also leaves the later stages' shares (`pipeline.allotment`)."""

    name: str
    yields: bool

    def share(self, config: PlanConfig) -> int | None:
        """The evaluations this stage asks for.

        Args:
            config: the run's settings.

        Returns:
            Evaluations, or None for whatever is left when it runs.
        """
        ...

    def reserve(self, config: PlanConfig) -> int:
        """What earlier stages must leave for this one.

        Args:
            config: the run's settings.

        Returns:
            Evaluations, >= 0.
        """
        ...

    def applies(self, state: PlanState, evaluator: Evaluator) -> bool:
        """Whether the stage runs (asked only when its allotment is > 0).

        Args:
            state: the run's state before it.
            evaluator: the run's evaluator (incumbent, `remaining`).

        Returns:
            True to run it.
        """
        ...

    def run(self, state: PlanState, evaluator: Evaluator) -> PlanState:
        """Run the stage inside its allotment (`Evaluator.stage`).

        Args:
            state: the run's state before it.
            evaluator: the run's evaluator; every evaluation goes through it.

        Returns:
            The state after it.

        Raises:
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        ...


class _Base:
    """Defaults of the protocol: no reserve, runs whenever it has evaluations."""

    name = ""
    yields = False

    def share(self, config: PlanConfig) -> int | None:
        return 0

    def reserve(self, config: PlanConfig) -> int:
        return 0

    def applies(self, state: PlanState, evaluator: Evaluator) -> bool:
        return True

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


def _incumbent_feasible(ev: Evaluator) -> bool:
    return ev.has_best and ev.best()[2] == 0.0


# --------------------------------------------------------------------------------- the stages
class ConstructivePlans(_Base):
    """Whole plans built from the sensors (`planner_core.search.construct.candidate_plans`:
    greedy set covers and a k-means sweep of hover sites, an open-path order on obstacle-aware
    flight times, visibility-graph detours, LP hover times), plus `seeder` of the seeder's
    plans (`SEEDER_PLANS` by default) when the start descents run; all scored in one evaluate
    call. Cost: the k-means sweep (I_max x J), one LP per plan, the leg-time matrix over the
    graph (V^2 log V for its build, once per map), and per seeder plan its clustering and
    slides (L02, 160 sensors: 20 seeder plans 0.43 s CPU)."""

    name = "constructive"

    def __init__(self, seeder: int | None = None) -> None:
        """seeder: seeder plans built beside the constructive ones when the start descents
        run, >= 0 (None: `planner_core.search.construct.SEEDER_PLANS`; a window's run builds
        none, `planner_core.pipeline.windows`)."""
        if seeder is not None and (int(seeder) != seeder or seeder < 0):
            raise ValueError(f"seeder: must be an integer >= 0, got {seeder!r}")
        self.seeder = seeder

    def share(self, config: PlanConfig) -> int:
        """Its evaluations: one per plan.

        Args:
            config: the run's settings.

        Returns:
            0 when `starts` or `start_candidates` is <= 0; else `start_candidates` plus the
            seeder plans (`seeder`, or `SEEDER_PLANS`) when the descent is on and
            `descents` > 0.
        """
        from planner_core.search.construct import SEEDER_PLANS

        if config.starts <= 0 or config.start_candidates <= 0:
            return 0
        k = SEEDER_PLANS if self.seeder is None else int(self.seeder)
        seeder = k if config.descent and config.descents > 0 else 0
        return config.start_candidates + seeder

    def run(self, state: PlanState, ev: Evaluator) -> PlanState:
        """Build the constructive plans (at most `start_candidates` and `ev.remaining`), then,
        with the descent on, `descents` > 0, the clock not out and room left, seeder plans for
        the rest of the allotment; score all in one evaluate call.

        Args:
            state: the run's state (config, problem, pool).
            ev: the run's evaluator.

        Returns:
            The state with the plans in its pool (kinds "constructive", "seeder"); `state`
            itself when no constructive plan was built.

        Raises:
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        from planner_core.search.construct import candidate_plans, seeder_plans

        cfg, problem = state.config, state.problem
        room = ev.remaining
        X, _ = candidate_plans(problem, cfg.seed, min(cfg.start_candidates, room),
                               order=cfg.order, stop=lambda: ev.expired, progress=ev.report)
        if not len(X):
            return state
        parts = [(X, "constructive")]
        if cfg.descent and cfg.descents > 0 and not ev.expired and room > len(X):
            parts.append((seeder_plans(problem, cfg.seed, room - len(X), ev.report), "seeder"))
        allX = np.vstack([p for p, _ in parts])
        f, phi = ev.evaluate(allX)
        pool, k = state.pool, 0
        for p, kind in parts:
            pool = pool.add(p, f[k:k + len(p)], phi[k:k + len(p)], kind)
            k += len(p)
        return state.replace(pool=pool)

    def __repr__(self) -> str:
        return "ConstructivePlans()" if self.seeder is None else \
            f"ConstructivePlans(seeder={self.seeder})"


class StartDescents(_Base):
    """The hover-point descent with exact LP hover times (`planner_core.search.descent`) on
    the `descents` Deb-best feasible plans of each kind (constructive, seeder), at most
    `descent_trials` evaluations each; every moved result joins the pool. When the pool holds
    no feasible plan and the map stores a witness (`witness_plan`: the known feasible plan a
    generated map carries), the witness joins the pool first (kind "witness", one
    evaluation) and is descended too: where every constructive plan leaves sensors unserved
    (1,000 uniform sensors on 30 km) the run still has a feasible plan to improve; a pool with
    a feasible plan is left as it was. Then the `starts` Deb-best of the pool become the rows
    injected into the DE's population. Cost per trial: one LP (I x J) and the C3/C5 checks
    (I x J, I x V)."""

    name = "start descents"

    def share(self, config: PlanConfig) -> int:
        """Its evaluations: two kinds x `descents` x `descent_trials`.

        Args:
            config: the run's settings.

        Returns:
            0 with the descent off or `starts` <= 0, else 2 x descents x descent_trials.
        """
        if not config.descent or config.starts <= 0:
            return 0
        return 2 * config.descents * config.descent_trials

    def applies(self, state: PlanState, ev: Evaluator) -> bool:
        """Whether there is anything to descend.

        Args:
            state: the run's state.
            ev: the run's evaluator (unused).

        Returns:
            True when the pool holds a plan.
        """
        return len(state.pool) > 0

    def run(self, state: PlanState, ev: Evaluator) -> PlanState:
        """Descend the `descents` Deb-first plans of each kind (an infeasible one is not
        descended, `descend`), at most `descent_trials` and `ev.remaining` evaluations each.

        Args:
            state: the run's state (config, problem, pool).
            ev: the run's evaluator.

        Returns:
            The state with each result that lowered f in the pool (kind "descended"), and the
            map's witness (kind "witness") where the pool held no feasible plan. The rows
            injected into the DE are chosen by `DifferentialEvolution.run`.

        Raises:
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        from planner_core.search.descent import descend

        cfg, problem, pool = state.config, state.problem, state.pool
        w = witness_plan(problem) if not np.any(pool.phi == 0.0) else None
        if w is not None and ev.remaining > 0:
            fw, pw = ev.evaluate(w[None, :])
            pool = pool.add(w[None, :], fw, pw, "witness")
        rows = []
        for kind in ("constructive", "seeder", "witness"):
            idx = pool.of_kind(kind)
            for i in idx[deb_order(pool.f[idx], pool.phi[idx])][:cfg.descents]:
                trials = min(cfg.descent_trials, ev.remaining)
                r = descend(problem, pool.X[i], ev.evaluate, trials=trials) if trials else None
                if r is not None and r.f < r.f_start:  # not moved: already in the pool
                    rows.append((r.x, r.f, r.phi))
        for x, f, phi in rows:
            pool = pool.add(x[None, :], [f], [phi], "descended")
        return state.replace(pool=pool)


def witness_plan(problem: Any) -> np.ndarray | None:
    """The decision vector (d,) of the map's witness (`witness` in the map file: a known
    feasible plan the generator stores, `planner_core.model.mapio.Witness`) on `problem`, or
    None: the map has none (a planning map with safety margins drops it: it was checked on
    the uninflated map), or its points do not fit the problem's encoding (more than I_max, a
    fixed-length problem of another size).

    Args:
        problem: the UAV `Problem` (its `map` is the planning map).

    Returns:
        (d,) decision vector, or None.
    """
    spec = getattr(getattr(problem, "map", None), "spec", None)
    wit = getattr(spec, "witness", None)
    if wit is None or not len(wit.hover_points):
        return None
    try:
        return np.asarray(problem.encode(np.asarray(wit.hover_points, dtype=float),
                                         np.asarray(wit.hover_times, dtype=float)),
                          dtype=float)  # fmt: skip
    except ValueError:
        return None


def _inject(state: PlanState) -> np.ndarray:
    """The `starts` Deb-best rows of the pool (k, d)."""
    k = max(int(state.config.starts), 0)
    return state.pool.X[state.pool.ordered()[:k]]


class DifferentialEvolution(_Base):
    """LAMDE's variable-length DE (`planner_core.search.de.run`) with the run's configurator,
    the pool's `starts` best plans in place of its initial population's last rows (in the
    seeded start its sensor-aware rows are the pool's seeder plans, built once by the
    constructive stage, the rest uniform) and, when `memetic` says so, the memetic step on
    the elite every 10 generations. Its share is `de_share` of the budget, of the default
    budget at most (and at least the population): in the default pipeline the DE rarely
    improves on its best injected plan (docs/search.md), so budget beyond the default goes to
    the improving rounds, and below the default it yields to the final stage's shares; with
    the descent or the polish off it gets everything the later stages do not reserve. Cost
    per generation: N evaluations (compiled kernels, N x I x (J + V)) and the configurator."""

    name = "de"
    #: its share never takes what the later stages' shares need (down to its population)
    yields = True

    def share(self, config: PlanConfig) -> int | None:
        """Its evaluations (class docstring).

        Args:
            config: the run's settings.

        Returns:
            None (the rest) with the descent or the polish off; else max(population,
            round(de_share x min(budget, `defaults.BUDGET`))).
        """
        if not (config.descent and config.polish):
            return None  # nothing after the polish: the DE gets the rest
        from planner_core.defaults import BUDGET

        # a share of the default budget at most: budget beyond it goes to the improving rounds
        return max(config.population, round(config.de_share * min(config.budget, BUDGET)))

    def reserve(self, config: PlanConfig) -> int:
        """What earlier stages leave it: one population.

        Args:
            config: the run's settings.

        Returns:
            `population` evaluations.
        """
        return config.population

    def run(self, state: PlanState, ev: Evaluator) -> PlanState:
        """Run the DE on everything the allotment has left (`ev.remaining`).

        Args:
            state: the run's state (config, problem, pool).
            ev: the run's evaluator.

        Returns:
            The state with `de` the DE's `Result` and `injected` the pool's `starts`
            Deb-best rows (k, d) put into its initial population.

        Raises:
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        from planner_core.search.construct import InjectedPopulation
        from planner_core.search.de import run
        from planner_core.search.refine import refine, use_memetic

        cfg = state.config
        injected = _inject(state)
        pool = state.pool
        # the seeded start's sensor-aware half: the pool's seeder plans, not the seeder again
        seeded = pool.X[pool.of_kind("seeder")] if len(pool) else None
        opt = InjectedPopulation(ev, injected, seeded) if len(injected) else ev
        hook = functools.partial(refine, state.problem) if use_memetic(cfg.memetic, ev) else None
        result = run(opt, configurator=cfg.configurator, seed=cfg.seed,
                     population=cfg.population, budget=ev.remaining, refine=hook)
        return state.replace(de=result, injected=injected)


def _polish_reserve(config: PlanConfig) -> int:
    from planner_core.search.polish import ELITE

    if not config.polish:
        return 0
    return max(min(ELITE, config.budget // 4, config.budget - config.population), 0)


class Polish(_Base):
    """The hover-time LP (`planner_core.search.polish.polish_elite`) for the DE's final
    population's `ELITE` Deb-best distinct rows, each evaluated once.

    Cost, per row: its breakdown (I x J rates, the C5 check of its I + 1 legs, I x V), one LP
    (I x J), and (variable-length plans) a drop trial for each of its Z points whose polished
    time is ~0 (`polish.ZERO_TIME`): the route-overlap check `polish._route_overlap` of
    start -> points -> end (I + 1 legs against the obstacles, I x V) with and without the
    point, twice a trial; a drop starts the scan again over the Z - 1 left, so at most
    Z (Z + 1) / 2 trials (Z <= I: the detour corners and the points the LP leaves idle), and
    any drop re-solves the LP on the kept points. Then ELITE evaluations (I x (J + V) each)
    and two uncounted breakdowns."""

    name = "polish"

    def share(self, config: PlanConfig) -> int:
        """Its evaluations, the same as its `reserve`.

        Args:
            config: the run's settings.

        Returns:
            0 with the polish off; else max(min(`ELITE`, budget // 4, budget - population),
            0).
        """
        return _polish_reserve(config)

    def reserve(self, config: PlanConfig) -> int:
        """What earlier stages leave it (its `share`).

        Args:
            config: the run's settings.

        Returns:
            Evaluations, as `share`.
        """
        return _polish_reserve(config)

    def applies(self, state: PlanState, ev: Evaluator) -> bool:
        """Whether there is a DE population to polish.

        Args:
            state: the run's state.
            ev: the run's evaluator (unused).

        Returns:
            True with the polish on and a DE result.
        """
        return state.config.polish and state.de is not None

    def run(self, state: PlanState, ev: Evaluator) -> PlanState:
        """Polish the DE's final population's elite (at most `ev.remaining` rows) and
        evaluate the polished plans in one call.

        Args:
            state: the run's state (problem, DE result).
            ev: the run's evaluator.

        Returns:
            The state with `polish` a record of the Deb-best polished plan against the DE's
            best (`f_before`, `phi_before`, `f_after`, `phi_after`, `accepted`,
            `dropped_points`, `c3_violation`, `c4_achievable`, `unserved`, `solver`);
            `state` itself when no row was polished.

        Raises:
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        from planner_core.model.formulas import deb_best, deb_not_worse
        from planner_core.search.de.core import to_problem
        from planner_core.search.polish import polish_elite

        problem, st = state.problem, state.de.state
        before = problem.breakdown(state.de.x)
        xs, pols = polish_elite(problem, to_problem(ev, st.X), st.f, st.phi, ev.remaining)
        if not len(xs):
            return state
        fs, phis = ev.evaluate(xs)
        c = deb_best(fs, phis)
        after = problem.breakdown(xs[c])
        pol = pols[c]
        info = {
            "f_before": before["f"],
            "phi_before": before["phi"],
            "f_after": after["f"],
            "phi_after": after["phi"],
            "accepted": bool(deb_not_worse(after["f"], after["phi"], before["f"],
                                           before["phi"])),
            "dropped_points": list(pol.dropped),
            "c3_violation": pol.c3_violation,
            "c4_achievable": pol.feasible_c4,
            "unserved": [u["message"] for u in pol.unserved],
            "solver": pol.solver,
        }
        return state.replace(polish=info)


class FinishIncumbent(_Base):
    """The final stage on the incumbent (`planner_core.search.final.finish`): its descent,
    the structural search, the removal moves and kicks, at most `descent_trials` +
    `restructure_trials` + `kick_trials` evaluations (`PlanConfig.final_trials`).

    Cost: at most that many evaluations (I x (J + V) each: rates and the C5 check of the
    I + 1 legs), each with its hover-time LP (I x J), plus work no evaluation counts:

    * the C3/C5 screen (`search.trial.held_points`: O(I x sensors in range) rates and the
      I + 1 legs against the obstacles, I x V) before every descent trial (and of its held
      points' turned steps), kick and structural move; a refused one costs only that, with
      at most `structure.KICK_ATTEMPTS` (4) kicks drawn per evaluation, and per pass of the
      structural search (at most one pass per evaluation it spends, plus one) O(I) merges,
      splits and removals, a removal screening up to 20 shifted neighbours:
      O(I^2 x (J + V)) a pass;
    * the rerouting of a structural move whose legs cut an obstacle through the visibility
      graph (`Seeder.route`; G = O(V) pushed-out corners, E edges): its legs' obstacle
      tests (I x V), and for each blocked leg not met before its ends linked to the corners
      they see (tangency and line-of-sight tests, O(G x V) a point) and a Dijkstra
      (O(E log G)); legs and points met before are looked up, not routed again."""

    name = "finish"

    def share(self, config: PlanConfig) -> int:
        """Its evaluations: one finish.

        Args:
            config: the run's settings.

        Returns:
            `final_trials` with the polish on, else 0.
        """
        return config.final_trials if config.polish else 0

    def applies(self, state: PlanState, ev: Evaluator) -> bool:
        """Whether the incumbent is feasible.

        Args:
            state: the run's state (unused).
            ev: the run's evaluator.

        Returns:
            True when something was evaluated and the Deb incumbent's phi is 0.
        """
        return _incumbent_feasible(ev)

    def run(self, state: PlanState, ev: Evaluator) -> PlanState:
        """Finish the incumbent with `ev.remaining` evaluations.

        Args:
            state: the run's state (config, problem).
            ev: the run's evaluator.

        Returns:
            The state with the incumbent's number of hover points in `finished`.

        Raises:
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        from planner_core.search.final import finish

        cfg, problem = state.config, state.problem
        x = ev.best()[0]
        finish(problem, x, ev.evaluate, trials=ev.remaining, seed=cfg.seed,
               descent_trials=cfg.descent_trials, restructure_trials=cfg.restructure_trials)
        return state.replace(finished=state.finished | {_points(problem, x)})


class OtherStructure(_Base):
    """The same finish on a second structure: the Deb-best feasible pool plan with fewer
    hover points than the incumbent, else with more (`planner_core.search.final.
    other_structure`); local moves rarely turn one structure into the other (docs/search.md,
    "A second structure"). At most `other_trials` evaluations; runs only when a descent's
    trials fit.

    Cost: finding the plan, an uncounted breakdown (I x (J + V)) of the incumbent and of the
    pool's plans in Deb order until one fits (at most the pool's size; done twice, by
    `applies` and by `run`); then `FinishIncumbent`'s cost with `other_trials` evaluations in
    place of `final_trials` (its descent, structural search and kicks share them)."""

    name = "other structure"

    def share(self, config: PlanConfig) -> int:
        """Its evaluations.

        Args:
            config: the run's settings.

        Returns:
            `other_trials` with the polish on and `final_trials` > 0, else 0.
        """
        return config.other_trials if config.polish and config.final_trials else 0

    def applies(self, state: PlanState, ev: Evaluator) -> bool:
        """Whether a second structure can be finished.

        Args:
            state: the run's state (config, problem, pool).
            ev: the run's evaluator.

        Returns:
            True with a feasible incumbent, at least `descent_trials` evaluations left and
            a pool plan of another structure (`final.other_structure`).
        """
        return (_incumbent_feasible(ev) and ev.remaining >= state.config.descent_trials
                and self._other(state, ev) is not None)

    @staticmethod
    def _other(state: PlanState, ev: Evaluator) -> np.ndarray | None:
        from planner_core.search.final import other_structure

        pool = state.pool
        return other_structure(state.problem, pool.X[pool.ordered()], ev.best()[0])

    def run(self, state: PlanState, ev: Evaluator) -> PlanState:
        """Finish the pool's plan of another structure with `ev.remaining` evaluations.

        Args:
            state: the run's state (config, problem, pool).
            ev: the run's evaluator.

        Returns:
            The state with that plan's number of hover points in `finished`.

        Raises:
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        from planner_core.search.final import finish

        cfg, problem = state.config, state.problem
        y = self._other(state, ev)
        finish(problem, y, ev.evaluate, trials=ev.remaining, seed=cfg.seed,
               descent_trials=cfg.descent_trials, restructure_trials=cfg.restructure_trials)
        return state.replace(finished=state.finished | {_points(problem, y)})


class Improve(_Base):
    """What budget is left after the final stage, while the incumbent is feasible: macro-actions
    of at most one finish's evaluations (`final_trials`) each, chosen one at a time by a
    scheduler (`planner_core.pipeline.schedule`: the actions, `Scheduler`, the registry).

    The default scheduler alternates

    * intensification: the structural search and removal moves on the incumbent when it
      changed since they last ran, else kicks on it (an iterated local search, Lourenco,
      Martin & Stuetzle 2003) with the spread cycling through `schedule.SPREADS`, each action
      its own random stream;
    * diversification: a restart, the whole finish on the Deb-best pool plan of a number of
      hover points not finished yet, else on the best of fresh constructive plans (the
      k-means sweep under another seed, `construct.candidate_plans`, only with
      `schedule.FRESH_ROOM` quanta left), scored into the pool; beyond the paper's sizes
      (I_max > `schedule.PAPER_POINTS`) a rebuild instead: windows of 2-5 hover points
      destroyed and repaired (`planner_core.search.rebuild`).

    The incumbent is the evaluator's, so a restart that ends worse changes nothing. Stops
    when fewer than a descent's trials are left or the scheduler says so (the default: after
    `schedule.IDLE_ROUNDS` actions in a row spent nothing).

    Cost: every evaluation the earlier stages left, in actions of at most one quantum
    (max(`final_trials`, `descent_trials`) evaluations) each, at the cost of the stage they
    repeat: kicks and the structural search as in `FinishIncumbent`, per evaluation and
    screen; a restart a whole `FinishIncumbent` on another plan, found by an uncounted
    breakdown (I x (J + V)) of the pool's plans in Deb order until one fits, after a fresh
    sweep what `ConstructivePlans` costs for `start_candidates` plans (only with
    `schedule.FRESH_ROOM` quanta left); a rebuild per move the points' rates (I x J), a
    k-means of the window's sensors, the snap and open path of its new sites, then a
    structural move's screen, rerouting, LP and race, and once a run its candidate sites
    (O(J^2) sensor-pair midpoints; `planner_core.search.rebuild`); a DE block
    `DifferentialEvolution`'s N x I x (J + V) a generation; a window a pipeline run on its
    sub-map (`planner_core.pipeline.windows`, its evaluations charged one for one). A
    scheduler's own choice (a learned policy's inference) comes on top, once an action.

    Args:
        scheduler: a registry name (`schedule.scheduler_names()`), a `Scheduler`, or None
            (the default).
    """

    name = "improve"

    def __init__(self, scheduler: Any = None) -> None:
        self.scheduler = scheduler

    def share(self, config: PlanConfig) -> int | None:
        """Its evaluations: the rest.

        Args:
            config: the run's settings.

        Returns:
            None (the rest) with the polish on and `final_trials` > 0, else 0.
        """
        return None if config.polish and config.final_trials else 0

    def applies(self, state: PlanState, ev: Evaluator) -> bool:
        """Whether the incumbent is feasible.

        Args:
            state: the run's state (unused).
            ev: the run's evaluator.

        Returns:
            True when something was evaluated and the Deb incumbent's phi is 0.
        """
        return _incumbent_feasible(ev)

    def configure(self, problem: Any, config: PlanConfig) -> PlanConfig:
        """The run's config as its scheduler wants it (`schedule.configured`; the default
        scheduler's `DefaultScheduler.configure`: the DE's share beyond 160 sensors and up to
        120).

        Args:
            problem: the run's `Problem`.
            config: the config asked for.

        Returns:
            The `PlanConfig` the run keeps.

        Raises:
            ValueError: an unknown scheduler, or its `configure` returned no `PlanConfig`.
        """
        from planner_core.pipeline.schedule import configured

        return configured(self.scheduler, problem, config)  # None: the default's

    def run(self, state: PlanState, ev: Evaluator) -> PlanState:
        """Run macro-actions chosen by the scheduler (`schedule.ImproveRun.run`).

        Args:
            state: the run's state.
            ev: the run's evaluator (it must have an incumbent).

        Returns:
            The final state (`actions` the actions taken; `schedule` a selector's template).

        Raises:
            ValueError: an unknown scheduler or action.
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        from planner_core.pipeline.schedule import ImproveRun, make_scheduler

        return ImproveRun(state, ev).run(make_scheduler(self.scheduler))

    def __repr__(self) -> str:
        return "Improve()" if self.scheduler is None else f"Improve({self.scheduler!r})"


class Repair(_Base):
    """What budget is left while the incumbent is infeasible: the DE again from its final
    population (Deb order) or the pool, with the memetic step on (its repair of unserved
    sensors and blocked legs, `planner_core.search.refine`), so an infeasible run spends all
    of its budget on becoming feasible; with less than a population left, the repair's
    candidates for the incumbent. Also when the incumbent is feasible but the improving
    stages left a population or more unspent (their scheduler stopped early), so no run ends
    with budget a DE could still use; under either `radio.access` the improving stages'
    moves act on a feasible plan (scheduled access: the scheduled hover-time LP, no C3
    screen), so a feasible run leaves this stage nothing in the default rounds. Cost: as
    `DifferentialEvolution`."""

    name = "repair"

    def share(self, config: PlanConfig) -> int | None:
        """Its evaluations: the rest.

        Args:
            config: the run's settings (unused).

        Returns:
            None.
        """
        return None

    def applies(self, state: PlanState, ev: Evaluator) -> bool:
        """Whether there is an incumbent to repair, or budget a DE could still use.

        Args:
            state: the run's state (config).
            ev: the run's evaluator.

        Returns:
            True when something was evaluated and the incumbent is infeasible or at least a
            population of evaluations is left.
        """
        if not ev.has_best:
            return False
        return ev.best()[2] > 0.0 or ev.remaining >= state.config.population

    def run(self, state: PlanState, ev: Evaluator) -> PlanState:
        """With less than a population left, evaluate the repair's candidates for the
        incumbent (as many as fit); else the DE with the memetic step on everything left,
        its population the incumbent then the DE's final population in Deb order (the pool's
        plans without a DE result).

        Args:
            state: the run's state (config, problem, DE result, pool).
            ev: the run's evaluator.

        Returns:
            `state` unchanged (the evaluator keeps the incumbent).

        Raises:
            TimeLimitReached: the evaluator's clock ran out (the pipeline catches it).
        """
        from planner_core.search.construct import InjectedPopulation
        from planner_core.search.de import run
        from planner_core.search.de.core import to_problem
        from planner_core.search.refine import refine, repair

        cfg, problem = state.config, state.problem
        n = cfg.population
        if ev.remaining < n:
            cand = repair(problem, ev.best()[0])[:ev.remaining]
            if len(cand):
                ev.evaluate(cand)
            return state
        if state.de is not None:
            st = state.de.state
            rows = to_problem(ev, st.X[deb_order(st.f, st.phi)])
        else:
            rows = state.pool.X[state.pool.ordered()]
        rows = np.vstack([ev.best()[0][None, :], rows])[:n]
        seed = stream_seed(cfg.seed, "repair")
        run(InjectedPopulation(ev, rows), configurator=cfg.configurator, seed=seed,
            population=n, budget=ev.remaining, refine=functools.partial(refine, problem))
        return state


