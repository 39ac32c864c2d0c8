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
    PROJECT_SLACK,
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
    if len(pts) >= 12:
        assert moved > 0, name  # the tight bandwidth makes some steps cross it


def test_a_projected_point_keeps_c3_on_its_limit_and_the_rest_stay() -> None:
    p = Problem(json.loads((MAPS / "suite" / "T09.json").read_text()))
    rng = np.random.default_rng(5)
    near = p.model.sensors[rng.integers(0, len(p.model.sensors), 300)]
    p = _tight(p, near)
    m = p.model
    box = np.array([m.width, m.height])
    # as in a descent: points that keep C3, each stepping 5-60 m toward a sensor
    P, _ = _moves(p, near, rng)
    P = P[m.rates(P).sum(axis=1) <= m.c3_limit]
    toward = m.sensors[rng.integers(0, len(m.sensors), len(P))] - P
    move = -toward / np.hypot(*toward.T)[:, None] * rng.uniform(5, 120, (len(P), 1))
    q = np.clip(P - move, 0.0, box)
    over = m.rates(q).sum(axis=1) > m.c3_limit
    out = project_c3(p, P, move, box)
    new = np.clip(P - out, 0.0, box)
    sums = m.rates(new).sum(axis=1)
    projected = (out != move).any(axis=1)
    assert over.sum() >= 10 and projected.sum() >= 0.8 * over.sum()  # most crossings placed
    assert not projected[~over].any()  # and only those
    # projected: under the limit, mostly within the tolerance of it, never farther back
    # from q than the step's length and the slack
    lim = m.c3_limit
    assert np.all(sums[projected] <= lim * (1 - C3_MARGIN))
    tight = sums[projected] >= lim * (1 - C3_MARGIN - C3_TOLERANCE) - 1e-9
    assert tight.mean() >= 0.9
    back = np.hypot(*(new - q).T)
    assert np.all(back[projected] <= np.hypot(*move.T)[projected] + PROJECT_SLACK + 1e-9)
    assert np.allclose(new[~projected], q[~projected])


def test_a_projection_never_throws_a_point_far_off() -> None:
    """A point 40 m from a sensor of a dense field, its 20 m step well over the limit (S(q)
    about 4 R_lambda): an unguarded Newton step from where the gradient is small left every
    link's range (1.3 km away, S = 0, a reviewer's case); the search keeps within the step's
    length of q, on the limit or not at all."""
    from planner_core.model.corner_slots import problem_for
    from planner_core.model.mapio import load_map

    p, _ = problem_for(load_map(MAPS / "large" / "L04.json").planning_map())
    m = p.model
    box = np.array([m.width, m.height])
    rng = np.random.default_rng(0)
    for j in range(len(m.sensors)):
        P = m.sensors[j][None, :] + rng.normal(0, 40, (8, 2))
        move = rng.normal(size=P.shape) * 20.0
        q = np.clip(P - move, 0.0, box)
        for fn in (project_c3, project_c3_reference):
            out = fn(p, P, move, box)
            new = np.clip(P - out, 0.0, box)
            moved = (out != move).any(axis=1)
            assert np.all(np.hypot(*(new - q).T)[moved] <= 20.0 * 5 + PROJECT_SLACK)
            assert np.all(m.rates(new[moved]).sum(axis=1) <= m.c3_limit)
        assert np.array_equal(project_c3(p, P, move, box).view(np.int64),
                              project_c3_reference(p, P, move, box).view(np.int64))


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
