"""LAMDE-S's contextual selector (planner_core.learning.schedule_select): the table's
neighbours and ties, leave-one-map-out by hand, the shipped table, the CLI, and the live
scheduler choosing what the offline table predicts from the same run's features."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from planner_core.learning.schedule_select import (
    DEFAULT_TABLE,
    FEATURES,
    SPLIT_FEATURES,
    SelectorScheduler,
    SelectorTable,
    SplitTable,
    cases_from_records,
    cross_validate,
    cross_validate_split,
    fit,
    fit_split,
    main,
    map_features,
    run_features,
    split_cases,
)
from planner_core.model.problem import Problem
from planner_core.pipeline import DEFAULT_PIPELINE, PlanConfig, run_pipeline
from planner_core.pipeline.pipeline import PipelineRun
from planner_core.pipeline.schedule import make_scheduler, scheduler_names
from tests.conftest import MAPS, ROOT


def _feats(sensors: float, gap: float = 0.0) -> dict[str, float]:
    return {"sensors": sensors, "obstacles": 5.0, "area_km2": 25.0, "imax": 10.0,
            "f_vs_constructive": gap, "points_over_imax": 0.5, "structures": 3.0,
            "next_structure_gap": 1.0, "improve_share": 0.07}


def _records(cases: list[tuple[str, int, dict[str, float], dict[str, float]]]) -> list[dict]:
    """Grid records: (map, seed, features, template -> f)."""
    return [{"map": m, "seed": s, "budget": 10_000, "template": t, "f": f, "phi": 0.0,
             "features": feats, "improve_seconds": 0.1}
            for m, s, feats, fs in cases for t, f in fs.items()]


# small maps want fine kicks, large maps the default; the default is best on the whole table
GRID = _records(
    [(f"small{i}", 0, _feats(8 + i), {"default": 101.0, "fine-kicks": 100.0})
     for i in range(3)]
    + [(f"large{i}", 0, _feats(80 + i), {"default": 100.0, "fine-kicks": 103.0})
       for i in range(3)])


def test_cases_are_the_complete_feasible_ones_with_gaps_in_per_cent() -> None:
    recs = GRID + _records([("bad", 0, _feats(9), {"default": 100.0, "fine-kicks": 99.0})])
    recs[-1]["phi"] = 2.0  # an infeasible template drops its case
    recs += [dict(GRID[0], template="kicks-only", f=1.0)]  # a template one case lacks: dropped
    keys, F, G, templates = cases_from_records(recs)
    assert templates == ["default", "fine-kicks"] and len(keys) == 6
    assert ("bad", 0) not in keys and F.shape == (6, len(FEATURES))
    assert G[0] == pytest.approx([1.0, 0.0]) and G[3] == pytest.approx([0.0, 3.0])


def test_the_nearest_cases_pick_the_template_and_ties_go_to_the_best_static() -> None:
    table = fit(GRID, k=1)
    assert table.templates[0] == "default"  # mean gaps: default 0.5 %, fine-kicks 1.5 %
    assert table.predict(_feats(9)) == "fine-kicks"
    assert table.predict(_feats(81)) == "default"
    tied = SelectorTable(table.features, np.zeros_like(table.gaps), table.templates,
                         table.maps, 1, {})
    assert tied.predict(_feats(9)) == "default"


def test_leave_one_map_out_by_hand() -> None:
    # each held-out small map's nearest other map is small: fine-kicks (gap 0 against the
    # static default's 1 %); each large one's is large: the default (gap 0 either way)
    cv = cross_validate(fit(GRID, k=1))
    assert cv == {"selector": 0.0, "static": pytest.approx(0.5), "cases": 6, "better": 3,
                  "worse": 0}
    table = fit(GRID)  # k chosen by leave-one-map-out: the least k of the best
    assert table.k == 1 and set(table.meta["cross_validation"]) == {"1", "3", "5", "10",
                                                                    "20", "40"}


def test_a_table_round_trips_and_a_missing_one_is_one_line(tmp_path) -> None:
    table = fit(GRID, k=1, meta={"command": "test"})
    back = SelectorTable.load(table.save(tmp_path / "t"))
    assert back.templates == table.templates and back.k == 1
    assert np.array_equal(back.features, table.features) and back.meta["command"] == "test"
    with pytest.raises(ValueError, match=r"^scheduler: no selector table in .*nowhere"):
        SelectorTable.load(tmp_path / "nowhere")


def test_a_manifest_without_a_usable_k_is_one_line(tmp_path, capsys) -> None:
    """A manifest.json without "k" (was a KeyError), with a non-integer one (was a TypeError
    or ValueError from int()) or with one outside 1..cases is refused in one line naming the
    folder, through `SelectorTable.load` and `--scheduler lamde-s:DIR` (exit 2)."""
    from lamde_mission.cli import main

    d = fit(GRID, k=1).save(tmp_path / "t")
    meta = json.loads((d / "manifest.json").read_text())
    for k, needle in ((None, "must be an integer, got nothing"), ("x", "got 'x'"),
                      (2.5, "got 2.5"), (True, "got True"), (0, "k must be 1..6, got 0"),
                      (7, "k must be 1..6, got 7")):
        (d / "manifest.json").write_text(json.dumps(
            {n: v for n, v in meta.items() if n != "k"} | ({} if k is None else {"k": k})))
        with pytest.raises(ValueError, match=r"^scheduler: the selector table in .*t: ") as e:
            SelectorTable.load(d)
        assert needle in str(e.value) and "\n" not in str(e.value)
    (d / "manifest.json").write_text(json.dumps({n: v for n, v in meta.items() if n != "k"}))
    out = tmp_path / "x.plan"
    rc = main(["plan", str(ROOT / "examples" / "maps" / "small-demo.json"), "--scheduler",
               f"lamde-s:{d}", "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "must be an integer, got nothing" in err[0], err
    assert not out.exists()


@pytest.mark.parametrize("kind", ["selector", "split"])
def test_a_table_killed_between_its_two_files_is_refused_naming_the_file(
        tmp_path, monkeypatch, kind) -> None:
    """Each file is written atomically, the arrays first; the manifest records their sha256,
    so new arrays beside the old manifest (a run killed between the two writes) are refused
    in one line naming the archive, and a manifest without a digest (older) still loads."""
    import dataclasses

    import planner_core.atomic

    cls, npz, manifest = ((SelectorTable, "table.npz", "manifest.json") if kind == "selector"
                          else (SplitTable, "split.npz", "split.json"))
    table = fit(GRID, k=1) if kind == "selector" else fit_split(SPLITS, k=3)
    d = table.save(tmp_path / "t")
    meta = json.loads((d / manifest).read_text())
    assert meta[npz.replace(".npz", "_sha256")] == hashlib.sha256(
        (d / npz).read_bytes()).hexdigest()
    changed = dataclasses.replace(table, gaps=table.gaps + 1.0)

    def killed(path, text, **kw):
        raise OSError("killed")

    monkeypatch.setattr(planner_core.atomic, "write_text_atomic", killed)
    with pytest.raises(OSError, match="killed"):
        changed.save(d)
    monkeypatch.undo()
    assert (d / manifest).read_text() == json.dumps(meta, indent=1, sort_keys=True) + "\n"
    assert not [p.name for p in d.iterdir() if "lamde-tmp" in p.name]
    with pytest.raises(ValueError) as err:
        cls.load(d)
    assert str(err.value) == (f"scheduler: {d}: {npz} is not the one {manifest} describes "
                              f"({npz.replace('.npz', '_sha256')} differs)")
    del meta[npz.replace(".npz", "_sha256")]
    (d / manifest).write_text(json.dumps(meta))
    assert np.array_equal(cls.load(d).gaps, changed.gaps)  # no digest: not checked


def test_the_shipped_table_loads_and_is_registered() -> None:
    table = SelectorTable.load(DEFAULT_TABLE)
    assert "default" in table.templates and len(table.gaps) >= 100
    assert table.meta["command"].startswith("python -m planner_core.learning.schedule_select")
    assert "lamde-s" in scheduler_names()
    assert isinstance(make_scheduler("lamde-s"), SelectorScheduler)


def test_the_cli_fits_and_refuses_a_bad_k(tmp_path, capsys) -> None:
    path = tmp_path / "grid.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in GRID))
    assert main(["fit", str(path), "-o", str(tmp_path / "out"), "--k", "1"]) == 0
    assert "k = 1: leave-one-map-out mean gap 0.0000 % (best static 0.5000 %)" in (
        capsys.readouterr().out)
    assert SelectorTable.load(tmp_path / "out").k == 1
    assert main(["fit", str(path), "-o", str(tmp_path / "x"), "--k", "0"]) == 2
    assert capsys.readouterr().err.strip() == "schedule_select: --k: must be >= 1, got 0"
    assert main(["fit", str(tmp_path / "missing.jsonl"), "-o", str(tmp_path / "y")]) == 2
    assert capsys.readouterr().err.startswith("schedule_select: records: ")


def test_the_cli_reads_records_by_the_shared_reader(tmp_path, capsys) -> None:
    """`fit` reads its records by `textio.read_jsonl`: a bad line is named with its file and
    line number (a bare JSONDecodeError before), and NaN, which JSON has not, is refused."""
    path = tmp_path / "grid.jsonl"
    path.write_text(json.dumps(GRID[0]) + "\n{not json\n")
    assert main(["fit", str(path), "-o", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err.startswith(f"schedule_select: records: {path}: line 2: ")
    path.write_text(json.dumps(GRID[0]).replace("}", ', "x": NaN}', 1) + "\n")
    assert main(["fit", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"schedule_select: records: {path}: line 1: ") and "NaN" in err


def test_the_live_scheduler_follows_the_template_the_table_predicts_from_the_run() -> None:
    """The features the scheduler reads at the stage's first decision are the ones
    bench_schedule.py records before `improve`, and the plan is that template's, to the bit."""
    problem = Problem(MAPS / "tiny.json")
    cfg = PlanConfig(seed=3, budget=3_000, population=20, de_share=0.2)
    base = PipelineRun(problem, cfg, pipeline=DEFAULT_PIPELINE, evaluator=None, progress=None)
    base.advance(until="improve")
    x, f, _ = base.ev.best()
    feats = run_features(problem, x, f, base.state.pool, base.ev.remaining, base.ev.budget)
    # a table whose only neighbour of this run says "fine-kicks", the default best overall
    far = dict(feats, sensors=feats["sensors"] * 50)
    table = fit(_records([("near", 0, feats, {"default": 101.0, "fine-kicks": 100.0}),
                          ("far", 0, far, {"default": 100.0, "fine-kicks": 110.0})]), k=1)
    assert table.templates[0] == "default" and table.predict(feats) == "fine-kicks"
    sched = SelectorScheduler(table)
    live = run_pipeline(problem, cfg, scheduler=sched)
    assert sched.template == "fine-kicks"
    fork = base.fork("fine-kicks")
    fork.advance()
    want = fork.result()
    assert live.x.tobytes() == want.x.tobytes() and live.f == want.f


