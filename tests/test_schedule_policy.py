"""LAMDE-S's learned policy (planner_core.learning.schedule_policy, schedule_ppo): the numpy
network against its torch twin, GAE by hand, checkpoints and their refusals, the scheduler's
choices, the env's cached prefixes giving the same episodes, and a small training run."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner_core.learning.schedule_env import FEATURES, N_FEATURES, ScheduleEnv, ScheduleFeatures
from planner_core.learning.schedule_policy import (
    DEFAULT_CHECKPOINT,
    PolicyScheduler,
    forward,
    init_params,
    load,
    rollout,
    save,
)
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from planner_core.pipeline import PlanConfig, run_pipeline
from planner_core.pipeline.schedule import ACTIONS, make_scheduler, scheduler_names
from tests.conftest import MAPS

A = len(ACTIONS)


def _manifest(**kw: object) -> dict:
    return {"actions": list(ACTIONS), "features": list(FEATURES), **kw}


def test_the_numpy_network_equals_its_torch_twin() -> None:
    torch = pytest.importorskip("torch")
    from planner_core.learning.schedule_ppo import Agent

    p = init_params(N_FEATURES, A, hidden=16, seed=3)
    rng = np.random.default_rng(0)
    p["mu"], p["sd"] = rng.normal(size=N_FEATURES), rng.uniform(0.5, 2.0, N_FEATURES)
    x = rng.normal(size=(7, N_FEATURES))
    logits, values = forward(p, x)
    tl, tv = Agent(p)(torch.tensor(x))
    assert logits.shape == (7, A) and values.shape == (7,)
    np.testing.assert_allclose(tl.detach().numpy(), logits, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tv.detach().numpy(), values, rtol=1e-12, atol=1e-12)
    back = Agent(p).numpy_params()
    assert all(np.array_equal(back[k], p[k]) for k in p)


def test_gae_by_hand() -> None:
    pytest.importorskip("torch")
    from planner_core.learning.schedule_ppo import gae

    r, v = np.array([1.0, 0.0, 2.0]), np.array([0.5, 0.25, 1.0])
    g, lam = 0.9, 0.5
    d = [1.0 + g * 0.25 - 0.5, 0.0 + g * 1.0 - 0.25, 2.0 - 1.0]
    want = [d[0] + g * lam * (d[1] + g * lam * d[2]), d[1] + g * lam * d[2], d[2]]
    np.testing.assert_allclose(gae(r, v, g, lam), want)


def test_a_checkpoint_round_trips_and_refuses_other_actions_or_features(tmp_path) -> None:
    p = init_params(N_FEATURES, A, hidden=8, seed=1)
    save(tmp_path / "ck", p, _manifest(hidden=8))
    q, m = load(tmp_path / "ck")
    assert m["hidden"] == 8 and all(np.array_equal(p[k], q[k]) for k in p)
    assert not list((tmp_path / "ck").glob("*.tmp*"))
    save(tmp_path / "old", p, _manifest() | {"actions": list(ACTIONS[:-2]) + ["stop"]})
    with pytest.raises(ValueError, match="^checkpoint: .*trained on actions"):
        load(tmp_path / "old")
    save(tmp_path / "feat", p, _manifest() | {"features": list(FEATURES[:-1])})
    with pytest.raises(ValueError, match="^checkpoint: .*other features"):
        load(tmp_path / "feat")
    with pytest.raises(ValueError, match="^checkpoint: cannot read"):
        load(tmp_path / "missing")
    bad = dict(p, Wpi=p["Wpi"][:, :-1])
    save(tmp_path / "shape", bad, _manifest())
    with pytest.raises(ValueError, match="misshaped arrays \\['Wpi', 'bpi'\\]|misshaped"):
        load(tmp_path / "shape")


class _Recording:
    """Wraps a scheduler and records its choices."""

    def __init__(self, inner: object) -> None:
        self.inner, self.name, self.chosen, self.idle = inner, inner.name, [], []

    def reset(self, problem: object, config: object) -> None:
        self.inner.reset(problem, config)

    def choose(self, observation: object) -> str:
        a = self.inner.choose(observation)
        self.chosen.append(a)
        self.idle.append(observation.idle)
        return a


def test_the_scheduler_takes_the_most_probable_action_and_stops_when_idle() -> None:
    from planner_core.pipeline.schedule import IDLE_ROUNDS

    problem = Problem(load_map(MAPS / "tiny.json").planning_map())
    for name in ("kicks-700", "rebuild"):
        p = init_params(N_FEATURES, A, hidden=8, seed=0)
        p["bpi"][ACTIONS.index(name)] = 50.0  # dominates every logit
        rec = _Recording(PolicyScheduler(params=p))
        res = run_pipeline(problem, PlanConfig(seed=2, budget=3_000, population=20),
                           scheduler=rec)
        assert res.phi == 0.0 and rec.chosen
        assert set(rec.chosen) <= {name, "stop"}
        assert res.state.actions == tuple(a for a in rec.chosen if a != "stop")
        # "stop" only once the last IDLE_ROUNDS actions spent nothing
        assert all(i >= IDLE_ROUNDS for a, i in zip(rec.chosen, rec.idle, strict=True)
                   if a == "stop")


def test_the_shipped_policy_loads_plans_deterministically_and_is_registered() -> None:
    assert "lamde-s-ppo" in scheduler_names()
    params, manifest = load(DEFAULT_CHECKPOINT)
    assert manifest["cpu_seconds"] > 0 and manifest["curve"]
    assert isinstance(make_scheduler("lamde-s-ppo"), PolicyScheduler)
    problem = Problem(load_map(MAPS / "tiny.json").planning_map())
    cfg = PlanConfig(seed=1, budget=3_000, population=20)
    a = run_pipeline(problem, cfg, scheduler="lamde-s-ppo")
    b = run_pipeline(problem, cfg, scheduler="lamde-s-ppo")
    assert a.x.tobytes() == b.x.tobytes() and a.phi == 0.0


def test_cached_prefixes_give_the_same_episodes() -> None:
    def episode(env: ScheduleEnv) -> tuple[list, float, bytes]:
        x, info = env.reset(seed=0, options={"map": MAPS / "tiny.json", "plan_seed": 3})
        xs, done = [x], False
        for a in ("kicks-120", "restart", "kicks-300", "stop"):
            x, _, done, _, _ = env.step(ACTIONS.index(a))
            xs.append(x)
            if done:
                break
        return xs, info["f_reference"], env.result.x.tobytes()

    plain = ScheduleEnv(budget=3_000, population=20)
    cached = ScheduleEnv(budget=3_000, population=20, cache=True)
    want = episode(plain)
    for _ in range(2):  # the second from the cached prefix
        got = episode(cached)
        assert got[1] == want[1] and got[2] == want[2]
        assert all(np.array_equal(g, w) for g, w in zip(got[0], want[0], strict=True))
    assert len(cached._prefixes) == 1


def test_features_from_an_observation_are_the_envs() -> None:
    env = ScheduleEnv(budget=3_000, population=20)
    x, _ = env.reset(seed=0, options={"map": MAPS / "tiny.json", "plan_seed": 5})
    fresh = ScheduleFeatures(env.problem, env.cfg)
    assert np.array_equal(fresh(env.observation()), x)
    x, *_ = env.step(ACTIONS.index("kicks-300"))
    assert np.array_equal(fresh(env.observation()), x)


def test_a_demonstration_is_the_default_plan() -> None:
    from planner_core.suite import generated_maps

    name, data = generated_maps(1, 77)[0]
    out = rollout({"map": data, "key": name, "plan_seed": 4, "budget": 3_000,
                   "population": 20, "params": None, "sample_seed": None})
    want = run_pipeline(Problem(load_map(data).planning_map()),
                        PlanConfig(seed=4, budget=3_000, population=20))
    assert out["f"] == want.f == out["f_reference"]
    assert out["obs"].shape == (len(out["actions"]), N_FEATURES)
    assert len(out["rewards"]) == len(out["actions"])


@pytest.mark.slow  # measured ~20 s: 2 generated maps at 10,000 evaluations, BC and 2 PPO
def test_a_small_training_run_writes_a_loadable_checkpoint_the_same_each_time(tmp_path) -> None:
    pytest.importorskip("torch")
    from planner_core.learning.schedule_ppo import main

    argv = ["--maps", "2", "--seeds", "1", "--iterations", "2", "--episodes", "2",
            "--bc-epochs", "50", "--bc-coef", "0", "--eval-every", "1"]
    assert main(["-o", str(tmp_path / "a"), "--jobs", "0", *argv]) == 0
    assert main(["-o", str(tmp_path / "b"), "--jobs", "1", *argv]) == 0
    params, manifest = load(tmp_path / "a")
    assert [r["iteration"] for r in manifest["curve"]] == [0, 1, 2]
    assert 0.0 <= manifest["curve"][0]["bc_accuracy"] <= 1.0
    assert "greedy_f_vs_default_pct" in manifest["curve"][1]
    assert manifest["max_points"] in (10, 20) and manifest["cases"] == 2
    assert json.loads((tmp_path / "a" / "manifest.json").read_text())["args"]["maps"] == 2
    # same seed, same weights, in this process or a worker
    other, _ = load(tmp_path / "b")
    assert all(np.array_equal(params[k], other[k]) for k in params)
    assert main(["-o", str(tmp_path / "c"), "--maps", "0"]) == 2
    assert main(["-o", str(tmp_path / "c"), "--reference", "gap"]) == 2
    assert not (tmp_path / "c").exists()


def test_the_paired_baseline_is_the_defaults_return_up_to_the_first_departure() -> None:
    pytest.importorskip("torch")
    from planner_core.learning.schedule_ppo import Args, advantages, gae

    demo = {"actions": np.array([0, 3, 1, 3]), "rewards": np.array([0.5, 0.0, 0.25, 0.0])}
    ep = {"actions": np.array([0, 3, 2, 0, 3]), "rewards": np.array([0.5, 0.0, 0.5, 0.1, 0.0]),
          "values": np.array([0.7, 0.3, 0.2, 0.1, 0.05])}
    adv, ret = advantages(ep, demo, Args(gamma=1.0, gae_lambda=0.9))
    g = np.array([1.1, 0.6, 0.6, 0.1, 0.0])
    np.testing.assert_allclose(ret, g)
    # steps 0, 1 follow the default, step 2 departs: G_t - G_t(default) there
    np.testing.assert_allclose(adv[:3], g[:3] - np.array([0.75, 0.25, 0.25]))
    np.testing.assert_allclose(adv[3:], gae(ep["rewards"], ep["values"], 1.0, 0.9)[3:])
    plain, _ = advantages(ep, demo, Args(gamma=1.0, gae_lambda=0.9, paired=False))
    np.testing.assert_allclose(plain, gae(ep["rewards"], ep["values"], 1.0, 0.9))


@pytest.mark.slow  # measured 1.5 s on a loaded machine (default suite <= 5 min)
def test_beyond_the_trained_sizes_the_policy_follows_the_default() -> None:
    from planner_core.pipeline.schedule import DefaultScheduler

    problem = Problem(load_map(MAPS / "tiny.json").planning_map())
    p = init_params(N_FEATURES, A, hidden=8, seed=0)
    p["bpi"][ACTIONS.index("de-block")] = 50.0
    cfg = PlanConfig(seed=2, budget=3_000, population=20)
    small = problem.hover_limit - 1
    rec, ref = _Recording(PolicyScheduler(params=p, max_points=small)), _Recording(
        DefaultScheduler())
    a = run_pipeline(problem, cfg, scheduler=rec)
    b = run_pipeline(problem, cfg, scheduler=ref)
    assert rec.chosen == ref.chosen and "de-block" not in rec.chosen
    assert a.x.tobytes() == b.x.tobytes()
    within = _Recording(PolicyScheduler(params=p, max_points=problem.hover_limit))
    run_pipeline(problem, cfg, scheduler=within)
    assert set(within.chosen) <= {"de-block", "stop"}
    # the plan says when the policy handed the stage to the default
    import lamde_mission

    handed = lamde_mission.plan(MAPS / "tiny.json", config=cfg,
                                scheduler=PolicyScheduler(params=p, max_points=small))
    assert handed.config["scheduler_choice"] == "default"
    own = lamde_mission.plan(MAPS / "tiny.json", config=cfg,
                             scheduler=PolicyScheduler(params=p, max_points=problem.hover_limit))
    assert "scheduler_choice" not in own.config


def test_a_learned_scheduler_is_named_with_its_checkpoint_folder(tmp_path) -> None:
    from planner_core.learning.schedule_select import DEFAULT_TABLE, SelectorScheduler

    p = init_params(N_FEATURES, A, hidden=8, seed=4)
    save(tmp_path / "ck", p, _manifest(max_points=7))
    s = make_scheduler(f"lamde-s-ppo:{tmp_path / 'ck'}")
    assert isinstance(s, PolicyScheduler) and s.max_points == 7
    assert np.array_equal(s.params["W1"], p["W1"])
    assert isinstance(make_scheduler(f"lamde-s:{DEFAULT_TABLE}"), SelectorScheduler)
    with pytest.raises(ValueError, match="^scheduler: checkpoint: cannot read"):
        make_scheduler(f"lamde-s-ppo:{tmp_path / 'none'}")
    with pytest.raises(ValueError, match="^scheduler: must be one of"):
        make_scheduler("nope:dir")


@pytest.mark.slow  # measured 4.1 s on a loaded machine (issue 35: default suite <= 5 min)
def test_the_cli_plans_with_the_policy_and_refuses_a_missing_checkpoint(tmp_path) -> None:
    import subprocess
    import sys

    base = [sys.executable, "-m", "lamde_mission.cli", "plan", str(MAPS / "tiny.json")]
    r = subprocess.run([*base, "-o", str(tmp_path / "t.plan"), "--scheduler", "lamde-s-ppo",
                        "--budget", "12000", "--seed", "3"], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    line = next(s for s in r.stdout.splitlines() if s.startswith("map '"))
    assert "scheduler lamde-s-ppo" in line, line
    r = subprocess.run([*base, "-o", str(tmp_path / "x.plan"), "--scheduler",
                        f"lamde-s-ppo:{tmp_path / 'none'}"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 2 and not (tmp_path / "x.plan").exists()
    assert r.stderr.strip().count("\n") == 0
    assert "--scheduler: checkpoint: cannot read" in r.stderr


def test_the_docs_lamde_s_ppo_figures_are_the_stored_records() -> None:
    from tests.conftest import ROOT
    from tests.test_schedule import _bench

    bench, runs = _bench(), ROOT / "docs" / "scheduler-runs"
    doc = (ROOT / "docs" / "scheduler.md").read_text()
    doc = doc[doc.index("## LAMDE-S-PPO"):]

    def summary(name: str) -> dict[str, list[str]]:
        out = bench.summarise(bench._read([str(runs / name)]))
        return {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[2:7]]
                for r in out.splitlines() if r.startswith("| ") and "---" not in r}

    held = summary("ppo-heldout100x2.jsonl.gz")
    for t in ("fresh-heavy", "lamde-s-ppo"):
        gap, _, diff, bw, _ = held[t]
        assert f"| `{t}` | {gap} | {diff} | {bw} |" in doc, t
    suite25, held200 = summary("ppo-suite25.jsonl.gz"), summary("ppo-held200.jsonl.gz")
    assert f"default {suite25['default'][0]} %" in doc
    assert f"default {held200['default'][0]} %" in doc
    for t in ("fresh-heavy", "lamde-s-ppo"):
        assert f"`{t}` {suite25[t][0]} % ({suite25[t][2]} points" in doc, t
        assert f"`{t}` {held200[t][0]} % ({held200[t][2]}" in doc, t


def test_damaged_or_mismatched_checkpoints_are_refused_in_one_line(tmp_path) -> None:
    p = init_params(N_FEATURES, A, hidden=8, seed=1)
    save(tmp_path / "ck", p, _manifest())
    raw = (tmp_path / "ck" / "weights.npz").read_bytes()
    (tmp_path / "ck" / "weights.npz").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(ValueError, match="^checkpoint: cannot read"):
        load(tmp_path / "ck")
    save(tmp_path / "ck", p, _manifest())
    save(tmp_path / "other", init_params(N_FEATURES, A, hidden=8, seed=2), _manifest())
    (tmp_path / "ck" / "weights.npz").write_bytes((tmp_path / "other" / "weights.npz")
                                                  .read_bytes())
    with pytest.raises(ValueError, match="weights_sha256 differs"):
        load(tmp_path / "ck")
    save(tmp_path / "list", p, _manifest())
    (tmp_path / "list" / "manifest.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match="must be a JSON object"):
        load(tmp_path / "list")
    save(tmp_path / "mp", p, _manifest(max_points="abc"))
    with pytest.raises(ValueError, match="max_points must be a whole number"):
        load(tmp_path / "mp")
    with pytest.raises(ValueError, match="^scheduler: 'lamde-s-ppo:' names no checkpoint"):
        make_scheduler("lamde-s-ppo:")


def test_a_deadline_that_does_not_bind_leaves_the_policys_plan_unchanged() -> None:
    problem = Problem(load_map(MAPS / "tiny.json").planning_map())
    base = dict(seed=1, budget=3_000, population=20)
    a = run_pipeline(problem, PlanConfig(**base), scheduler="lamde-s-ppo")
    b = run_pipeline(problem, PlanConfig(**base, time_limit=600.0), scheduler="lamde-s-ppo")
    assert a.x.tobytes() == b.x.tobytes() and a.state.actions == b.state.actions


@pytest.mark.parametrize(("flag", "value", "want"), [
    ("--lr", "-1", "lr: must be > 0.0"), ("--bc-smoothing", "1", "bc_smoothing: must be"),
    ("--gamma", "0", "gamma: must be > 0.0 and <= 1.0"), ("--seed", "-1", "seed: must be >= 0"),
    ("--eval-every", "-2", "eval_every: must be >= 0"), ("--maps", "0", "maps: must be >= 1"),
    ("--reference", "gap", "reference: must be 'default' or 'percent'"),
    ("--paired", "maybe", "must be true or false")])
def test_the_trainer_refuses_bad_settings_before_any_work(tmp_path, capsys, flag, value,
                                                           want) -> None:
    pytest.importorskip("torch")
    from planner_core.learning.schedule_ppo import main

    try:
        rc = main(["-o", str(tmp_path / "ck"), flag, value])
    except SystemExit as exc:  # argparse's own refusal (a bad boolean)
        rc = exc.code
    assert rc == 2 and want in capsys.readouterr().err
    assert not (tmp_path / "ck").exists()


def test_the_trainer_without_torch_is_one_line_exit_2(tmp_path) -> None:
    """`python -m planner_core.learning.schedule_ppo` without torch ended in the import's
    ModuleNotFoundError traceback (exit 1), where `lamde-mission train` says it needs torch in
    one line (exit 2); now the module's command line says so too. Torch is hidden as an
    uninstalled one is (sys.modules["torch"] = None), the module run as `-m` runs it."""
    import subprocess
    import sys

    from tests.conftest import ROOT

    code = ("import runpy, sys; sys.modules['torch'] = None; "
            f"sys.argv = ['schedule_ppo', '-o', {str(tmp_path / 'ck')!r}]; "
            "runpy.run_module('planner_core.learning.schedule_ppo', run_name='__main__', "
            "alter_sys=True)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                       timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr == "schedule_ppo: needs torch: pip install 'lamde-mission[train]'\n"
    assert r.stdout == "" and not (tmp_path / "ck").exists()


def test_the_trainer_refuses_a_bad_maps_file_or_output_before_any_work(tmp_path,
                                                                        capsys) -> None:
    pytest.importorskip("torch")
    from planner_core.learning.schedule_ppo import main

    bad = tmp_path / "picks.json"
    bad.write_text('{"maps": [{"name": "a", "size": "abc", "density": 1, "seed": 3}]}')
    assert main(["-o", str(tmp_path / "ck"), "--maps-file", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "maps_file: " in err and "entry 0: " in err and err.count("\n") == 1
    bad.write_text('{"maps": []}')
    assert main(["-o", str(tmp_path / "ck"), "--maps-file", str(bad)]) == 2
    assert "'maps' must be a non-empty list" in capsys.readouterr().err
    (tmp_path / "afile").write_text("")
    assert main(["-o", str(tmp_path / "afile" / "ck"), "--maps", "1"]) == 2
    assert "output: " in capsys.readouterr().err
    assert not (tmp_path / "ck").exists()


def test_the_schedule_benchmark_refuses_a_bad_checkpoint_before_any_run(tmp_path,
                                                                          capsys) -> None:
    from tests.test_schedule import _bench

    out = tmp_path / "runs.jsonl"
    rc = _bench().main(["--suite", "T01", "--seeds", "1", "--templates", "default",
                        f"lamde-s-ppo:{tmp_path / 'none'}", "-o", str(out)])
    assert rc == 2 and not out.exists()
    assert "--templates: scheduler: checkpoint: cannot read" in capsys.readouterr().err
