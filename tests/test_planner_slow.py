"""Slow: the default planner finds a feasible plan on every suite map for seeds 0, 1, 2."""

from __future__ import annotations

import pytest

import lamde_mission
from tests.conftest import SUITE

TASKS = sorted(SUITE.glob("T*.json"))


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("task", TASKS, ids=[t.stem for t in TASKS])
def test_default_planner_is_feasible_on_suite(task, seed: int) -> None:
    p = lamde_mission.plan(task, seed=seed, budget=10_000)
    assert p.evaluations <= 10_000
    assert p.feasible, f"{task.stem} seed {seed}: phi = {p.phi:.4g}, {p.breakdown}"


def test_suite_is_present() -> None:
    assert len(TASKS) == 16