def test_beyond_the_papers_sizes_the_selector_follows_the_default() -> None:
    """The shipped table has no template with rebuilds: on a map with I_max > 20 lamde-s
    follows the default (whose rounds there rebuild windows), without reading features."""
    from types import SimpleNamespace

    from planner_core.pipeline.schedule import LARGE_CYCLE, Observation

    big = Problem(ROOT / "examples" / "maps" / "large" / "L04.json")
    sched = SelectorScheduler()
    sched.reset(big, PlanConfig())
    obs = Observation(step=0, remaining=10, budget=10, quantum=5, idle=0, f=1.0, phi=0.0,
                      elapsed=0.0, history=(), state=SimpleNamespace(problem=big, pool=None,
                                                                     config=PlanConfig()))
    assert sched.choose(obs) == LARGE_CYCLE[0] and sched.template == "default"


def test_bench_schedule_evaluates_a_table_on_held_out_records(tmp_path, capsys) -> None:
    from tests.test_schedule import _bench

    table = fit(GRID, k=1).save(tmp_path / "table")
    held = tmp_path / "held.jsonl"
    held.write_text("".join(json.dumps(r) + "\n" for r in _records([
        ("hs", 0, _feats(9), {"default": 101.0, "fine-kicks": 100.0}),
        ("hl", 0, _feats(81), {"default": 100.0, "fine-kicks": 102.0})])))
    assert _bench().main(["--evaluate", str(table), str(held)]) == 0
    out = capsys.readouterr().out
    # hs: lamde-s picks fine-kicks (gap 0), the static default has 1 %; hl: both the default
    assert "mean gap to the per-case best (%): lamde-s 0.0000, best static (default) " \
           "0.5000, default 0.5000, oracle 0" in out
    assert "-100.0 % of its mean gap; better / worse on 1 / 0 cases" in out
    assert "maps where lamde-s's mean is lower: 1 of 1 that differ (2 maps)" in out
    assert "picks: default 1, fine-kicks 1" in out
    assert _bench().main(["--evaluate", str(table)]) == 2


