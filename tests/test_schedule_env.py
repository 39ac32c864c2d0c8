"""LAMDE-S's MDP (planner_core.learning.schedule_env): check_env, and following the default
scheduler's choices through the env gives the default plan to the bit."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from planner_core.learning.schedule_env import ENV_ID, FEATURES, N_FEATURES, ScheduleEnv
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from planner_core.pipeline import PlanConfig, run_pipeline
from planner_core.pipeline.schedule import ACTIONS, DefaultScheduler
from tests.conftest import MAPS, SUITE


def _follow_default(env: ScheduleEnv, **reset: object) -> tuple[float, dict]:
    env.reset(**reset)
    s, total, done, info = DefaultScheduler(plan_windows=False), 0.0, False, {}
    st = env.observation().state
    s.reset(st.problem, st.config)  # the default's rounds depend on the problem's size
    while not done:
        a = ACTIONS.index(s.choose(env.observation()))
        obs, r, done, _, info = env.step(a)
        assert obs.shape == (N_FEATURES,) and np.isfinite(obs).all()
        total += r
    return total, info


@pytest.mark.slow  # measured 10.6 s (check_env resets and steps the tiny map's plan)
def test_the_env_passes_gymnasiums_checker_and_is_registered() -> None:
    env = ScheduleEnv([MAPS / "tiny.json"], budget=1_500, population=20, reference="percent")
    check_env(env, skip_render_check=True)
    assert len(FEATURES) == N_FEATURES and 30 <= N_FEATURES <= 41
    made = gymnasium.make(ENV_ID, maps=[MAPS / "tiny.json"], budget=1_500, population=20)
    assert isinstance(made.unwrapped, ScheduleEnv)


@pytest.mark.parametrize(("seed", "budget"), [
    (0, 1_500), pytest.param(4, 3_000, marks=pytest.mark.slow)])  # ~3.3 s each
def test_following_the_default_scheduler_reproduces_the_default_plan(seed: int,
                                                                     budget: int) -> None:
    env = ScheduleEnv([MAPS / "tiny.json"], budget=budget, population=20)
    total, info = _follow_default(env, seed=1, options={"plan_seed": seed})
    want = run_pipeline(Problem(load_map(MAPS / "tiny.json").planning_map()),
                        PlanConfig(seed=seed, budget=budget, population=20))
    assert env.result.x.tobytes() == want.x.tobytes() and info["f"] == want.f
    assert env.improve.step > 0 and any(s.name == "improve" for s in want.stages)
    assert [(s.name, s.evaluations) for s in env.result.stages] == [
        (s.name, s.evaluations) for s in want.stages]
    # the reference is the default's own f: following it closes the whole gap
    assert total == pytest.approx(1.0, abs=1e-9) or env.f_start == want.f


@pytest.mark.slow  # measured ~12 s: T06 at 10,000 evaluations, twice (env and reference)
def test_the_default_through_the_env_on_a_suite_map_at_the_default_budget() -> None:
    path = SUITE / "T06.json"
    env = ScheduleEnv([path], budget=10_000)
    _follow_default(env, seed=0, options={"plan_seed": 1})
    want = run_pipeline(Problem(load_map(path).planning_map()), PlanConfig(seed=1))
    assert env.result.x.tobytes() == want.x.tobytes()


def test_a_generated_map_episode_runs_other_actions_to_the_end() -> None:
    env = ScheduleEnv(None, budget=3_000, population=20, reference="percent",
                      config=PlanConfig(de_share=0.2))
    _, info = env.reset(seed=7)
    assert info["map"][0] == "gen"
    done = False
    for a in ("restructure", "kicks-700", "fresh", "de-block", "restart-other", "stop"):
        _, _, done, _, _ = env.step(ACTIONS.index(a))
        if done:
            break
    assert done and env.result.evaluations <= 3_000 and env.result.phi == 0.0
    with pytest.raises(RuntimeError, match="^step: call reset"):
        env.step(0)


def test_a_given_map_that_leaves_improve_nothing_names_itself() -> None:
    """A budget the stages before `improve` spend whole: a typed error naming the map, its plan
    seed and the budget (the trainer's command line turns it into one line, exit 2)."""
    from planner_core.learning.schedule_env import NoImprovingStageError

    env = ScheduleEnv(budget=200, population=20, reference="percent")
    with pytest.raises(NoImprovingStageError, match=r"^map tiny: .* plan seed 3 and budget 200"):
        env.reset(seed=0, options={"map": MAPS / "tiny.json", "key": "tiny", "plan_seed": 3})
