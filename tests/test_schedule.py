"""LAMDE-S's seam (planner_core.pipeline.schedule): the improving phase as macro-actions chosen
by a scheduler. The default scheduler reproduces the improving rounds before the refactor to
the bit: tests/data/schedule_digests.json holds sha256(x, f, phi)[:16] of `run_pipeline` on
T01, T06, T16 at budgets 2,000 / 10,000 / 30,000, recorded at 1d72e5d (before the seam)."""

from __future__ import annotations

import dataclasses
import hashlib
import json

import numpy as np
import pytest

from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from planner_core.pipeline import PlanConfig, run_pipeline
from planner_core.pipeline.schedule import (
    ACTIONS,
    LARGE_CYCLE,
    PAPER_POINTS,
    SCHEDULES,
    DefaultScheduler,
    Observation,
    StaticScheduler,
    make_scheduler,
    scheduler_names,
)
from tests.conftest import MAPS, ROOT, SUITE

DIGESTS = json.loads((ROOT / "tests" / "data" / "schedule_digests.json").read_text())


def _digest(r) -> str:
    return hashlib.sha256(r.x.tobytes() + np.float64(r.f).tobytes()
                          + np.float64(r.phi).tobytes()).hexdigest()[:16]


@pytest.fixture(scope="module")
def tiny() -> Problem:
    return Problem(MAPS / "tiny.json")


def test_the_default_scheduler_alternates_kicks_and_restarts_then_stops_when_idle() -> None:
    s = DefaultScheduler()
    obs = [Observation(step=k, remaining=10, budget=10, quantum=5, idle=0, f=1.0, phi=0.0,
                       elapsed=0.0, history=(), state=None) for k in range(7)]
    assert [s.choose(o) for o in obs] == [
        "kicks-300", "restart", "kicks-120", "restart", "kicks-700", "restart", "kicks-300"]
    assert s.choose(dataclasses.replace(obs[0], idle=3)) == "stop"


def test_beyond_the_papers_sizes_the_default_alternates_kicks_and_rebuilds(tiny: Problem) -> None:
    s = DefaultScheduler()
    s.reset(tiny, PlanConfig())
    assert not s.large and tiny.model.n_points <= PAPER_POINTS
    big = Problem(ROOT / "examples" / "maps" / "large" / "L04.json")
    s.reset(big, PlanConfig())
    assert s.large
    obs = [Observation(step=k, remaining=10, budget=10, quantum=5, idle=0, f=1.0, phi=0.0,
                       elapsed=0.0, history=(), state=None) for k in range(7)]
    assert [s.choose(o) for o in obs] == [*LARGE_CYCLE, LARGE_CYCLE[0]]
    assert "rebuild" in LARGE_CYCLE and "restart" not in LARGE_CYCLE
    assert SCHEDULES["kicks-rebuild"] == LARGE_CYCLE


def test_default_alternate_and_an_explicit_default_give_the_same_plan(tiny: Problem) -> None:
    cfg = PlanConfig(seed=3, budget=2_000, population=20)
    base = run_pipeline(tiny, cfg)
    for spec in ("default", "alternate", DefaultScheduler()):
        r = run_pipeline(tiny, cfg, scheduler=spec)
        assert r.x.tobytes() == base.x.tobytes() and r.f == base.f
        assert [(s.name, s.evaluations) for s in r.stages] == [
            (s.name, s.evaluations) for s in base.stages]


@pytest.mark.parametrize("name", list(SCHEDULES))
@pytest.mark.slow  # measured 6.3 s on a loaded machine (default suite <= 5 min)
def test_every_static_schedule_runs_within_the_budget_and_is_deterministic(
        tiny: Problem, name: str) -> None:
    cfg = PlanConfig(seed=1, budget=2_500, population=20)
    a, b = run_pipeline(tiny, cfg, scheduler=name), run_pipeline(tiny, cfg, scheduler=name)
    assert a.x.tobytes() == b.x.tobytes()
    assert a.evaluations <= cfg.budget and a.phi == 0.0


def test_a_de_block_schedule_spends_evaluations_in_the_improve_stage(tiny: Problem) -> None:
    cfg = PlanConfig(seed=2, budget=3_000, population=20)
    r = run_pipeline(tiny, cfg, scheduler=StaticScheduler("de", ["de-block"]))
    (imp,) = [s for s in r.stages if s.name == "improve"]
    assert imp.evaluations >= cfg.population and r.evaluations <= cfg.budget