@pytest.mark.slow  # measured ~5 s: two plans in a subprocess
def test_bench_policy_times_the_scheduler_in_whole_plans() -> None:
    import subprocess
    import sys

    from tests.conftest import ROOT

    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_policy.py"),
                        str(MAPS / "tiny.json"), "--scheduler", "lamde-s", "--plans", "1"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "tiny: lamde-s " in r.stdout and "scheduler / plan = " in r.stdout


def test_the_docs_lamde_s_figures_are_what_the_shipped_table_gives_on_the_stored_records() -> None:
    from tests.conftest import ROOT
    from tests.test_schedule import _bench

    bench, runs = _bench(), ROOT / "docs" / "scheduler-runs"
    doc = (ROOT / "docs" / "scheduler.md").read_text()
    section = doc[doc.index("## LAMDE-S: the contextual selector"):]
    section = section[:section.index("\n## ")]  # this section's table only
    row = {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[2:5]]
           for r in section.splitlines() if r.startswith("| ")}
    for col, name in enumerate(("heldout200x5", "suite10x10", "large-heldout3x3")):
        out = bench.evaluate(str(DEFAULT_TABLE), bench._read([str(runs / f"{name}.jsonl.gz")]))
        sel, static, default = (row[k][col].split()[0] for k in (
            "lamde-s", "best static of the training grid (`fresh-heavy`)", "default"))
        assert (f"lamde-s {sel}, best static (fresh-heavy) {static}, default {default}"
                in out), (name, out)
        share = row["lamde-s against that static: share of its mean gap"][col]
        assert f"lamde-s vs best static: {share}" in out


