"""The constructive starts (`planner_core.search.construct`, issue 14): every sensor covered, I_max
kept, deterministic for a seed, our open-path order against naive orders, the obstacle-aware leg
times, and `plan` starting its DE from them with the budget counted exactly."""

from __future__ import annotations

import copy
import itertools

import numpy as np
import pytest

from planner_core.model.formulas import deb_best
from planner_core.model.problem import Problem
from planner_core.model.routing import open_path, open_tour, path_cost
from planner_core.search import construct
from planner_core.search.refine import covers
from tests.conftest import MAPS, SUITE, modules_after
from tests.test_peers import WALLED


@pytest.fixture(scope="module")
def walled() -> Problem:
    return Problem(WALLED)


def test_greedy_cover_covers_every_sensor(walled: Problem) -> None:
    sites = construct.candidate_sites(walled)
    for frac in construct.FRACTIONS:
        chosen = sites[construct.greedy_cover(walled, sites, frac)]
        # every sensor within frac x T_max where some candidate can do it, else within T_max
        can = covers(walled, sites, frac).any(axis=0)
        cov = np.where(can, covers(walled, chosen, frac), covers(walled, chosen, 1))
        assert cov.any(axis=0).all()
        assert len(chosen) <= len(walled.sensors)  # each pick covers a new sensor
    # a site is a candidate only under the bandwidth (C3), and never inside an obstacle
    assert np.all(walled.rates(sites).sum(axis=1)
                  <= construct.BANDWIDTH_USE * walled.bandwidth)  # fmt: skip
    from planner_core.model.geometry import points_inside

    assert not points_inside(sites, walled.obstacles).any()


@pytest.mark.parametrize("task", ["T05", "T13"])
def test_every_candidate_serves_every_sensor_within_i_max(task: str) -> None:
    """Each constructive plan of a suite map collects every sensor's data (C4: no shortfall),
    within I_max hover points, and its hover times are the LP's (never above T_max)."""
    from planner_core.model.mapio import load_map

    p = Problem(load_map(SUITE / f"{task}.json").planning_map())
    X, labels = construct.candidate_plans(p, 0, 12)
    assert len(X) == len(labels) == 12
    assert len({x.tobytes() for x in X}) == len(X)  # distinct
    for x in X:
        b = p.breakdown(x)
        assert b["v4"] == 0.0, b["shortfall"]
        assert 1 <= b["n_hover"] <= p.n_points
        assert np.all(np.asarray(b["hover_times"]) <= p.t_max + 1e-9)
    f, phi = p.evaluate(X)
    assert np.any(phi == 0.0)  # some are feasible outright (legs routed, C3 kept)


def test_i_max_kept_when_detours_overflow_and_fixed_length_fills() -> None:
    """I_max = 4 on the walled map: the sites plus the wall's detour corners do not fit, every
    plan is cut back to at most 4 points; in the fixed-length encoding every plan has exactly
    I_max."""
    m = copy.deepcopy(WALLED)
    m["uav"]["max_hover_points"] = 4
    for variable in (True, False):
        p = Problem(m, variable_length=variable)
        X, _ = construct.candidate_plans(p, 0)
        assert len(X)
        n = [p.breakdown(x)["n_hover"] for x in X]
        assert max(n) <= 4
        if not variable:
            assert set(n) == {4}


def test_candidates_are_deterministic_for_a_seed(walled: Problem) -> None:
    a, la = construct.candidate_plans(walled, 5)
    b, lb = construct.candidate_plans(Problem(WALLED), 5)
    np.testing.assert_array_equal(a, b)
    assert la == lb
    # a limit takes a prefix of the same sequence
    c, _ = construct.candidate_plans(walled, 5, 3)
    np.testing.assert_array_equal(c, a[:3])
    assert construct.candidate_plans(walled, 5, 0)[0].shape == (0, walled.dim)


def _brute(W: np.ndarray) -> float:
    P = len(W)
    return min(path_cost(W, np.array([0, *perm, P - 1]))
               for perm in itertools.permutations(range(1, P - 1)))  # fmt: skip


def test_open_path_no_worse_than_naive_orders() -> None:
    """Random small instances (Euclidean, start and end fixed): our open path is never longer
    than the points in their given order or than nearest neighbour + 2-opt (`open_tour`, the
    seeder's), and is optimal (brute force) on nearly all of them."""
    rng = np.random.default_rng(0)
    optimal = 0
    better_than_nn = 0
    for _ in range(60):
        pts = rng.random((int(rng.integers(5, 9)), 2)) * 1000.0
        W = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1))
        t = open_path(W)
        P = len(W)
        assert t[0] == 0 and t[-1] == P - 1 and sorted(t.tolist()) == list(range(P))
        ours = path_cost(W, t)
        assert ours <= path_cost(W, np.arange(P)) + 1e-9
        nn = path_cost(W, open_tour(W))
        assert ours <= nn + 1e-9
        better_than_nn += ours < nn - 1e-6
        optimal += ours <= _brute(W) + 1e-6
    assert optimal >= 57
    assert better_than_nn >= 1  # Or-opt and the second start do find what 2-opt misses