def test_unknown_schedulers_and_actions_are_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="^scheduler: must be one of default, ") as err:
        make_scheduler("nope")
    assert "(or lamde-s:DIR, lamde-s-ppo:DIR: a learned one from its checkpoint folder " \
        "DIR)" in str(err.value)  # the forms a checkpoint takes, named too
    with pytest.raises(ValueError, match="^scheduler: a static schedule"):
        StaticScheduler("x", ["stop"])
    with pytest.raises(ValueError, match="^scheduler: must be a name"):
        make_scheduler(3)
    assert scheduler_names()[0] == "default" and "stop" == ACTIONS[-1]


@pytest.mark.slow  # measured ~60 s over 9 runs (3 at 30,000 evaluations)
def test_the_default_scheduler_reproduces_the_pre_refactor_plans() -> None:
    for key, want in DIGESTS.items():
        task, seed, budget = key.split("/")
        p = Problem(load_map(SUITE / f"{task}.json").planning_map())
        # the DE's share then: 0.8 (0.6 since the split was re-measured, docs/search.md)
        r = run_pipeline(p, PlanConfig(seed=int(seed), budget=int(budget), de_share=0.8))
        assert (_digest(r), r.f, r.evaluations) == (want["digest"], want["f"],
                                                    want["evaluations"]), key


def test_plan_takes_a_scheduler_by_name_and_records_a_non_default_one() -> None:
    import lamde_mission

    kw = {"seed": 0, "budget": 2_000, "population": 20}
    a = lamde_mission.plan(MAPS / "tiny.json", scheduler="kicks-heavy", **kw)
    b = lamde_mission.plan(MAPS / "tiny.json", **kw)
    assert a.config["scheduler"] == "kicks-heavy" and "scheduler" not in b.config
    with pytest.raises(ValueError, match="^scheduler: must be one of"):
        lamde_mission.plan(MAPS / "tiny.json", scheduler="bogus", **kw)


@pytest.mark.slow  # measured 1.5 s on a loaded machine (default suite <= 5 min)
def test_the_cli_refuses_an_unknown_scheduler_in_one_line(tmp_path) -> None:
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "lamde_mission.cli", "plan", str(MAPS / "tiny.json"),
                        "-o", str(tmp_path / "x.plan"), "--scheduler", "bogus"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and not (tmp_path / "x.plan").exists()
    assert r.stderr.strip().count("\n") == 0 and "--scheduler: must be one of" in r.stderr


def test_a_fork_before_improve_gives_each_schedule_its_whole_run_plan(tiny: Problem) -> None:
    from planner_core.pipeline import DEFAULT_PIPELINE
    from planner_core.pipeline.pipeline import PipelineRun

    cfg = PlanConfig(seed=4, budget=2_500, population=20)
    run = PipelineRun(tiny, cfg, pipeline=DEFAULT_PIPELINE, evaluator=None, progress=None)
    run.advance(until="improve")
    for name in ("default", "kicks-heavy", "fresh-heavy"):
        twin = run.fork(name)
        twin.advance()
        want = run_pipeline(tiny, cfg, scheduler=name)
        assert twin.result().x.tobytes() == want.x.tobytes(), name
    assert run.i < len(run.stages) and run.ev.count < cfg.budget  # the original is untouched


def _bench():
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_schedule",
                                                  ROOT / "benchmarks" / "bench_schedule.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_schedule_grid_summary_by_hand() -> None:
    rec = [{"map": m, "seed": 0, "budget": 10, "template": t, "f": f, "phi": 0.0,
            "improve_evaluations": 5, "improve_seconds": 0.1}
           for m, fs in (("a", (100.0, 99.0)), ("b", (50.0, 50.0)), ("c", (10.0, 10.1)))
           for t, f in zip(("default", "kicks-heavy"), fs, strict=True)]
    table = _bench().summarise(rec).splitlines()
    # gaps: default (1.0101 + 0 + 0) / 3, kicks-heavy (0 + 0 + 1) / 3; wins 2 and 2
    row = {r.split("|")[1].strip(): r.split("|")[2:] for r in table if r.startswith("| ")}
    assert float(row["default"][0]) == pytest.approx(100 / 99 / 3, abs=1e-4)
    assert float(row["kicks-heavy"][0]) == pytest.approx(1 / 3, abs=1e-4)
    assert row["kicks-heavy"][3].strip() == "1 / 1" and row["default"][1].strip() == "2"


