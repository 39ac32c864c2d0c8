"""Window re-planning (planner_core.pipeline.windows): a stretch of a large plan planned again
as a map of its own, its evaluations charged to the run's evaluator, raced against the
incumbent; the sub-map it plans on; the default scheduler's switch to it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner_core.model.mapio import load_map, sub_map_dict
from planner_core.model.problem import Problem
from planner_core.pipeline.evaluator import BudgetExceeded, Evaluator
from planner_core.search.descent import hover_of
from tests.conftest import SUITE

LARGE = SUITE.parent / "large"


@pytest.fixture(scope="module")
def l02() -> tuple[Problem, np.ndarray]:
    """L02's planning problem and its stored best-known plan (d,)."""
    p = Problem(load_map(LARGE / "L02.json").planning_map())
    bk = json.loads((SUITE.parent / "large_best_known.json").read_text())["tasks"]["L02"]
    x = p.encode(np.asarray(bk["hover_points"], float), np.asarray(bk["hover_times"], float))
    return p, x


def test_charge_counts_evaluations_made_elsewhere_and_keeps_the_budget() -> None:
    p = Problem(SUITE / "T05.json")
    ev = Evaluator(p, 100)
    ev.charge(60)
    assert ev.count == 60 and ev.remaining == 40 and not ev.has_best
    with pytest.raises(BudgetExceeded, match="41 evaluations charged"):
        ev.charge(41)
    assert ev.count == 60


def test_sub_map_keeps_the_obstacles_that_meet_its_box() -> None:
    m = load_map(LARGE / "L02.json")
    J = len(m.sensor_ids)
    lo, hi = np.array([4000.0, 4000.0]), np.array([9000.0, 8000.0])
    full = m.to_dict()
    a, b = full["start"], full["end"]
    d = sub_map_dict(m, a, b, np.ones(J), box=(lo, hi))
    full = full["obstacles"]
    for c in full["circles"]:
        inside = (c["x"] + c["radius"] >= lo[0] and c["x"] - c["radius"] <= hi[0]
                  and c["y"] + c["radius"] >= lo[1] and c["y"] - c["radius"] <= hi[1])
        assert (c in d["obstacles"]["circles"]) == inside
    kept = sum(len(v) for v in d["obstacles"].values())
    assert 0 < kept < sum(len(v) for v in full.values())
    assert d["start"] == [float(v) for v in a] and len(d["sensors"]) == J
    load_map(d)  # a map the reader takes


def test_a_window_map_asks_what_the_other_points_leave(l02: tuple[Problem, np.ndarray]) -> None:
    """The sub-map's requirement of each sensor plus what the plan's other points collect
    covers its Q_j; its ends are the window's neighbours; its I_max is the paper's sizes."""
    from planner_core.pipeline.windows import SUB_POINTS, window_map

    p, x = l02
    P, T = hover_of(p.breakdown(x))
    keep = T > 0
    P, T = P[keep], T[keep]
    i, w = 10, 8
    d = window_map(p, P, T, i, w)
    assert d is not None
    assert d["start"] == [float(v) for v in P[i - 1]]
    assert d["end"] == [float(v) for v in P[i + w]]
    assert d["uav"]["max_hover_points"] == SUB_POINTS
    assert d["name"] == f"window-{i}"  # not the map's name, which may be at its length limit
    ids = list(p.map.sensor_ids)
    req = {s["id"]: s["required_data"] for s in d["sensors"]}
    D = p.model.rates(P) * T[:, None]
    others = D.sum(axis=0) - D[i:i + w].sum(axis=0)
    need = p.model.required - others
    for j, sid in enumerate(ids):
        if need[j] > 1e-6 * p.model.required[j]:
            assert req[sid] == pytest.approx(need[j], rel=1e-9)
    assert 0 < sum(r > 0 for r in req.values()) < len(ids) / 3


