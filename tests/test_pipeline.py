"""The declared pipeline (planner_core.pipeline): the one counted evaluator, the config checked
once, determinism, the time limit, and an infeasible run spending its whole budget on repair."""

from __future__ import annotations

import time

import numpy as np
import pytest

import lamde_mission
from lamde_mission.result import Plan
from planner_core.model.problem import Problem
from planner_core.pipeline import (
    DEFAULT_PIPELINE,
    BudgetExceeded,
    Evaluator,
    PlanConfig,
    TimeLimitReached,
    run_pipeline,
)
from tests.conftest import MAPS, SUITE


@pytest.fixture(scope="module")
def tiny() -> Problem:
    return Problem(MAPS / "tiny.json")


def test_the_evaluator_refuses_beyond_the_budget_and_the_stage_allotment(tiny: Problem) -> None:
    ev = Evaluator(tiny, 10)
    X = np.tile(tiny.lower, (4, 1))
    with ev.stage("a", 5):
        ev.evaluate(X)
        assert ev.remaining == 1
        with pytest.raises(BudgetExceeded, match="in stage 'a' with 1 of 10 left"):
            ev.evaluate(X[:2])
    assert ev.remaining == 6 and ev.count == 4
    with pytest.raises(BudgetExceeded):
        ev.evaluate(np.tile(tiny.lower, (7, 1)))
    (rec,) = ev.records
    assert (rec.name, rec.allotted, rec.evaluations) == ("a", 5, 4)
    assert rec.f_before == np.inf and rec.f_after == ev.best()[1]
    # the trace: one row per evaluate call, the incumbent never worse
    t = ev.trace()
    assert list(t.evaluations) == [4]


def test_the_evaluator_hands_on_its_own_copies_with_nan_as_inf() -> None:
    """A NaN from the problem loses every comparison (+inf, the DE core's rule,
    `sanitise_evaluation`), the problem's arrays are never handed on or written, and results
    of the wrong length are refused."""

    class Broken:
        lower, upper = np.zeros(2), np.ones(2)

        def __init__(self) -> None:
            self.f = np.array([1.0, np.nan, 3.0])
            self.phi = np.array([0.0, 0.0, np.nan])

        def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return self.f[: len(X)], self.phi[: len(X)]

    p = Broken()
    ev = Evaluator(p, 10)
    f, phi = ev.evaluate(np.zeros((3, 2)))
    assert list(f) == [1.0, np.inf, 3.0] and list(phi) == [0.0, 0.0, np.inf]
    f[0] = phi[0] = 7.0
    assert p.f[0] == 1.0 and p.phi[0] == 0.0 and np.isnan(p.f[1]) and np.isnan(p.phi[2])
    assert ev.best()[1:] == (1.0, 0.0)
    p.f = np.array([1.0, 2.0])  # two f for three solutions
    with pytest.raises(ValueError, match=r"evaluate returned shapes \(2,\), \(3,\); expected"):
        ev.evaluate(np.zeros((3, 2)))


@pytest.mark.parametrize("one_row", [True, False])
def test_the_evaluator_has_an_incumbent_after_any_evaluated_row(one_row: bool) -> None:
    """Rows whose f or phi is infinite (a NaN made +inf, an unflyable plan) still become the
    incumbents when there is none yet, under both criteria, one row at a time or in a batch;
    a finite row then replaces them (the module's promise: an incumbent after one row)."""

    class Values:
        lower, upper = np.zeros(2), np.ones(2)
        f = np.array([np.inf, np.inf])
        phi = np.array([np.inf, 0.0])

        def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return self.f[: len(X)].copy(), self.phi[: len(X)].copy()

    p = Values()
    ev = Evaluator(p, 10)
    X = np.array([[0.1, 0.1], [0.2, 0.2]])
    if one_row:
        ev.evaluate(X[:1])
        assert ev.has_best and ev.best("penalised")[1:] == (np.inf, np.inf)
        p.f, p.phi = p.f[1:], p.phi[1:]
        ev.evaluate(X[1:])
    else:
        ev.evaluate(X)
    assert ev.has_best
    assert ev.best("deb")[1:] == (np.inf, 0.0) and list(ev.best("deb")[0]) == [0.2, 0.2]
    assert ev.best("penalised")[2] in (np.inf, 0.0)
    p.f, p.phi = np.array([5.0]), np.array([1.0])
    ev.evaluate(np.array([[0.3, 0.3]]))
    assert ev.best("penalised")[1:] == (5.0, 1.0) and ev.best("deb")[1:] == (np.inf, 0.0)


