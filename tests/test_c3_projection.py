"""The descent's C3 projection (`planner_core.search.trial.project_c3`, issue 31): the
compiled kernel equals its numpy reference to the bit, a projected point keeps C3 and lies
on its bandwidth limit, what keeps C3 is not moved, and scheduled access is left alone."""

from __future__ import annotations

import copy
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from planner_core.model.problem import Problem
from planner_core.search.trial import (
    C3_MARGIN,
    C3_TOLERANCE,
    project_c3,
    project_c3_reference,
)
from tests.test_scaling_paths import CASES

MAPS = Path(__file__).resolve().parent.parent / "examples" / "maps"


def _tight(problem: Problem, pts: np.ndarray) -> Problem:
    """`problem` with a bandwidth that about half of the points pts (I, 2) break (C3 binds)."""
    sums = problem.model.rates(pts).sum(axis=1)
    out = copy.copy(problem)
    if (sums > 0).any():
        out.model = dataclasses.replace(problem.model,
                                        bandwidth=float(np.median(sums[sums > 0])))
    return out


def _moves(problem: Problem, pts: np.ndarray, rng: np.random.Generator
           ) -> tuple[np.ndarray, np.ndarray]:
    """Points near pts and moves of 0-600 m (a few zero), as a per-point descent draws them."""
    m = problem.model
    box = np.array([m.width, m.height])
    P = np.clip(pts + rng.normal(0, 30, pts.shape), 0.0, box)
    move = rng.normal(size=P.shape) * rng.choice([0.0, 5.0, 60.0, 600.0], (len(P), 1))
    return P, move


@pytest.mark.parametrize("name,problem,pts", CASES, ids=[c[0] for c in CASES])
def test_projection_equals_its_reference(name: str, problem: Problem, pts: np.ndarray
                                         ) -> None:
    rng = np.random.default_rng(len(pts) + 3)
    moved = 0
    for p in (problem, _tight(problem, pts)):
        box = np.array([p.model.width, p.model.height])
        for _ in range(6):
            P, move = _moves(p, pts, rng)
            fast = project_c3(p, P, move, box)
            slow = project_c3_reference(p, P, move, box)
            assert np.array_equal(fast.view(np.int64), slow.view(np.int64)), name
            moved += int((fast != move).any(axis=1).sum())
    if "near" in name or name.startswith("random"):
        assert moved > 0, name  # the tight bandwidth makes some steps cross it


def test_a_projected_point_keeps_c3_on_its_limit_and_the_rest_stay() -> None:
    p = Problem(json.loads((MAPS / "suite" / "T09.json").read_text()))
    rng = np.random.default_rng(5)
    near = p.model.sensors[rng.integers(0, len(p.model.sensors), 40)]
    p = _tight(p, near)
    m = p.model
    box = np.array([m.width, m.height])
    P, move = _moves(p, near, rng)
    q = np.clip(P - move, 0.0, box)
    over = m.rates(q).sum(axis=1) > m.c3_limit
    out = project_c3(p, P, move, box)
    new = np.clip(P - out, 0.0, box)
    sums = m.rates(new).sum(axis=1)
    projected = (out != move).any(axis=1)
    assert projected.sum() >= 5 and not projected[~over].any()  # only steps across the limit
    # projected: under the limit, by at most the tolerance (each on the line it was pushed
    # along: farther from q the more it was over)
    lim = m.c3_limit
    assert np.all(sums[projected] <= lim * (1 - C3_MARGIN))
    assert np.all(sums[projected] >= lim * (1 - C3_MARGIN - C3_TOLERANCE) - 1e-9)
    assert np.allclose(new[~projected], q[~projected])


def test_scheduled_access_has_no_c3_to_project() -> None:
    d = json.loads((MAPS / "suite" / "T09.json").read_text())
    d["radio"] = {**d.get("radio", {}), "access": "scheduled"}
    p = Problem(d)
    rng = np.random.default_rng(2)
    P, move = _moves(p, p.model.sensors[:10], rng)
    box = np.array([p.model.width, p.model.height])
    assert np.array_equal(project_c3(p, P, move, box), move)
    assert np.array_equal(project_c3_reference(p, P, move, box), move)


def test_the_descent_moves_points_along_the_limit_on_a_dense_field() -> None:
    """On a clustered field (L04) the hover points sit on their bandwidth limits; with the
    projection a descent from a constructive start ends lower than with the slides alone."""
    import planner_core.search.descent as DS
    from planner_core.model.corner_slots import problem_for
    from planner_core.model.mapio import load_map
    from planner_core.search.construct import candidate_plans

    p, _ = problem_for(load_map(MAPS / "large" / "L04.json").planning_map())
    X, _ = candidate_plans(p, seed=0, limit=1)
    x0 = X[0]
    f = {}
    for tag, proj in (("on", DS.project_c3), ("off", lambda _p, _P, mv, _b: np.array(mv))):
        old = DS.project_c3
        DS.project_c3 = proj
        try:
            f[tag] = DS.descend(p, x0, lambda X: p.evaluate(X), trials=200).f
        finally:
            DS.project_c3 = old
    assert f["on"] < f["off"]