def test_a_window_charges_its_run_and_never_worsens_the_incumbent(
        l02: tuple[Problem, np.ndarray]) -> None:
    """From L02's best-known plan: the sub-run's evaluations are counted in the run's
    evaluator, the incumbent is never worse, and the same seed gives the same plan."""
    from planner_core.pipeline.windows import SUB_BUDGET, replan_window

    p, x = l02
    outs = []
    for _ in range(2):
        ev = Evaluator(p, 5000)
        f0 = float(ev.evaluate(x[None, :])[0][0])
        nxt, better = replan_window(p, ev, index=20, trials=640, seed=3)
        assert ev.count > 1 + SUB_BUDGET // 2  # the sub-run was charged
        assert ev.count <= 1 + 640
        assert ev.best()[1] <= f0 and ev.best()[2] == 0.0
        assert better == (ev.best()[1] < f0)
        assert nxt != 20
        outs.append((ev.count, ev.best()[0].tobytes()))
    assert outs[0] == outs[1]


def test_a_sweep_shares_the_evaluations_left_among_its_windows() -> None:
    """A window's sub-run gets the stage's evaluations left over the windows to the sweep's
    end (less each race), between SUB_MIN and SUB_BUDGET, within the action's trials."""
    from planner_core.pipeline.windows import RACE_TRIALS, SUB_BUDGET, SUB_MIN, sub_budget

    # 176 hovering points, windows of 8: 22 to the end from the first, 1 from the last
    assert sub_budget(10_000, 640, 176, 0, 8) == 10_000 // 22 - 1 - RACE_TRIALS
    cap = min(SUB_BUDGET, 640 - 1 - RACE_TRIALS)  # 599 at the default quantum
    assert sub_budget(10_000, 640, 176, 168, 8) == cap
    assert sub_budget(600, 640, 20, 12, 8) == 600 - 1 - RACE_TRIALS  # one window to go
    assert sub_budget(600, 640, 20, 11, 8) == 300 - 1 - RACE_TRIALS  # a part-window counts
    assert sub_budget(1_000, 640, 176, 0, 8) == SUB_MIN  # the floor
    assert sub_budget(10_000, 120, 176, 168, 8) == 120 - 1 - RACE_TRIALS  # the action's cap
    # L01-like: 35 points, 5 windows a sweep; 4,000 left: the cap; 2,000 left: 359 each
    assert sub_budget(4_000, 640, 35, 0, 8) == cap
    assert sub_budget(2_000, 640, 35, 0, 8) == 2_000 // 5 - 1 - RACE_TRIALS


def test_a_windows_run_is_the_default_pipeline_without_seeder_plans() -> None:
    from planner_core.pipeline import DEFAULT_PIPELINE, WINDOW_PIPELINE
    from planner_core.pipeline.stages import ConstructivePlans

    assert [s.name for s in WINDOW_PIPELINE] == [s.name for s in DEFAULT_PIPELINE]
    assert [s.seeder for s in WINDOW_PIPELINE if isinstance(s, ConstructivePlans)] == [0]
    assert all(a is b for a, b in zip(WINDOW_PIPELINE, DEFAULT_PIPELINE, strict=True)
               if not isinstance(a, ConstructivePlans))


def test_a_window_needs_seconds_left_and_a_variable_length_problem(
        l02: tuple[Problem, np.ndarray]) -> None:
    """With less than `MIN_SECONDS` of the run's time limit left, or a fixed-length problem,
    a window spends nothing."""
    import copy
    import time

    from planner_core.pipeline.windows import replan_window

    p, x = l02
    ev = Evaluator(p, 5000, time_limit=0.03)
    ev.evaluate(x[None, :])
    time.sleep(0.05)
    assert replan_window(p, ev, index=4, trials=640, seed=1) == (4, False)
    assert ev.count == 1
    fixed = copy.copy(p)
    fixed.variable_length = False
    ev = Evaluator(p, 5000)
    ev.evaluate(x[None, :])
    assert replan_window(fixed, ev, index=4, trials=640, seed=1) == (4, False)
    assert ev.count == 1