@pytest.mark.slow  # measured ~25 s: two suite maps at 2,000 evaluations, two templates
def test_bench_schedule_runs_summarises_and_selects(tmp_path) -> None:
    bench, out = _bench(), tmp_path / "grid.jsonl"
    assert bench.main(["--suite", "T01", "T02", "--seeds", "1", "--budget", "4000",
                       "--templates", "default", "kicks-heavy", "-o", str(out)]) == 0
    rows = [json.loads(x) for x in out.read_text().splitlines()]
    assert len(rows) == 4 and all(r["features"]["sensors"] > 0 for r in rows)
    assert bench.main(["--select", str(out)]) == 0
    assert bench.main(["--templates", "nope"]) == 2


def test_bench_schedule_large_names_the_large_suite() -> None:
    bench = _bench()
    large = bench.suite_maps([], bench.LARGE)
    assert [n for n, _ in large] == [f"L0{k}" for k in range(1, 9)]
    assert bench.suite_maps(["L04"], bench.LARGE) == [("L04", bench.LARGE / "L04.json")]
    assert [n for n, _ in bench.suite_maps([])] == [f"T{k:02d}" for k in range(1, 17)]
    # a record's map name finds its file in either suite
    assert bench._map_source("L04") == bench.LARGE / "L04.json"
    assert bench._map_source("T04") == bench.SUITE / "T04.json"
    assert bench.main(["--suite", "T01", "--large", "L01"]) == 2
    assert bench.main(["--large-seed", "3"]) == 2
    assert bench.main(["--large", "L04", "--large-seed", "-1"]) == 2


def test_bench_schedule_held_out_large_maps_are_the_suite_specs_from_another_seed() -> None:
    bench = _bench()
    (name, data), = bench.large_maps(["L04"], 7)
    assert name == "L04-s7" and len(data["sensors"]) == 80
    assert bench._map_source(name) == data  # a record's name regenerates its map


def test_docs_grid_table_is_what_the_stored_records_give() -> None:
    bench = _bench()
    runs = ROOT / "docs" / "scheduler-runs"
    table = bench.summarise(bench._read([str(runs / "grid10k.jsonl.gz")]))
    got = {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[2:7]]
           for r in table.splitlines() if r.startswith("| ") and "template" not in r}
    doc = (ROOT / "docs" / "scheduler.md").read_text()
    start = doc.index("### Measured: the grid at the default budget")
    end = doc.find("\n## ", start)
    section = doc[start:end if end > 0 else None]
    rows = [r for r in section.splitlines() if r.startswith("| ") and "template" not in r
            and "---" not in r]
    assert len(rows) >= 7
    for r in rows:
        cells = [c.strip() for c in r.split("|")[1:-1]]
        name = cells[0].split(",")[0].split(" (")[0]
        assert cells[1] == got[name][0] and cells[2] == got[name][1], name
        assert cells[4] == got[name][3] or name == "default", name


@pytest.mark.slow  # measured 1.4 s on a loaded machine (default suite <= 5 min)
def test_a_sortie_plan_refuses_a_non_default_scheduler_in_one_line(tmp_path) -> None:
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "lamde_mission.cli", "plan",
                        str(MAPS / "fleet-demo.json"), "-o", str(tmp_path / "out") + "/",
                        "--scheduler", "kicks-heavy"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and not (tmp_path / "out").exists()
    assert r.stderr.strip().count("\n") == 0 and "--scheduler: not available" in r.stderr


def test_the_large_rounds_need_i_max_above_20_without_counting_corner_slots() -> None:
    """Corner slots do not make a paper-size map large; fixed-length and tau <= 0 keep the
    paper-size rounds (a rebuild could not change their plans); scheduled access takes the
    large rounds too (its moves are scored by the scheduled hover-time LP)."""
    from planner_core.pipeline.schedule import large_rounds

    t12 = load_map(SUITE / "T12.json")
    assert not large_rounds(Problem(t12, corner_slots=4))
    large = load_map(ROOT / "examples" / "maps" / "large" / "L04.json")
    assert large_rounds(Problem(large)) and large_rounds(Problem(large, corner_slots=2))
    assert not large_rounds(Problem(large, variable_length=False))
    doc = json.loads((ROOT / "examples" / "maps" / "large" / "L04.json").read_text())
    doc.setdefault("radio", {})["access"] = "scheduled"
    assert large_rounds(Problem(load_map(doc)))