def test_plan_records_and_prints_the_template_lamde_s_chose(tmp_path) -> None:
    """`plan(scheduler="lamde-s")` records the template the selector followed
    (`config["scheduler_choice"]`), the CLI's summary prints it, and a static schedule has no
    choice to record."""
    import lamde_mission

    cfg = PlanConfig(seed=3, budget=3_000, population=20, de_share=0.2)
    p = lamde_mission.plan(MAPS / "tiny.json", config=cfg, scheduler="lamde-s")
    table = SelectorTable.load(DEFAULT_TABLE)
    assert p.config["scheduler"] == "lamde-s"
    assert p.config["scheduler_choice"] in table.templates
    q = lamde_mission.plan(MAPS / "tiny.json", config=cfg, scheduler="kicks-heavy")
    assert q.config["scheduler"] == "kicks-heavy" and "scheduler_choice" not in q.config


@pytest.mark.slow  # measured 3.7 s on a loaded machine (issue 35: default suite <= 5 min)
def test_the_cli_summary_names_the_chosen_schedule(tmp_path) -> None:
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "lamde_mission.cli", "plan", str(MAPS / "tiny.json"),
                        "-o", str(tmp_path / "t.plan"), "--scheduler", "lamde-s", "--budget",
                        "12000", "--seed", "3"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    line = next(s for s in r.stdout.splitlines() if s.startswith("map '"))
    assert "scheduler lamde-s -> " in line, line


# --- the split table (the DE's share, chosen from the map before the first stage) ---------


def _mfeats(sensors: float, ce: float = 1.0) -> dict[str, float]:
    return {"sensors": sensors, "obstacles": 5.0, "area_km2": 25.0, "imax": sensors / 2,
            "clark_evans": ce}


def _split_records(cases: list[tuple[str, int, dict[str, float],
                                     dict[float, tuple[float, float]]]]) -> list[dict]:
    """Split records: (map, seed, map features, share -> (f, cpu seconds))."""
    return [{"map": m, "seed": s, "budget": 10_000, "template": "default",
             "arm": f"default@{x:g}", "de_share": x, "f": f, "phi": 0.0, "cpu_seconds": c,
             "map_features": feats, "features": {}}
            for m, s, feats, fc in cases for x, (f, c) in fc.items()]


# small maps: the split changes nothing but time (2x); large maps: 0.4 is 1 % better at
# 1.3x, 0.3 is 1.5 % better at 1.8x (over the cap); no static share but 0.6 is within the cap
SPLITS = _split_records(
    [(f"small{i}", 0, _mfeats(10 + i), {0.6: (100.0, 1.0), 0.4: (100.0, 2.0),
                                        0.3: (100.0, 2.4)}) for i in range(3)]
    + [(f"large{i}", 0, _mfeats(200 + i), {0.6: (101.5, 4.0), 0.4: (100.5, 5.2),
                                           0.3: (100.0, 7.2)}) for i in range(3)])


def test_split_cases_are_complete_feasible_default_template_cases() -> None:
    recs = SPLITS + _split_records([("bad", 0, _mfeats(9), {0.6: (1.0, 1.0), 0.4: (1.0, 1.0),
                                                            0.3: (1.0, 1.0)})])
    recs[-1]["phi"] = 1.0  # an infeasible split drops its case
    recs += [dict(SPLITS[0], template="kicks-heavy", f=0.5)]  # not the default's: ignored
    keys, F, G, C, splits = split_cases(recs)
    assert splits == [0.6, 0.4, 0.3] and len(keys) == 6 and ("bad", 0) not in keys
    assert F.shape == (6, len(SPLIT_FEATURES)) and G.shape == C.shape == (6, 3)
    assert G[3] == pytest.approx([1.5, 0.5, 0.0]) and C[3] == pytest.approx([1.0, 1.3, 1.8])
    with pytest.raises(ValueError, match="default split"):
        split_cases([r for r in SPLITS if r["de_share"] != 0.6])