def test_the_evaluator_stops_at_its_time_limit_after_a_first_evaluation(tiny: Problem) -> None:
    ev = Evaluator(tiny, 100, time_limit=0.05)
    time.sleep(0.06)
    ev.evaluate(tiny.lower[None, :])  # the first call always runs: there is an incumbent
    with pytest.raises(TimeLimitReached), ev.stage("late", 10):
        ev.evaluate(tiny.lower[None, :])
    assert ev.count == 1 and ev.records[-1].stopped == "time limit"


class _Rows:
    """A problem whose row x = (f, phi, tag) evaluates to that f and phi (the tag tells rows
    with the same f and phi apart)."""

    lower = np.zeros(3)
    upper = np.full(3, np.inf)

    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return X[:, 0].copy(), X[:, 1].copy()


def test_the_evaluator_keeps_the_same_incumbents_row_by_row_as_in_one_batch() -> None:
    """The one-row path (`Evaluator._update_one`, the descents' calls) and the batch path rank
    by the same Deb rule and penalised score (`planner_core.model.formulas`): ties in phi, in f
    and in the score, and infinite f or phi, keep the first row either way."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        n = int(rng.integers(1, 9))
        X = np.column_stack([rng.choice([0.0, 1.0, 2.0, 10.0, 21.0, np.inf], n),
                             rng.choice([0.0, 0.0, 0.1, 1.0, 2.0, np.inf], n), np.arange(n)])
        batch, rows = Evaluator(_Rows(), n), Evaluator(_Rows(), n)
        batch.evaluate(X)
        for x in X:
            rows.evaluate(x[None, :])
        for criterion in ("deb", "penalised"):
            b, r = _incumbent(batch, criterion), _incumbent(rows, criterion)
            assert (b is None) == (r is None), (criterion, X)
            if b is not None:  # None: no row beat the empty incumbent (inf f or phi)
                assert np.array_equal(b[0], r[0]) and b[1:] == r[1:], (criterion, X)


def _incumbent(ev: Evaluator, criterion: str) -> tuple | None:
    try:
        return ev.best(criterion)  # type: ignore[arg-type]
    except RuntimeError:
        return None


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"budget": 50}, "budget"), ({"de_share": 1.5}, "de_share"), ({"time_limit": 0}, "time_limit"),
     ({"time_limit": float("nan")}, "time_limit"), ({"population": 5}, "population"),
     ({"descent_trials": -1}, "descent_trials"), ({"seed": -2}, "seed")],
)
def test_a_config_is_checked_once_naming_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=f"^{field}:"):
        PlanConfig(**kwargs)


def test_the_default_pipeline_is_declared_once_in_order() -> None:
    assert [s.name for s in DEFAULT_PIPELINE] == [
        "constructive", "start descents", "de", "polish", "finish", "other structure",
        "improve", "repair"]


def test_same_seed_and_budget_same_plan_and_stage_counts(tiny: Problem) -> None:
    cfg = PlanConfig(seed=5, budget=1_500, population=20)
    a, b = run_pipeline(tiny, cfg), run_pipeline(tiny, cfg)
    assert a.x.tobytes() == b.x.tobytes() and a.f == b.f
    assert [(s.name, s.evaluations) for s in a.stages] == [
        (s.name, s.evaluations) for s in b.stages]
    assert sum(s.evaluations for s in a.stages) == a.evaluations <= 1_500


def test_descent_trials_zero_turns_off_every_finish_as_the_defaults_table_says() -> None:
    """`descent_trials` 0 (planner_core.defaults): no start descents, the final stage and the
    other structure spend nothing (`finish` starts with the descent), and what they leave goes
    to the improving stage."""
    p = Problem(SUITE / "T03.json")
    r = run_pipeline(p, PlanConfig(seed=1, descent_trials=0))
    spent = {s.name: s.evaluations for s in r.stages}
    assert "start descents" not in spent and spent["finish"] == spent["other structure"] == 0
    assert r.phi == 0 and spent["improve"] > 0 and r.evaluations == PlanConfig().budget


def test_an_infeasible_run_spends_its_whole_budget_on_the_repair() -> None:
    """A map no plan can serve (a sensor beyond every point's reach): the incumbent stays
    infeasible, the stages after the polish do not apply, and `repair` takes all that is left,
    so the run ends at exactly its budget."""
    p = lamde_mission.plan(MAPS / "infeasible-demo.json", seed=0, budget=1_200, population=20)
    assert not p.feasible
    assert p.evaluations == 1_200
    assert p.stages[-1].name == "repair" and p.stages[-1].evaluations > 0


def test_a_time_limit_returns_the_best_plan_found_in_time() -> None:
    t0 = time.perf_counter()
    p = lamde_mission.plan(MAPS / "small-demo.json", seed=0, budget=10_000_000, time_limit=0.8)
    wall = time.perf_counter() - t0 - p.timings["compile"]
    assert p.stopped == "time limit" and p.feasible and p.evaluations < 10_000_000
    assert wall < 0.8 + 2.0  # generous: a stage stops at its next evaluation
    # the clock stopped a stage at an evaluation, or the run between two stages
    assert all(s.stopped in ("", "time limit") for s in p.stages)


def test_a_plan_with_its_stages_round_trips_through_json(tiny: Problem) -> None:
    p = lamde_mission.plan(MAPS / "tiny.json", seed=1, budget=800, population=20)
    q = Plan.from_dict(p.to_dict())
    assert q.same_as(p) and [s.name for s in q.stages] == [s.name for s in p.stages]
    assert q.stages == p.stages  # the first stage's f before is inf: None in JSON, inf back
    assert q.config == p.config and q.stopped == p.stopped


def test_the_constructive_stage_reports_its_plans_between_evaluations(tiny: Problem) -> None:
    """A stage that builds for seconds before it evaluates tells the progress callback what it
    has built (`Evaluator.report`): the constructive plans and the seeder plans, in order, before
    the stage's one evaluate call; the plan's progress bar prints them."""
    import io

    from lamde_mission.commands.plan import _ProgressBar

    seen = []
    run_pipeline(tiny, PlanConfig(seed=0, budget=1500), progress=seen.append)
    details = [p.detail for p in seen if p.stage == "constructive" and p.detail]
    assert details and details[0].endswith(" plans") and "seeder plans" in details[-1]
    first_eval = next(i for i, p in enumerate(seen) if p.evaluations > 0)
    assert all(not p.detail for p in seen[first_eval:] if p.stage != "constructive")
    assert seen[0].evaluations == 0 and seen[0].best_f == float("inf")
    out = io.StringIO()
    bar = _ProgressBar(out)
    bar(seen[0])
    assert "no plan scored yet" in out.getvalue() and f"({seen[0].detail})" in out.getvalue()


def test_the_maps_witness_is_a_start_only_when_no_constructive_plan_is_feasible(monkeypatch
                                                                                ) -> None:
    """A generated map stores a feasible plan (its witness). Where none of the constructive
    and seeder plans is feasible (1,000 uniform sensors on 30 km: 26-45 sensors unserved and
    the run ended infeasible, its witness unused), the witness joins the pool, is descended
    and the run ends feasible; where one is, the witness is not evaluated (the default plans
    stay as they were)."""
    import planner_core.search.construct as construct
    from planner_core.pipeline.stages import witness_plan

    p = Problem(SUITE / "T03.json")
    w = witness_plan(p)
    assert w is not None and p.breakdown(w)["phi"] == 0.0
    cfg = PlanConfig(seed=0, budget=2_000)
    normal = run_pipeline(p, cfg)
    assert "witness" not in normal.state.pool.kinds and normal.phi == 0.0

    # every built plan hovers at the start only: it serves no sensor (phi > 0)
    def unserved(problem, *args, **kwargs):
        x = problem.encode(np.asarray([problem.start], dtype=float), np.asarray([10.0]))
        return np.asarray([x]), ["start only"]

    monkeypatch.setattr(construct, "candidate_plans", unserved)
    monkeypatch.setattr(construct, "seeder_plans",
                        lambda problem, seed, k, progress=None: unserved(problem)[0])
    rescued = run_pipeline(p, cfg)
    assert rescued.state.pool.kinds.count("witness") == 1 and rescued.phi == 0.0
    assert rescued.f <= p.breakdown(w)["f"]
    # the start descents act on feasible plans only: here on the witness alone
    spent = {s.name: s.evaluations for s in rescued.stages}
    assert spent["start descents"] > 0
    monkeypatch.setattr("planner_core.pipeline.stages.witness_plan", lambda problem: None)
    alone = {s.name: s.evaluations for s in run_pipeline(p, cfg).stages}
    assert alone.get("start descents", 0) == 0