def test_leg_times_route_blocked_legs_through_the_graph(walled: Problem) -> None:
    """Clear legs cost their straight Eq. 1 time; a leg through the wall costs the fastest way
    around it: more than the straight leg, at most the seeder's shortest-length detour flown
    hop by hop; the matrix is symmetric."""
    legs = construct.LegTimes(walled)
    a = np.array([[300.0, 400.0], [300.0, 1100.0], [1000.0, 400.0]])
    W = legs.matrix(a)
    np.testing.assert_allclose(W, W.T)
    mp = walled.model
    assert W[0, 2] == pytest.approx(float(mp.flight_time(700.0)))  # clear: straight
    straight = float(mp.flight_time(700.0))
    assert W[0, 1] > straight
    seeder = walled.seeder
    A = seeder.connect(a[:2])
    _, path = seeder.graph.route(A[0], A[1])
    way = np.vstack([a[0], seeder.graph.nodes[path], a[1]])
    detour = float(mp.flight_time(np.hypot(*np.diff(way, axis=0).T)).sum())
    assert straight < W[0, 1] <= detour + 1e-9


def test_injected_population_replaces_the_last_rows(walled: Problem) -> None:
    starts = np.stack([walled.lower, walled.upper])
    X = construct.InjectedPopulation(walled, starts).initial_population(
        np.random.default_rng(0), 8)
    own = walled.initial_population(np.random.default_rng(0), 8)
    np.testing.assert_array_equal(X[:6], own[:6])
    np.testing.assert_array_equal(X[6:], starts)
    # the uniform start mode (no hook): uniform rows in the box, then the starts
    from planner_core.search.init_modes import UniformStart

    U = construct.InjectedPopulation(UniformStart(walled), starts).initial_population(
        np.random.default_rng(0), 8)
    assert np.all((U[:6] >= walled.lower) & (U[:6] <= walled.upper))
    np.testing.assert_array_equal(U[6:], starts)


def test_injected_population_takes_seeded_rows_for_the_hook(walled: Problem) -> None:
    """`seeded` rows stand in for the problem's own (seeder) hook, which is not called: the
    population is uniform with those rows first and the starts last; with the uniform start
    mode (no hook) the seeded rows are not used; starts that fill the population are it."""
    from planner_core.search.init_modes import UniformStart

    class Counting:
        def __init__(self, problem: Problem) -> None:
            self.problem, self.calls = problem, 0

        def __getattr__(self, name: str):  # noqa: ANN204
            return getattr(self.problem, name)

        def initial_population(self, rng: np.random.Generator, n: int) -> np.ndarray:
            self.calls += 1
            return self.problem.initial_population(rng, n)

    seeded = np.stack([walled.lower + 1.0, walled.lower + 2.0, walled.lower + 3.0])
    starts = np.stack([walled.lower, walled.upper])
    c = Counting(walled)
    X = construct.InjectedPopulation(c, starts, seeded).initial_population(
        np.random.default_rng(0), 8)
    assert c.calls == 0
    np.testing.assert_array_equal(X[:3], seeded)
    np.testing.assert_array_equal(X[6:], starts)
    assert np.all((X[3:6] >= walled.lower) & (X[3:6] <= walled.upper))
    U = construct.InjectedPopulation(UniformStart(walled), starts, seeded).initial_population(
        np.random.default_rng(0), 8)
    assert not any(np.array_equal(row, s) for row in U for s in seeded)
    full = np.repeat(starts, 4, axis=0)
    F = construct.InjectedPopulation(c, full).initial_population(np.random.default_rng(0), 8)
    assert c.calls == 0
    np.testing.assert_array_equal(F, full)


def test_the_constructive_stage_scores_its_plans_in_one_call(walled: Problem) -> None:
    """The pipeline's first stage: the first `start_candidates` plans (and the seeder's when
    the descents run) scored once each, through the evaluator, into the pool."""
    from planner_core.pipeline import Evaluator, PlanConfig
    from planner_core.pipeline.stages import ConstructivePlans, PlanState, Pool

    cfg = PlanConfig(budget=1000, population=10, start_candidates=5, descent=False)
    ev = Evaluator(walled, 1000)
    d = walled.lower.shape[0]
    state = PlanState(walled, cfg, Pool.empty(d), np.zeros((0, d)))
    with ev.stage("constructive", ConstructivePlans().share(cfg)):
        out = ConstructivePlans().run(state, ev)
    X, _ = construct.candidate_plans(walled, 0, 5)
    assert ev.count == len(out.pool) == len(X) == 5 and ev.records[0].evaluations == 5
    np.testing.assert_array_equal(out.pool.X, X)
    f, phi = walled.evaluate(X)
    np.testing.assert_array_equal(out.pool.X[out.pool.ordered()[0]], X[deb_best(f, phi)])