def test_the_split_of_least_gap_within_the_cpu_cap_is_chosen() -> None:
    table = fit_split(SPLITS, k=3)
    assert table.splits == (0.6, 0.4, 0.3) and table.cap == 1.5
    # large maps: 0.3 is best but 1.8x over the cap, so 0.4; small maps: a tie, the default
    assert table.predict(_mfeats(201)) == 0.4 and table.predict(_mfeats(11)) == 0.6
    assert dataclass_replace(table, cap=2.0).predict(_mfeats(201)) == 0.3
    # leave one map out: the large maps get 0.4 (gap 0.5 against the static 0.6's 1.5)
    cv = cross_validate_split(table, k=2)
    assert cv["cases"] == 6 and cv["better"] == 3 and cv["worse"] == 0
    assert cv["selector"] == pytest.approx(0.25) and cv["static"] == pytest.approx(0.75)
    assert cv["selector_cpu"] == pytest.approx((3 * 1.0 + 3 * 1.3) / 6)


def dataclass_replace(table: SplitTable, **kw: object) -> SplitTable:
    import dataclasses

    return dataclasses.replace(table, **kw)


def test_a_split_table_round_trips_and_a_damaged_one_is_one_line(tmp_path) -> None:
    table = fit_split(SPLITS, k=3, meta={"command": "x"})
    table.save(tmp_path)
    back = SplitTable.load(tmp_path)
    assert back.splits == table.splits and back.k == 3 and back.cap == 1.5
    assert np.array_equal(back.gaps, table.gaps) and back.maps == table.maps
    assert back.predict(_mfeats(201)) == 0.4
    assert SplitTable.load(tmp_path / "none") is None  # no split table: none
    meta = json.loads((tmp_path / "split.json").read_text())
    (tmp_path / "split.json").write_text(json.dumps(dict(meta, k=2.5)))
    with pytest.raises(ValueError, match='"k" must be an integer, got 2.5'):
        SplitTable.load(tmp_path)  # it was cut to 2 and loaded
    (tmp_path / "split.json").write_text("{")
    with pytest.raises(ValueError, match="split table in .* does not load"):
        SplitTable.load(tmp_path)


def test_the_tables_are_read_by_the_shared_bounded_reader(tmp_path, monkeypatch) -> None:
    """A table folder given on the command line (`--scheduler lamde-s:DIR`) is read through
    `planner_core.textio`: a FIFO in place of an archive is refused without blocking, and a
    file over the byte limit is refused before it is read whole."""
    import os

    fit(GRID, k=1).save(tmp_path)
    fit_split(SPLITS, k=3).save(tmp_path)
    os.replace(tmp_path / "table.npz", tmp_path / "old.npz")
    os.mkfifo(tmp_path / "table.npz")
    with pytest.raises(ValueError, match="no selector table in .*not a regular file"):
        SelectorTable.load(tmp_path)
    monkeypatch.setenv("LAMDE_MAX_INPUT_BYTES", "100")
    with pytest.raises(ValueError, match="split table in .* does not load .*LAMDE_MAX_INPUT_BYTES"):
        SplitTable.load(tmp_path)


def test_the_selector_configures_the_share_only_over_the_default(tmp_path) -> None:
    from planner_core.defaults import DE_SHARE

    problem = Problem(MAPS / "tiny.json")
    feats = map_features(problem)
    near = dict(feats)
    far = dict(feats, sensors=feats["sensors"] * 50)
    split = fit_split(_split_records([
        ("near", 0, near, {DE_SHARE: (101.0, 1.0), 0.3: (100.0, 1.2)}),
        ("far", 0, far, {DE_SHARE: (100.0, 1.0), 0.3: (103.0, 1.2)})]), k=1)
    sched = SelectorScheduler(SelectorTable.load(DEFAULT_TABLE), split)
    assert sched.configure(problem, PlanConfig()).de_share == 0.3
    mine = PlanConfig(de_share=0.5)  # a share of one's own is kept
    assert sched.configure(problem, mine) is mine
    assert SelectorScheduler(split=None).configure(problem, PlanConfig()) == PlanConfig()
    cfg = PlanConfig(seed=3, budget=3_000, population=20)
    got = run_pipeline(problem, cfg, scheduler=sched)
    assert got.state.config.de_share == 0.3
    # the folder form reads both tables
    fit(GRID, k=1).save(tmp_path)
    split.save(tmp_path)
    assert SelectorScheduler.from_checkpoint(str(tmp_path)).split.splits == split.splits


