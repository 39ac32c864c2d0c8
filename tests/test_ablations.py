"""Issue 16, the ablations (paper Sec. 5.3): the training options of each variant (LAMDE-F/R/E/L/O),
policy entries outside the registry in the benchmark, the report's ablation section and the
driver `benchmarks/ablations.py` end to end (slow)."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from lamde_mission.cli import main
from planner_core.bench import BenchError, run_bench
from planner_core.bench.ablation import META_KEY, normalised, normalised_table
from planner_core.bench.baselines import optimise, policy_spec
from planner_core.bench.records import RESULTS_FILE, read_records
from planner_core.bench.report import build_report
from planner_core.execution import SerialExecutor
from planner_core.learning.policy.problems import (
    bbob_training_specs,
    build,
    read_trainset,
    spec_name,
    with_encoding,
)
from planner_core.model.problem import Problem
from tests import test_bench
from tests.conftest import MAPS, ROOT

#: the two-map suite fixture (A1, B2) of the bench tests
suite = test_bench.suite
SUITE = ROOT / "examples" / "maps" / "suite"


# ---------------------------------------------------------------- training problem sets
def test_bbob_specs_cover_the_functions_and_build_plain_problems() -> None:
    pytest.importorskip("ioh")
    specs = bbob_training_specs(50, (20, 40))
    assert [s["function"] for s in specs[:24]] == list(range(1, 25))
    assert {s["dimension"] for s in specs[:24]} == {20}
    assert specs[24]["dimension"] == 40 and specs[48] == {
        "kind": "bbob", "function": 1, "dimension": 20, "instance": 2}
    assert spec_name(specs[3]) == "bbob-f4i1-d20"
    p = build(specs[0])
    f, phi = p.evaluate(np.full((3, 20), 0.5))
    assert f.shape == (3,) and np.all(phi == 0.0) and np.all(f >= 0.0)
    with pytest.raises(ValueError, match="problems: bbob spec: functions: 25"):
        build({"kind": "bbob", "function": 25, "dimension": 5, "instance": 1})
    with pytest.raises(ValueError, match="lacks 'instance'"):
        build({"kind": "bbob", "function": 2, "dimension": 5})
    for count in (0, 14_401):  # 14,400: the paper's whole BBOB database (MAX_PROBLEMS)
        with pytest.raises(ValueError, match=r"count must be an integer in \[1, 14,400\]"):
            bbob_training_specs(count)


def test_fixed_length_reaches_uav_problems_only() -> None:
    specs = [{"kind": "map", "path": str(MAPS / "tiny.json")},
             {"kind": "bbob", "function": 1, "dimension": 4, "instance": 1}]
    fixed = with_encoding(specs, variable_length=False)
    assert fixed[0]["variable_length"] is False and fixed[1] == specs[1]
    assert with_encoding(fixed, variable_length=True) == specs
    assert build(fixed[0]).variable_length is False and build(specs[0]).variable_length
    assert spec_name(fixed[0]).endswith("-fixedlen")
    with pytest.raises(ValueError, match="variable_length must be true or false"):
        build({**specs[0], "variable_length": "no"})


@pytest.mark.slow  # measured 91 s (issue 35: default suite <= 5 min)
def test_cli_train_bbob_and_fixed_length(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    pytest.importorskip("torch")
    pytest.importorskip("ioh")
    tiny = ["--epochs", "1", "--envs", "1", "--population", "6", "--budget", "30", "--quiet",
            "--set", "n_steps=2", "--set", "net.embed=8"]
    assert main(["train", "-o", str(tmp_path / "o"), "--bbob", "2", "--bbob-dims", "4",
                 *tiny]) == 0
    manifest = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert manifest["problems"] == bbob_training_specs(2, (4,))
    trainset = tmp_path / "set.json"
    trainset.write_text(json.dumps({"problems": [{"kind": "map",
                                                  "path": str(MAPS / "tiny.json")}]}))
    assert main(["train", "-o", str(tmp_path / "f"), "--problems", str(trainset),
                 "--fixed-length", *tiny]) == 0
    manifest = json.loads((tmp_path / "f" / "manifest.json").read_text())
    assert manifest["problems"][0]["variable_length"] is False
    capsys.readouterr()
    assert main(["train", "-o", str(tmp_path / "x"), "--problems", str(trainset), "--bbob",
                 "2"]) == 2
    assert "--bbob: give either --problems or --bbob" in capsys.readouterr().err
    assert main(["train", "-o", str(tmp_path / "x"), "--bbob", "2", "--bbob-dims", "a"]) == 2
    assert "--bbob-dims: expected integers" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


@pytest.mark.slow  # measured 5 s (issue 35: default suite <= 5 min)
def test_cli_lam_select_strategies_and_features(tmp_path: Path) -> None:
    """The retrieval ablations as `lam select` options: global/random/local x learned/ela."""
    pytest.importorskip("ioh")
    tasks = tmp_path / "tasks"
    tasks.mkdir()
    shutil.copy(SUITE / "T01.json", tasks / "T01.json")
    shutil.copy(SUITE / "T09.json", tasks / "T09.json")
    common = ["lam", "select", "--tasks", str(tasks), "--k", "4", "--functions", "1-6",
              "--dims", "40,80", "--instances", "1", "--cache", str(tmp_path / "cache"),
              "--quiet"]
    docs = {}
    for sel, feat in (("global", "learned"), ("random", "learned"), ("local", "learned"),
                      ("global", "ela")):
        out = tmp_path / f"{sel}-{feat}.json"
        assert main([*common, "--selection", sel, "--features", feat, "-o", str(out)]) == 0
        docs[sel, feat] = json.loads(out.read_text())
        assert docs[sel, feat]["options"]["selection"] == sel
        assert docs[sel, feat]["options"]["features"] == feat
        assert len(read_trainset(out)) == 4
    # local retrieval serves each task its own nearest instances: both tasks get pairs
    assert {p["task"] for p in docs["local", "learned"]["problems"]} == {"T01", "T09"}
    picks = {k: [(p["objective"]["function"], p["objective"]["dimension"]) for p in
                 d["problems"]] for k, d in docs.items()}
    assert picks["random", "learned"] != picks["global", "learned"]


# ---------------------------------------------------------------- policy entries in the bench
@pytest.fixture
def checkpoint(tmp_path: Path) -> Path:
    from planner_core.learning.policy import NetConfig, init_params, save

    net = NetConfig(embed=8, heads=1, ff=8, hidden=8)
    save(tmp_path / "ck", init_params(net, 1), net)
    return tmp_path / "ck"


@pytest.mark.slow  # 14 s measured in the default suite
def test_policy_spec_charges_the_probes_and_uses_its_checkpoint(checkpoint: Path) -> None:
    from planner_core.bench.baselines.de import optimise as de_optimise
    from planner_core.learning.policy import PolicyConfigurator

    problem = Problem(MAPS / "tiny.json")
    spec = policy_spec("LAMDE-X", str(checkpoint), probe_evaluations=30)
    res = optimise("LAMDE-X", problem, 200, 3, init="uniform", spec=spec)
    assert res.evaluations == 200
    assert res.history.evaluations[0] == 30 + 100  # the probes, then the first population
    from planner_core.search.init_modes import with_init

    direct = de_optimise(with_init(problem, "uniform"), 170, 3,
                         configurator=PolicyConfigurator(checkpoint=checkpoint))
    assert np.array_equal(direct.x, res.x) and direct.f == res.f
    fixed = policy_spec("LAMDE-XF", str(checkpoint), variable_length=False)
    assert "fixed-length" in fixed.description
    with pytest.raises(ValueError, match="does not exceed its 30 probe"):
        optimise("LAMDE-X", problem, 30, 3, spec=spec)
    with pytest.raises(ValueError, match="policy: only with configurator 'lamde'"):
        de_optimise(problem, 100, 0, configurator="adaptive", policy=str(checkpoint))
    with pytest.raises(ValueError, match="probe_evaluations"):
        policy_spec("x", "y", probe_evaluations=-1)


def test_run_bench_runs_extra_entries_and_refuses_a_changed_one(suite: Path, tmp_path: Path,
                                                                checkpoint: Path) -> None:
    out = tmp_path / "out"
    a = policy_spec("VAR-A", str(checkpoint), probe_evaluations=20)
    s = run_bench(suite, ["VAR-A", "de-adaptive"], runs=1, budget=200, out=out, command="t",
                  executor=SerialExecutor(), best_known=False, inits=("uniform",), extra=[a])
    assert s.done == 4 and not s.failed
    recs = read_records(out / RESULTS_FILE).records
    assert {r["optimiser"] for r in recs} == {"VAR-A", "de-adaptive"}
    meta = json.loads((out / "meta.json").read_text())
    assert meta["optimisers"]["VAR-A"]["probe_evaluations"] == 20
    assert meta["optimisers"]["VAR-A"]["kwargs"]["policy"] == str(checkpoint)
    changed = policy_spec("VAR-A", str(checkpoint), probe_evaluations=50)
    with pytest.raises(BenchError, match="optimiser VAR-A was run as"):
        run_bench(suite, ["VAR-A"], runs=2, budget=200, out=out, executor=SerialExecutor(),
                  best_known=False, inits=("uniform",), extra=[changed])
    with pytest.raises(BenchError, match="^extra optimiser de-adaptive shadows registry names$"):
        run_bench(suite, ["de-adaptive"], runs=1, budget=200, out=tmp_path / "o2",
                  executor=SerialExecutor(), best_known=False,
                  extra=[policy_spec("de-adaptive", str(checkpoint))])
    with pytest.raises(BenchError, match="unknown optimiser"):
        run_bench(suite, ["VAR-B"], runs=1, budget=200, out=tmp_path / "o3",
                  executor=SerialExecutor(), best_known=False)


# ---------------------------------------------------------------- the report's section
def _record(opt: str, task: str, run: int, first: float, final: float) -> dict:
    return {"optimiser": opt, "task": task, "run": run, "seed": run, "budget": 100,
            "init": "uniform", "score": final, "f": final, "phi": 0.0, "feasible": True,
            "evaluations": 100, "wall_s": 0.1, "cpu_s": 0.1, "n_hover": 1, "n_points": 1,
            "hover_points": [[1.0, 1.0]], "hover_times": [1.0], "x": [0.0],
            "last_feasible_rate": 1.0, "map_sha256": "0",
            "history": {"evaluations": [10, 100], "best_f": [first, final],
                        "best_phi": [0.0, 0.0]}}


def test_normalised_performance_by_hand() -> None:
    r = _record("A", "T1", 0, 400.0, 100.0)
    assert normalised(r) == 0.25
    r["history"]["best_phi"][0] = 30.0  # initial f + 10 phi = 400 + 300
    assert normalised(r) == pytest.approx(100.0 / 700.0)
    assert math.isnan(normalised({**r, "history": {}}))
    recs = [_record("LAMDE", "T1", k, 100.0, 10.0 + k) for k in range(8)]
    recs += [_record("LAMDE-R", "T1", k, 100.0, 50.0 + k) for k in range(8)]
    tab = normalised_table(recs, ["LAMDE", "LAMDE-R"], "LAMDE")
    assert tab["LAMDE"]["mark"] == "" and tab["LAMDE-R"]["mark"] == "+"
    assert tab["LAMDE"]["mean"] == pytest.approx(np.mean([0.10 + k / 100 for k in range(8)]))
    assert tab["LAMDE-R"]["n"] == 8


@pytest.mark.slow  # measured 12 s (issue 35: default suite <= 5 min)
def test_report_adds_the_ablation_section(tmp_path: Path) -> None:
    res = tmp_path / "res"
    res.mkdir()
    recs = [_record(o, t, k, 100.0, base + k)
            for o, base in (("LAMDE", 10.0), ("LAMDE-F", 40.0), ("LAMDE-O", 20.0),
                            ("de-adaptive", 30.0))
            for t in ("T1", "T2") for k in range(5)]
    (res / RESULTS_FILE).write_text("".join(json.dumps(r) + "\n" for r in recs))
    ck = tmp_path / "ck"
    ck.mkdir()
    (ck / "curve.csv").write_text("epoch,seconds\n1,12.5\n2,7.5\n")
    meta = {"suite": str(tmp_path / "nosuite"), "budget": 100,
            "optimisers": {"LAMDE-F": {"description": "fixed-length variant"}},
            META_KEY: {"reference": "LAMDE", "variants": {
                "LAMDE": {"description": "the method", "checkpoint": str(ck)},
                "LAMDE-F": {"description": "fixed length", "checkpoint": str(ck)},
                "LAMDE-O": {"description": "plain BBOB", "checkpoint": None}}}}
    (res / "meta.json").write_text(json.dumps(meta))
    md = tmp_path / "abl.md"
    assert main(["report", str(res), "-o", str(md), "--no-limits"]) == 0
    text = md.read_text()
    assert "against the reference **LAMDE**" in text
    assert "| Task | LAMDE-F | LAMDE-O | de-adaptive | LAMDE (ref) |" in text
    assert "| +/~/- | 2/0/0 | 2/0/0 | 2/0/0 | (reference) |" in text
    # a baseline run alongside is in the normalised table, not in the training table
    assert "| de-adaptive | 10 | 0.3200 ± 0.0141 | 0.3200 | + |" in text
    assert "| de-adaptive | the" not in text
    assert "| LAMDE-F | fixed-length variant |" in text
    assert "## Ablations (paper Sec. 5.3, Table 3 and Fig. 3)" in text
    assert "| LAMDE | the method | 2 epoch(s), 20 s |" in text
    assert "| LAMDE-F | 10 | 0.4200 ± 0.0141 | 0.4200 | + |" in text
    assert (tmp_path / "abl" / "ablation_normalised_uniform.png").read_bytes()[:4] == b"\x89PNG"
    assert "--reference" not in text.split("Report produced by:")[1].splitlines()[2]
    # an explicit reference still wins
    build_report(res, tmp_path / "b.md", reference="LAMDE-O", limits=False, title="REDUCED x")
    text = (tmp_path / "b.md").read_text()
    assert text.startswith("# REDUCED x\n") and "against the reference **LAMDE-O**" in text


# ---------------------------------------------------------------- the driver, end to end
@pytest.mark.slow
def test_ablation_driver_end_to_end_is_resumable_and_reproducible(tmp_path: Path) -> None:
    """REDUCED: 1 task, 2 runs, K = 2 problems, 1-epoch trainings on tiny settings."""
    pytest.importorskip("torch")
    pytest.importorskip("ioh")
    import importlib.util

    spec = importlib.util.spec_from_file_location("ablations", ROOT / "benchmarks" /
                                                  "ablations.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    common = ["--tasks", "T01", "--runs", "2", "--budget", "400", "--k", "2", "--epochs", "1",
              "--envs", "2", "--train-population", "10", "--train-budget", "60",
              "--db-functions", "1-8", "--db-dims", "40", "--db-instances", "1",
              "--n-probe", "20", "--cache", str(tmp_path / "cache"), "--jobs", "0", "--quiet",
              "--set", "n_steps=2", "--baselines", "random-search"]
    a, b = tmp_path / "a", tmp_path / "b"
    assert mod.main(["--out", str(a), *common, "--report", str(a / "report.md"),
                     "--no-limits"]) == 0
    recs = read_records(a / RESULTS_FILE).records
    assert len(recs) == 7 * 2 and {r["optimiser"] for r in recs} >= {"random-search"}
    meta = json.loads((a / "meta.json").read_text())
    entry = meta[META_KEY]
    assert list(entry["variants"]) == ["LAMDE", "LAMDE-F", "LAMDE-R", "LAMDE-E", "LAMDE-L",
                                       "LAMDE-O"]
    # LAMDE-F trains exactly as LAMDE (synthetic pairs have no hover points): one training
    assert entry["variants"]["LAMDE-F"]["checkpoint"] == entry["variants"]["LAMDE"]["checkpoint"]
    assert not (a / "train" / "LAMDE-F").exists()
    o = json.loads((a / "train" / "LAMDE-O" / "manifest.json").read_text())["problems"]
    assert {p["kind"] for p in o} == {"bbob"}
    assert meta["optimisers"]["LAMDE-O"]["probe_evaluations"] == 0
    assert meta["optimisers"]["LAMDE-E"]["probe_evaluations"] == 20
    assert meta["optimisers"]["LAMDE-F"]["variable_length"] is False
    text = (a / "report.md").read_text()
    assert "## Ablations" in text and "| LAMDE-R | 2 |" in text
    # resumable: a second call finds everything done and changes nothing
    before = (a / RESULTS_FILE).read_bytes()
    assert mod.main(["--out", str(a), *common]) == 0
    assert (a / RESULTS_FILE).read_bytes() == before
    steps = json.loads((a / "meta.json").read_text())[META_KEY]["steps"]
    assert sum(c.startswith("lamde-mission lam select") for c in steps) == 4
    distinct = {e["checkpoint"] for e in entry["variants"].values()}  # equal sets train once
    assert sum(c.startswith("lamde-mission train") for c in steps) == len(distinct) >= 4
    # reproducible: a fresh folder gives the same scores
    assert mod.main(["--out", str(b), *common]) == 0

    def scores(folder: Path) -> dict:
        return {(r["optimiser"], r["task"], r["run"]): r["score"]
                for r in read_records(folder / RESULTS_FILE).records}

    assert scores(a) == scores(b)