@pytest.mark.slow  # measured 2.7 s on a loaded machine (issue 35: default suite <= 5 min)
def test_a_fork_before_the_de_with_another_share_gives_that_shares_whole_run(
        tiny: Problem) -> None:
    """`PipelineRun.fork(config=)` before the DE: the stages before it do not read
    `de_share`, so each share's fork is that share's whole run, to the bit (what
    `bench_schedule.py --splits` relies on); a fork may not change the budget."""
    from planner_core.pipeline import DEFAULT_PIPELINE
    from planner_core.pipeline.pipeline import PipelineRun

    cfg = PlanConfig(seed=2, budget=2_500, population=20)
    run = PipelineRun(tiny, cfg, pipeline=DEFAULT_PIPELINE, evaluator=None, progress=None)
    run.advance(until="de")
    plans = set()
    for share in (0.6, 0.3, 0.1):
        twin = run.fork(None, config=cfg.replace(de_share=share))
        twin.advance()
        got = twin.result()
        want = run_pipeline(tiny, cfg.replace(de_share=share))
        assert got.x.tobytes() == want.x.tobytes() and got.f == want.f, share
        assert got.state.config.de_share == share
        plans.add(got.x.tobytes())
    assert len(plans) > 1  # the share changes the plan here, so the test can fail
    with pytest.raises(ValueError, match="budget"):
        run.fork(None, config=cfg.replace(budget=3_000))


class _Halving:
    """A scheduler that halves the DE's share (the `configure` hook) and plays the default."""

    name = "halving"

    def __init__(self, out: object = None) -> None:
        self.out = out
        self.inner = DefaultScheduler()

    def configure(self, problem: Problem, config: PlanConfig) -> PlanConfig:
        return self.out if self.out is not None else config.replace(
            de_share=config.de_share / 2)

    def reset(self, problem: Problem, config: PlanConfig) -> None:
        self.inner.reset(problem, config)

    def choose(self, observation: Observation) -> str:
        return self.inner.choose(observation)


@pytest.mark.slow  # measured 1.2 s on a loaded machine (default suite <= 5 min)
def test_a_schedulers_configure_sets_the_runs_config_and_the_plan_records_it(
        tiny: Problem) -> None:
    import lamde_mission

    cfg = PlanConfig(seed=1, budget=2_500, population=20, de_share=0.6)
    got = run_pipeline(tiny, cfg, scheduler=_Halving())
    want = run_pipeline(tiny, cfg.replace(de_share=0.3))
    assert got.x.tobytes() == want.x.tobytes() and got.state.config.de_share == 0.3
    de = [s for s in got.stages if s.name == "de"][0]
    assert de.allotted == [s for s in want.stages if s.name == "de"][0].allotted
    p = lamde_mission.plan(MAPS / "tiny.json", config=cfg, scheduler=_Halving())
    assert p.config["de_share"] == 0.3 and p.config["scheduler"] == "halving"
    # the default scheduler leaves the config as it is
    assert lamde_mission.plan(MAPS / "tiny.json", config=cfg).config["de_share"] == 0.6
    with pytest.raises(ValueError, match="configure\\(\\) must return a PlanConfig"):
        run_pipeline(tiny, cfg, scheduler=_Halving(out={"de_share": 0.1}))


@pytest.mark.slow  # measured ~15 s: two suite maps, two seeds, twice (serial and 2 workers)
def test_bench_schedule_on_workers_writes_the_serial_records(tmp_path) -> None:
    """`--jobs 2` runs the cases on the executor's workers: the same records as in one
    process (order aside), CPU seconds each worker's own."""
    import subprocess
    import sys

    rows = {}
    for jobs in ("0", "2"):
        out = tmp_path / f"j{jobs}.jsonl"
        r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_schedule.py"),
                            "--suite", "T01", "T02", "--seeds", "2", "--budget", "3000",
                            "--templates", "default", "kicks-heavy", "--splits", "0.6", "0.4",
                            "--jobs", jobs, "-o", str(out)],
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr
        recs = [json.loads(x) for x in out.read_text().splitlines()]
        assert all(x["cpu_seconds"] > 0 for x in recs)
        rows[jobs] = sorted((x["map"], x["seed"], x["arm"], x["f"], x["phi"]) for x in recs)
    assert len(rows["0"]) == 16 and rows["0"] == rows["2"]
    assert _bench().main(["--jobs", "-1"]) == 2