def test_the_selector_never_gives_the_de_more_than_the_default_does() -> None:
    """The shipped split table was fitted on shares 0.3-0.6; the default's later rules give
    the DE 0 beyond 160 sensors and 0.2 up to 120 on the large maps, and there lamde-s gave
    it 0.3-0.4 (its plans worse than the default's). Between them (L02, 160 sensors) the
    default keeps 0.6 and the table's pick stands."""
    from planner_core.pipeline.schedule import DefaultScheduler

    large = ROOT / "examples" / "maps" / "large"
    shipped = SelectorScheduler()
    for name, want in (("L01", 0.2), ("L02", 0.3), ("L03", 0.0), ("L08", 0.0)):
        problem = Problem(large / f"{name}.json")
        picked = shipped.split.predict(map_features(problem))
        default = DefaultScheduler().configure(problem, PlanConfig()).de_share
        got = shipped.configure(problem, PlanConfig()).de_share
        assert got == want == min(picked, default), name
        assert SelectorScheduler(split=None).configure(problem, PlanConfig()).de_share == default
    assert shipped.split.predict(map_features(Problem(large / "L03.json"))) > 0.0


def test_map_features_clark_evans_tells_a_lattice_from_clustered_fields() -> None:
    from types import SimpleNamespace

    def fake(xy: np.ndarray) -> SimpleNamespace:
        m = SimpleNamespace(width=1000.0, height=1000.0,
                            spec=SimpleNamespace(obstacles=SimpleNamespace(count=0)))
        return SimpleNamespace(sensors=xy, map=m, hover_limit=10)

    g = (np.arange(10) + 0.5) * 100.0
    lattice = np.array([(x, y) for x in g for y in g])  # spacing 100 m, 100 sensors
    assert map_features(fake(lattice))["clark_evans"] == pytest.approx(2.0)
    rng = np.random.default_rng(0)
    fields = np.vstack([c + rng.normal(0, 10, (25, 2)) for c in
                        ((200, 200), (800, 200), (200, 800), (800, 800))])
    assert map_features(fake(fields))["clark_evans"] < 0.3
    assert map_features(fake(lattice[:1]))["clark_evans"] == 1.0
    f = map_features(Problem(MAPS / "tiny.json"))
    assert list(f) == list(SPLIT_FEATURES) and f["sensors"] >= 1


def test_the_cli_fits_a_split_table_and_bench_schedule_evaluates_it(tmp_path, capsys) -> None:
    from tests.test_schedule import _bench

    train = tmp_path / "train.jsonl"
    train.write_text("".join(json.dumps(r) + "\n" for r in SPLITS))
    out = tmp_path / "table"
    assert main(["fit-split", str(train), "-o", str(out), "--k", "3"]) == 0
    printed = capsys.readouterr().out
    assert "shares 0.6, 0.4, 0.3" in printed and "k = 3" in printed
    assert json.loads((out / "split.json").read_text())["cap"] == 1.5
    assert main(["fit-split", str(train), "-o", str(out), "--cap", "0.5"]) == 2
    assert main(["fit-split", str(tmp_path / "none.jsonl"), "-o", str(out)]) == 2
    held = tmp_path / "held.jsonl"
    held.write_text("".join(json.dumps(r) + "\n" for r in _split_records([
        ("hs", 0, _mfeats(11), {0.6: (100.0, 1.0), 0.4: (100.0, 2.0), 0.3: (99.0, 2.4)}),
        ("hl", 0, _mfeats(201), {0.6: (102.0, 4.0), 0.4: (100.0, 5.0), 0.3: (101.0, 7.0)})])))
    capsys.readouterr()
    assert _bench().main(["--evaluate-split", str(out), str(held)]) == 0
    printed = capsys.readouterr().out
    # hs: the table keeps 0.6 (gap 1.0101 % to 0.3's 99); hl: it picks 0.4, the best
    assert "lamde-s 0.5051, best static (0.6) 1.5051, default (0.6) 1.5051" in printed
    assert "lamde-s vs default: f -0.980 % on average" in printed
    assert "lower / higher on 1 / 0 cases" in printed and "picks: 0.6 1, 0.4 1" in printed
    assert "lamde-s 1.12x (max 1.25x), best static 1.00x" in printed
    assert _bench().main(["--evaluate-split", str(out)]) == 2
    assert _bench().main(["--evaluate-split", str(tmp_path), str(held)]) == 2