def test_the_constructive_stage_builds_the_seeder_plans_it_is_given(walled: Problem) -> None:
    """With the descents on, `SEEDER_PLANS` seeder plans beside the constructive ones by
    default; `ConstructivePlans(seeder=k)` k of them (a window's run: none); a bad k refused."""
    from planner_core.pipeline import Evaluator, PlanConfig
    from planner_core.pipeline.stages import ConstructivePlans, PlanState, Pool

    cfg = PlanConfig(budget=1000, population=10, start_candidates=5)
    d = walled.lower.shape[0]
    for stage, k in ((ConstructivePlans(), construct.SEEDER_PLANS),
                     (ConstructivePlans(seeder=3), 3), (ConstructivePlans(seeder=0), 0)):
        assert stage.share(cfg) == 5 + k
        ev = Evaluator(walled, 1000)
        with ev.stage("constructive", stage.share(cfg)):
            out = stage.run(PlanState(walled, cfg, Pool.empty(d), np.zeros((0, d))), ev)
        assert len(out.pool.of_kind("seeder")) == k and len(out.pool) == ev.count == 5 + k
    assert repr(ConstructivePlans()) == "ConstructivePlans()"
    with pytest.raises(ValueError, match="seeder: must be an integer >= 0"):
        ConstructivePlans(seeder=-1)


@pytest.mark.slow  # measured 4 s (issue 35: default suite <= 5 min)
def test_plan_starts_from_the_constructive_plans() -> None:
    """`plan` with starts: at most the budget (exactly without the descents, which may stop
    early), never worse (Deb) than its best constructive plan, deterministic; starts=0 is the
    plain DE (a different plan)."""
    import lamde_mission

    path = MAPS / "small-demo.json"
    p = lamde_mission.plan(path, seed=1, budget=1200, population=40)
    assert p.evaluations <= 1200
    exact = lamde_mission.plan(path, seed=1, budget=1200, population=40, descent=False)
    assert exact.evaluations == 1200
    assert p.stages[0].name == "constructive"  # the constructive plans were scored first
    assert p.history["evaluations"][0] == p.stages[0].evaluations > 1
    from planner_core.defaults import START_CANDIDATES
    from planner_core.model.mapio import load_map

    prob = Problem(load_map(path).planning_map())
    X, _ = construct.candidate_plans(prob, 1, START_CANDIDATES)
    f, phi = prob.evaluate(X)
    c = deb_best(f, phi)
    assert (p.phi, p.f) <= (phi[c], f[c] + 1e-9)
    again = lamde_mission.plan(path, seed=1, budget=1200, population=40)
    np.testing.assert_array_equal(p.hover_points, again.hover_points)
    np.testing.assert_array_equal(p.hover_times, again.hover_times)
    plain = lamde_mission.plan(path, seed=1, budget=1200, population=40, starts=0,
                               descent=False)
    assert plain.evaluations == 1200 and [s.name for s in plain.stages] == ["de", "polish"]
    assert plain.history["evaluations"][0] == 40  # the DE's first population
    with pytest.raises(ValueError, match="^starts: "):
        lamde_mission.plan(path, starts=-1)


@pytest.mark.slow  # measured 10 s (issue 35: default suite <= 5 min)
def test_planning_path_needs_no_ortools() -> None:
    """OR-Tools is in the `baselines` extra only: a `plan` (constructive starts included) never
    imports it."""
    code = ("import lamde_mission; lamde_mission.plan('examples/maps/tiny.json', seed=0, "
            "budget=400, population=20)")
    assert modules_after(code, "ortools") == []


@pytest.mark.slow  # measured 4 s (issue 35: default suite <= 5 min)
def test_plan_is_the_benchmark_planner_entry() -> None:
    """`plan` and the benchmark's `planner` entry are one pipeline: the same seed and budget give
    the same plan score and evaluation count (at most the budget: a descent may stop early)."""
    import lamde_mission
    from planner_core.bench.baselines import optimise
    from planner_core.model.mapio import load_map

    path = MAPS / "small-demo.json"
    p = lamde_mission.plan(path, seed=2, budget=1500)
    r = optimise("planner", Problem(load_map(path).planning_map()), 1500, seed=2)
    assert (p.f, p.phi, p.evaluations) == (r.f, r.phi, r.evaluations)
    assert 1400 < p.evaluations <= 1500