def test_the_default_gives_the_de_a_smaller_share_beyond_160_sensors() -> None:
    """`DefaultScheduler.configure`: a map of more than `LARGE_SENSORS` sensors with the large
    rounds runs with `LARGE_DE_SHARE` (recorded in the run's config before any stage), one of
    at most `MID_SENSORS` with `MID_DE_SHARE`; 160 sensors, a share the caller set, a run
    without the descent or fixed-length keep the config as it is (scheduled access does not:
    its rounds are the large ones too); a scheduler without its own `configure` gets the
    default's."""
    from planner_core.defaults import DE_SHARE
    from planner_core.pipeline.pipeline import DEFAULT_PIPELINE, PipelineRun
    from planner_core.pipeline.schedule import (
        LARGE_DE_SHARE,
        LARGE_SENSORS,
        MID_DE_SHARE,
        MID_SENSORS,
        configured,
    )

    large = ROOT / "examples" / "maps" / "large"
    l05, l02 = load_map(large / "L05.json"), load_map(large / "L02.json")
    assert len(l05.sensors) > LARGE_SENSORS == len(l02.sensors)
    cfg = PlanConfig(seed=0)
    assert cfg.de_share == DE_SHARE != LARGE_DE_SHARE
    p05 = Problem(l05)
    assert configured("default", p05, cfg).de_share == LARGE_DE_SHARE
    run = PipelineRun(p05, cfg, pipeline=DEFAULT_PIPELINE, evaluator=None, progress=None)
    assert run.config.de_share == LARGE_DE_SHARE == run.state.config.de_share
    assert configured("default", Problem(l02), cfg) is cfg
    l01 = load_map(large / "L01.json")  # 80 sensors: up to MID_SENSORS
    assert len(l01.sensors) <= MID_SENSORS < LARGE_SENSORS
    assert configured("default", Problem(l01), cfg).de_share == MID_DE_SHARE
    # the bounds: L02's sensors cut to 120 and 121, and one more sensor (161)
    src = json.loads((large / "L02.json").read_text())
    extra = {"id": "S999", "x": src["sensors"][0]["x"] + 50.0, "y": src["sensors"][0]["y"]}
    for sensors, share in ((src["sensors"][:MID_SENSORS], MID_DE_SHARE),
                           (src["sensors"][:MID_SENSORS + 1], DE_SHARE),
                           (src["sensors"] + [extra], LARGE_DE_SHARE)):
        doc = {**src, "sensors": sensors}
        doc.pop("witness")
        got = configured("default", Problem(load_map(doc)), cfg).de_share
        assert got == share, len(sensors)
    for kept in (cfg.replace(de_share=0.5), cfg.replace(descent=False)):
        assert configured("default", p05, kept) is kept
    assert configured("default", Problem(l05, variable_length=False), cfg) is cfg
    doc = json.loads((large / "L05.json").read_text())
    doc.setdefault("radio", {})["access"] = "scheduled"
    assert configured("default", Problem(load_map(doc)), cfg).de_share == LARGE_DE_SHARE
    # a scheduler without a configure of its own (a static schedule) follows the default's
    assert configured("kicks-rebuild", p05, cfg).de_share == LARGE_DE_SHARE


class _Watching(StaticScheduler):
    """A static schedule that keeps the last `Observation` it was shown."""

    last: Observation | None = None

    def choose(self, observation: Observation) -> str:
        self.last = observation
        return super().choose(observation)


@pytest.mark.parametrize("action", ["restructure", "kicks-300"])
def test_a_restructure_or_kicks_action_spends_at_most_its_quantum(action: str) -> None:
    # a quantum of 101 (descent 1 + restructure 100 + kicks 0) against the structural search
    # and the removal moves of up to 100 each: together they stop at the quantum (they spent
    # 107 on T05 when each pass was capped alone); the quantum binds, so `==`
    p = Problem(load_map(SUITE / "T05.json").planning_map())
    cfg = PlanConfig(seed=0, budget=8_000, population=20, restructure_trials=100,
                     descent_trials=1, kick_trials=0)
    s = _Watching("watch", [action])
    run_pipeline(p, cfg, scheduler=s)
    assert s.last is not None and s.last.quantum == 101
    steps = [r.evaluations for r in s.last.history if r.action == action]
    assert len(steps) >= 3 and max(steps) == s.last.quantum, steps