@pytest.mark.slow  # measured ~15 s: one suite map, two shares, and lamde-s
def test_bench_schedule_splits_fork_before_the_de_and_record_each_share(tmp_path) -> None:
    import lamde_mission
    from tests.test_schedule import _bench

    out = tmp_path / "splits.jsonl"
    assert _bench().main(["--suite", "T01", "--seeds", "1", "--budget", "4000", "--templates",
                          "default", "lamde-s", "--splits", "0.6", "0.3", "-o", str(out)]) == 0
    rows = {r["arm"]: r for r in map(json.loads, out.read_text().splitlines())}
    assert set(rows) == {"default@0.6", "default@0.3", "lamde-s"}
    for arm in ("default@0.6", "default@0.3"):
        r = rows[arm]
        assert r["cpu_seconds"] > 0 and r["map_features"]["sensors"] > 0
        whole = lamde_mission.plan(ROOT / "examples" / "maps" / "suite" / "T01.json",
                                   config=PlanConfig(seed=0, budget=4000,
                                                     de_share=r["de_share"]))
        assert whole.breakdown["f"] == pytest.approx(r["f"], rel=1e-12)
    assert _bench().main(["--splits", "1.5"]) == 2


def test_the_docs_split_figures_are_what_the_shipped_table_gives_on_the_stored_records() -> None:
    """docs/scheduler.md's held-out split table: each column's figures are what
    `bench_schedule.py --evaluate-split` prints for the shipped table on the stored records."""
    from tests.test_schedule import _bench

    bench, runs = _bench(), ROOT / "docs" / "scheduler-runs"
    doc = (ROOT / "docs" / "scheduler.md").read_text()
    section = doc[doc.index("### The DE's share: LAMDE-S's split table"):]
    section = section[:section.index("\n## ")]
    row = {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[2:5]]
           for r in section.splitlines() if r.startswith("| ")}
    for col, name in enumerate(("split-heldout-large", "split-heldout100x2", "split-suite5")):
        out = bench.evaluate_split(str(DEFAULT_TABLE),
                                   bench._read([str(runs / f"{name}.jsonl.gz")]))
        vs_default = row["lamde-s's share against the default's (0.6): mean f"][col]
        mean, ci = vs_default.split(" % ", 1)
        assert f"lamde-s vs default: f {mean} % on average, 95 % CI {ci};" in out, (name, out)
        cases = row["lower / higher cases, Wilcoxon p"][col].split(",")[0]
        assert f"lower / higher on {cases} cases" in out.split("lamde-s vs default")[1]
        cpu = row["whole-plan CPU over the default's: lamde-s (max) / static 0.4"][col]
        lam, static = cpu.split(" / ")
        lam_mean, lam_max = lam.split(" ")
        assert (f"lamde-s {lam_mean} {lam_max.replace('(', '(max ')}, best static {static}"
                in out), (name, out)
        picks = row["picks"][col].replace(":", "").replace(", ", ", ")
        assert f"picks: {picks}" in out, (name, out)
    large = bench.evaluate_split(str(DEFAULT_TABLE),
                                 bench._read([str(runs / "split-heldout-large.jsonl.gz")]))
    assert "lamde-s vs best static: f -0.036 % on average, 95 % CI [-0.058, -0.016]" in large
    assert "the picked share's plan in 48 of 48 complete cases" in large


def test_split_records_and_tables_are_checked_in_one_line(tmp_path) -> None:
    from planner_core.learning.schedule_select import map_spec

    mixed = SPLITS + [dict(SPLITS[0], budget=5_000, map="other")]
    with pytest.raises(ValueError, match=r"budgets \[5000, 10000\] mixed"):
        split_cases(mixed)
    lacking = [dict(r) for r in SPLITS]
    del lacking[0]["cpu_seconds"]
    with pytest.raises(ValueError, match="lacks cpu_seconds"):
        split_cases(lacking)
    one_spec = [dict(r, map=f"L04-s{3000 + sorted({x['map'] for x in SPLITS}).index(r['map'])}")
                for r in SPLITS]  # six maps of one spec
    with pytest.raises(ValueError, match="at least 2 map specs"):
        fit_split(one_spec, k=1)
    assert map_spec("L04-s3001") == "L04" and map_spec("gen-5000-d0-s3400") == "gen-5000-d0"
    assert map_spec("T06") == "T06"
    table = fit_split(SPLITS, k=3)
    for change, match in (({"k": 0}, "k must be 1..6"), ({"cap": 0.5}, "cap must be"),
                          ({"splits": [0.4, 0.6, 0.3]}, "first share must be the default")):
        d = tmp_path / str(len(change) * 10 + len(str(change)))
        table.save(d)
        meta = json.loads((d / "split.json").read_text())
        meta.update(change)
        (d / "split.json").write_text(json.dumps(meta))
        if "splits" in change:
            meta.pop("split_sha256")  # an older manifest: no digest, so the arrays are read
            (d / "split.json").write_text(json.dumps(meta))
            with np.load(d / "split.npz") as z:
                arrays = dict(z)
            arrays["splits"] = np.array(change["splits"])
            np.savez(d / "split.npz", **arrays)
        with pytest.raises(ValueError, match=match):
            SplitTable.load(d)


