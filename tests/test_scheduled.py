"""`radio.access` "scheduled" (issue 31): the sensors in range of a hover point share
R_lambda by time slots (D_ij <= R_ij T_i, sum_j D_ij <= R_lambda T_i, no C3). The planner's
evaluation (a max flow), its hover-time LP and the sim's own allocation LP."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from lamde_mission.formats import read_mission
from planner_core.model.diagnose import diagnose
from planner_core.model.hoverlp import hover_lp, scheduled_lp
from planner_core.model.kernels import scheduled_flow
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from sim import replay, verify
from sim.mission import CMD
from sim.replay import scheduled_allocation
from tests.conftest import run_cli, run_cli_many
from tests.test_cannot import dense_field


def _max_flow_lp(R: np.ndarray, t: np.ndarray, Q: np.ndarray, bw: float) -> float:
    """The reference: max sum D s.t. D_ij <= R_ij t_i, sum_j D_ij <= bw t_i,
    sum_i D_ij <= Q_j (scipy's linprog)."""
    from scipy.optimize import linprog

    idx = [(i, j) for i in range(R.shape[0]) for j in range(R.shape[1]) if R[i, j] > 0]
    if not idx:
        return 0.0
    rows = [[1.0 if p[0] == i else 0.0 for p in idx] for i in range(R.shape[0])]
    rows += [[1.0 if p[1] == j else 0.0 for p in idx] for j in range(R.shape[1])]
    res = linprog(-np.ones(len(idx)), A_ub=rows, b_ub=[*(bw * t), *Q],
                  bounds=[(0, R[i, j] * t[i]) for i, j in idx], method="highs")  # fmt: skip
    return -res.fun


def test_the_evaluations_max_flow_is_the_lp_optimum() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        k, J = int(rng.integers(1, 7)), int(rng.integers(1, 12))
        R = np.where(rng.random((k, J)) < 0.6, rng.uniform(0, 9, (k, J)), 0.0)
        t, Q, bw = rng.uniform(0, 60, k), rng.uniform(0, 300, J), float(rng.uniform(3, 40))
        F = scheduled_flow(R, t, Q, bw)
        assert np.all(F <= Q + 1e-9) and np.all(F <= R.T @ t + 1e-9)
        assert F.sum() == pytest.approx(_max_flow_lp(R, t, Q, bw), rel=1e-9, abs=1e-9)


def test_scheduled_lp_is_the_hover_lp_when_the_bandwidth_is_ample() -> None:
    rng = np.random.default_rng(4)
    for _ in range(30):
        R = np.where(rng.random((5, 8)) < 0.5, rng.uniform(0, 9, (5, 8)), 0.0)
        R[np.arange(5), rng.integers(0, 8, 5)] += 1.0
        req = rng.uniform(10, 300, 8) * (R.sum(axis=0) > 0)
        bw = 2 * float(R.sum(axis=1).max())  # above every point's rate sum
        a, b = hover_lp(R, req, 1e6), scheduled_lp(R, req, bw, 1e6)
        assert (a is None) == (b is None)
        if a is not None:
            assert b[2] == pytest.approx(a[1], rel=1e-7)
        if b is not None:  # its allocation is feasible and meets every requirement
            T, D = b[0], b[1].toarray()
            assert np.all(D <= R * T[:, None] * (1 + 1e-7) + 1e-9)
            assert np.all(D.sum(axis=0) >= req * (1 - 1e-7))


def test_kernel_and_numpy_twin_agree_in_scheduled_access() -> None:
    p = Problem(dense_field(radio={"access": "scheduled"}))
    assert p.scheduled
    rng = np.random.default_rng(0)
    X = p.lower + rng.random((64, p.dim)) * (p.upper - p.lower)
    X[:8, 0::4] = 500 + rng.normal(0, 30, (8, p.n_points))  # over the field: saturated
    X[:8, 1::4] = 500 + rng.normal(0, 30, (8, p.n_points))
    f, phi = p.evaluate(X)
    parts = p._evaluate_parts(X)
    assert np.allclose(f, parts["f"]) and np.allclose(phi, parts["phi"], rtol=1e-9, atol=1e-9)
    assert np.all(parts["v3"] == 0.0)


@pytest.mark.slow  # 8.4 s measured in the default suite
def test_a_field_only_c3_rules_out_is_planned_with_scheduled_access(tmp_path) -> None:
    """12 sensors within 40 m: under the paper's C3 no point serves them (check: CANNOT);
    scheduled, check passes, the plan is feasible, the sim verifies the mission, and the same
    mission with a hover time cut short fails C4."""
    simultaneous, scheduled = tmp_path / "c3.json", tmp_path / "slots.json"
    simultaneous.write_text(json.dumps(dense_field()))
    scheduled.write_text(json.dumps(dense_field(origin={"lat": 46.2, "lon": 7.3, "alt": 500.0},
                                                radio={"access": "scheduled"})))  # fmt: skip
    assert not [f for f in diagnose(load_map(scheduled)).findings if f.fatal]
    mission = tmp_path / "slots.plan"
    r_c3, r_slots, r_plan = run_cli_many(
        ("check", simultaneous), ("check", scheduled),
        ("plan", scheduled, "-o", mission, "--budget", "1500", "--quiet"))
    assert r_c3.returncode == 1 and r_c3.stdout.count("  CANNOT  ") == 12
    assert r_slots.returncode == 0, r_slots.stdout
    assert "CANNOT" not in r_slots.stdout and "access scheduled" in r_slots.stdout
    assert r_plan.returncode == 0, r_plan.stdout + r_plan.stderr
    r = run_cli("verify", scheduled, mission)
    assert r.returncode == 0, r.stdout + r.stderr
    m = load_map(scheduled)
    items, _ = read_mission(mission)
    tl = replay(items, m)
    assert tl.allocation is not None
    assert np.all(tl.allocation.sum(axis=1) <= 25.0 * tl.hover_times * (1 + 1e-6))
    v = verify(tl, m)
    assert v.passed, v.table()
    cut = list(items)
    i = max(i for i, it in enumerate(cut) if it.command == CMD.LOITER_TIME)
    cut[i] = replace(cut[i], param1=0.8 * cut[i].param1)
    v = verify(replay(cut, m), m)
    assert "C4" in v.failed, v.table()


def test_the_sims_allocation_maximises_the_worst_share() -> None:
    R = np.array([[9.0, 9.0, 9.0], [0.0, 0.0, 5.0]])
    t = np.array([20.0, 10.0])
    D = scheduled_allocation(R, t, np.array([100.0, 100.0, 100.0]), 15.0)
    assert np.all(D <= R * t[:, None] + 1e-9)
    assert np.all(D.sum(axis=1) <= 15.0 * t + 1e-9)
    # 300 s.Mbit of bandwidth at point 1 and 50 of sensor 3 at point 2: 350 / 300 each at best
    assert D.sum(axis=0) == pytest.approx([350 / 3] * 3, rel=1e-6)


def test_a_bad_access_is_one_line_naming_the_field(tmp_path) -> None:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(dense_field(radio={"access": "tdma"})))
    r = run_cli("check", path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "radio.access" in lines[0]
