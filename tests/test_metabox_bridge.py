"""Issue 16, the optional MetaBox-v2 bridge (benchmarks/metabox/): the runner's client side and
the merge into a benchmark folder, with OUR interpreter (the agents themselves need the MetaBox
venv and are not run here; benchmarks/metabox/README.md)."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from planner_core.bench.records import RESULTS_FILE, key_of, read_records
from planner_core.bench.runner import run_seed
from planner_core.model.formulas import penalised_score
from planner_core.model.problem import Problem
from tests.test_bench import _map

DIR = Path(__file__).parents[1] / "benchmarks" / "metabox"


def _load(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"metabox_{name}", DIR / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_runner_imports_without_metaevobox_and_checks_its_arguments(tmp_path: Path) -> None:
    rm = _load("run_metabox")
    assert "metaevobox" not in sys.modules
    with pytest.raises(SystemExit):
        rm.parse_args(["--project-python", sys.executable, "--agents", "lde,nope",
                       "--out", str(tmp_path)])
    with pytest.raises(SystemExit):
        rm.parse_args(["--project-python", sys.executable, "--maps", str(tmp_path / "*.json"),
                       "--out", str(tmp_path)])
    a = rm.parse_args(["--project-python", sys.executable, "--agents", "gleet",
                       "--maps", str(Path(__file__).parents[1] / "examples/maps/suite/T0*.json"),
                       "--out", str(tmp_path)])
    assert a.agents == ["gleet"] and [m.stem for m in a.map_files][:2] == ["T01", "T02"]


@pytest.mark.slow  # measured 4 s (issue 35: default suite <= 5 min)
def test_runner_problem_scores_through_the_server_with_our_seed(tmp_path: Path) -> None:
    """ServerProblem (MetaBox's problem duck type) evaluates rows and single points through a
    real evaluator_server.py; the server derives the run's seed as our bench does and records
    the best penalised score."""
    rm = _load("run_metabox")
    m = tmp_path / "A1.json"
    m.write_text(json.dumps(_map("A1", 0.0)))
    p = Problem(_map("A1", 0.0))
    client = rm.EvaluatorClient(sys.executable, [
        "--map", str(m), "--optimiser", "lde", "--run", "3", "--base-seed", "7",
        "--budget", "6", "--out", str(tmp_path / "res")])
    try:
        info = client.info()
        assert info["seed"] == run_seed(7, "A1", 3)
        prob = rm.ServerProblem(client, info, "A1")
        assert prob.dim == p.dim and prob.optimum is None
        np.testing.assert_allclose(prob.lb, p.lower)
        X = np.random.default_rng(1).uniform(p.lower, p.upper, (5, p.dim))
        y = prob.eval(X)
        y1 = prob.eval(X[0])
        f, phi = p.evaluate(X)
        np.testing.assert_allclose(y, penalised_score(f, phi))
        assert np.ndim(y1) == 0 and y1 == pytest.approx(y[0])
        with pytest.raises(rm.EvaluatorError, match="Budget"):
            prob.eval(X[:2])  # 7 and 8 of a budget of 6
        rec = client.finish()
    finally:
        client.close()
    assert rec["seed"] == run_seed(7, "A1", 3) and rec["init"] == "uniform"
    assert rec["evaluations"] == 6 and rec["score"] == pytest.approx(float(np.min(y)))
    assert read_records(tmp_path / "res" / RESULTS_FILE).records == [rec]
    assert rm.done_keys(tmp_path / "res") == {("lde", "A1", 3)}


def test_merge_adds_metabox_records_and_descriptions(tmp_path: Path) -> None:
    mm = _load("merge_results")
    ours, theirs = tmp_path / "bench", tmp_path / "mb.jsonl"
    ours.mkdir()
    base = {"task": "A1", "budget": 100, "f": 1.0, "phi": 0.0, "score": 1.0, "evaluations": 100,
            "init": "uniform"}
    (ours / RESULTS_FILE).write_text(
        "".join(json.dumps({**base, "optimiser": "de-lamde", "run": r}) + "\n" for r in (0, 1)))
    (ours / "meta.json").write_text(json.dumps({"budget": 100, "commands": [{"command": "x"}]}))
    theirs.write_text("".join(json.dumps({**base, "optimiser": "gleet", "run": r}) + "\n"
                              for r in (0, 1)) + json.dumps({**base, "optimiser": "de-lamde",
                                                             "run": 0}) + "\n")
    out = tmp_path / "merged"
    assert mm.main(["--results", str(ours), "--metabox", str(theirs), "--out", str(out)]) == 0
    recs = read_records(out / RESULTS_FILE).records
    assert sorted(key_of(r)[:3] for r in recs) == [("de-lamde", "A1", 0), ("de-lamde", "A1", 1),
                                                   ("gleet", "A1", 0), ("gleet", "A1", 1)]
    meta = json.loads((out / "meta.json").read_text())
    assert meta["optimisers"]["gleet"]["description"] == mm.DESCRIPTIONS["gleet"]
    assert meta["commands"][0] == {"command": "x"} and "merge_results" in meta["commands"][1][
        "command"]
    assert json.loads((ours / "meta.json").read_text()) == {"budget": 100,
                                                           "commands": [{"command": "x"}]}
    # OUT exists now: refused, exit 2; another budget: refused
    assert mm.main(["--results", str(ours), "--metabox", str(theirs), "--out", str(out)]) == 2
    theirs.write_text(json.dumps({**base, "optimiser": "lde", "run": 0, "budget": 50}) + "\n")
    assert mm.main(["--results", str(ours), "--metabox", str(theirs),
                    "--out", str(tmp_path / "m2")]) == 2
    assert not (tmp_path / "m2").exists()


def test_merge_script_runs_as_a_command(tmp_path: Path) -> None:
    out = subprocess.run([sys.executable, str(DIR / "merge_results.py"), "--results",
                          str(tmp_path / "none"), "--metabox", str(tmp_path / "none.jsonl"),
                          "--out", str(tmp_path / "o")], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "--results" in out.stderr