def test_leave_one_spec_out_holds_a_specs_seeds_out_together() -> None:
    """Twin maps of one spec (other generator seeds) are held out together: a table whose
    only twin says 0.3 cannot pick 0.3 for its held-out sibling."""
    recs = _split_records(
        [("L09", 0, _mfeats(300), {0.6: (101.0, 1.0), 0.3: (100.0, 1.2)}),
         ("L09-s3001", 0, _mfeats(300), {0.6: (101.0, 1.0), 0.3: (100.0, 1.2)})]
        + [(f"small{i}", 0, _mfeats(10 + i), {0.6: (100.0, 1.0), 0.3: (100.5, 1.2)})
           for i in range(2)])
    cv = cross_validate_split(fit_split(recs, k=1), k=1)
    # by map, each L09 twin would learn 0.3 from the other (gap 0); by spec, its nearest
    # cases are the small maps, whose best share is 0.6 (gap 1 % on both twins); the small
    # maps get 0.6 from each other (gap 0): mean 2 / 4
    assert cv["cases"] == 4 and cv["selector"] == pytest.approx(0.5, rel=1e-3)


def test_a_fork_after_the_de_may_not_change_its_share() -> None:
    problem = Problem(MAPS / "tiny.json")
    cfg = PlanConfig(seed=1, budget=2_500, population=20)
    run = PipelineRun(problem, cfg, pipeline=DEFAULT_PIPELINE, evaluator=None, progress=None)
    run.advance(until="improve")
    with pytest.raises(ValueError, match="once the DE has run"):
        run.fork(None, config=cfg.replace(de_share=0.3))
    run.fork(None, config=cfg.replace(kick_trials=cfg.kick_trials))  # the same share: fine


@pytest.mark.slow  # measured 1.5 s on a loaded machine (default suite <= 5 min)
def test_bench_schedule_without_splits_runs_lamde_s_as_plan_does(tmp_path) -> None:
    """Without --splits the prefix has run the DE: lamde-s, whose share differs from the
    default's, runs its own whole plan, the one `plan --scheduler lamde-s` gives."""
    import lamde_mission
    from tests.test_schedule import _bench

    out = tmp_path / "grid.jsonl"
    assert _bench().main(["--suite", "T01", "--seeds", "1", "--budget", "3000", "--templates",
                          "default", "lamde-s", "-o", str(out)]) == 0
    rows = {r["arm"]: r for r in map(json.loads, out.read_text().splitlines())}
    want = lamde_mission.plan(ROOT / "examples" / "maps" / "suite" / "T01.json", budget=3000,
                              seed=0, scheduler="lamde-s")
    assert rows["lamde-s"]["de_share"] == want.config["de_share"] != rows["default"]["de_share"]
    assert rows["lamde-s"]["f"] == pytest.approx(want.breakdown["f"], rel=1e-12)
    # a split table asked for shares the records lack: one line
    held = tmp_path / "held.jsonl"
    held.write_text("".join(json.dumps(r) + "\n" for r in SPLITS if r["de_share"] != 0.4))
    table = fit_split(SPLITS, k=3).save(tmp_path / "t")
    assert _bench().main(["--evaluate-split", str(table), str(held)]) == 2
    # the template table's --evaluate on split records: one line, not a traceback
    split_recs = tmp_path / "split.jsonl"
    split_recs.write_text("".join(json.dumps(dict(r, features=_feats(9))) + "\n"
                                  for r in SPLITS))
    assert _bench().main(["--evaluate", str(DEFAULT_TABLE), str(split_recs)]) == 2


def test_the_shipped_tables_record_their_archives_digests() -> None:
    """Every shipped scheduler checkpoint's manifest records its archive's sha256 (the
    lamde-s manifests predated the digest, so a swapped table.npz or split.npz loaded
    unchecked), and the digest is the archive's."""
    from planner_core.learning.npz_manifest import check_digest, digest_key

    shipped = ROOT / "planner_core" / "learning" / "checkpoints"
    pairs = [("lamde-s", "table.npz", "manifest.json"), ("lamde-s", "split.npz", "split.json"),
             ("lamde-s-ppo", "weights.npz", "manifest.json")]
    for folder, npz, manifest in pairs:
        meta = json.loads((shipped / folder / manifest).read_text(encoding="utf-8"))
        assert digest_key(npz) in meta, (folder, manifest)
        raw = (shipped / folder / npz).read_bytes()
        assert check_digest(raw, meta, npz, manifest) is None, (folder, npz)
        assert check_digest(raw + b"x", meta, npz, manifest) is not None