def test_the_default_scheduler_turns_to_windows_when_the_cycle_stalls() -> None:
    """On a problem with the large rounds and a uniform layout the default runs
    `LARGE_CYCLE` while its last `STALL_ACTIONS` actions gain at least `WINDOWS_STALL` of f
    per 1,000 evaluations, then `windows` for the rest of the stage; on clustered fields
    and corridors never (`Problem.uniform_layout`)."""
    from types import SimpleNamespace

    from planner_core.pipeline.schedule import (
        LARGE_CYCLE,
        STALL_ACTIONS,
        WINDOWS_STALL,
        DefaultScheduler,
        StepRecord,
    )

    def history(rel_gain_per_1000: float) -> tuple[StepRecord, ...]:
        f, out = 5000.0, []
        for k in range(STALL_ACTIONS):
            g = rel_gain_per_1000 * 0.64 * 5000.0  # 640 evaluations an action
            out.append(StepRecord(LARGE_CYCLE[k], 640, 0.3, f, 0.0, f - g, 0.0))
            f -= g
        return tuple(out)

    s = DefaultScheduler()
    s.large, s.windows, s.uniform = True, False, True
    obs = SimpleNamespace(idle=0, step=STALL_ACTIONS, history=history(2 * WINDOWS_STALL))
    assert s.choose(obs) == LARGE_CYCLE[STALL_ACTIONS]
    obs.history = obs.history[:-1]  # fewer actions than the look-back: the cycle goes on
    assert s.choose(obs) == LARGE_CYCLE[STALL_ACTIONS]
    obs.history = history(0.5 * WINDOWS_STALL)
    assert s.choose(obs) == "windows"
    obs.history = history(2 * WINDOWS_STALL)  # once stalled, windows for the rest
    assert s.choose(obs) == "windows"
    s.windows, s.uniform = False, False  # clustered fields: the cycle whatever it gains
    obs.history = history(0.0)
    assert s.choose(obs) == LARGE_CYCLE[STALL_ACTIONS]
    # a windows action that found nothing to plan: the cycle takes the rest
    s.windows, s.uniform = True, True
    obs.history = (*history(0.0), StepRecord("windows", 0, 0.01, 5000.0, 0.0, 5000.0, 0.0))
    assert s.choose(obs) == LARGE_CYCLE[STALL_ACTIONS]
    assert s.choose(obs) == LARGE_CYCLE[STALL_ACTIONS]


def test_the_layout_rule_reads_the_suite_as_documented() -> None:
    """Windows on L01-L03 (uniform), not on L04-L08 (clustered fields, corridors)."""
    from planner_core.pipeline.config import PlanConfig
    from planner_core.pipeline.schedule import DefaultScheduler

    for task, uniform in (("L01", True), ("L03", True), ("L04", False), ("L06", False),
                          ("L07", False)):
        problem = Problem(load_map(LARGE / f"{task}.json").planning_map())
        s = DefaultScheduler()
        s.reset(problem, PlanConfig())
        assert s.large and s.uniform == uniform, task
        s = DefaultScheduler(plan_windows=False)  # the learned schedulers' action space
        s.reset(problem, PlanConfig())
        assert s.large and not s.uniform, task


def test_moves_descend_to_coarser_steps_on_clustered_fields_and_corridors(monkeypatch) -> None:
    """A structural move's descent stops at `FIELD_MIN_STEP` (5 m) on a large problem whose
    layout is not uniform (L04-L08), at the descent's own 1 cm elsewhere (L01-L03; the
    paper's maps: not large), and `_move` hands that step to its descent."""
    from planner_core.search import structure
    from planner_core.search.structure import FIELD_MIN_STEP, move_min_step

    for task, uniform, step in (("L01", True, None), ("L03", True, None),
                                ("L04", False, FIELD_MIN_STEP), ("L07", False, FIELD_MIN_STEP),
                                ("L08", False, FIELD_MIN_STEP),
                                ("L06", False, FIELD_MIN_STEP)):
        problem = Problem(load_map(LARGE / f"{task}.json").planning_map())
        assert problem.uniform_layout == uniform, task
        assert move_min_step(problem) == step, task
    paper = Problem(load_map(SUITE / "T16.json"))
    assert move_min_step(paper) is None  # 20 hover points at most: not large
    import lamde_mission

    m = load_map(LARGE / "L04.json")
    plan = lamde_mission.plan(m, seed=0, budget=1500)  # a feasible plan to move from
    problem = Problem(m.planning_map())
    seen: list[object] = []

    def spy(*args, **kw):
        seen.append(kw.get("min_step"))
        return None  # as a descent that found nothing: _move keeps the move's own plan

    monkeypatch.setattr(structure, "descend", spy)
    ev = Evaluator(problem, 100)
    out = structure._move(problem, np.asarray(plan.hover_points), ev.evaluate, 10)
    assert out is not None and seen == [FIELD_MIN_STEP]
