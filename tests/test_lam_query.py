"""The two-stage query, the feature cache, training problems, the trainset file and `lam` CLI."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from planner_core.learning.lam import (
    BBOBProblem,
    Database,
    DatabaseSpec,
    InstanceKey,
    PairProblem,
    load_trainset,
    make_extractors,
    match,
    select,
    threshold_for,
)
from planner_core.learning.lam.probe import blas_single_thread
from planner_core.learning.lam.trainset import dumps_trainset, read_trainset, write_trainset


@pytest.fixture(autouse=True)
def _one_blas_thread():
    with blas_single_thread():
        yield


ROOT = Path(__file__).resolve().parents[1]
SUITE = ROOT / "examples" / "maps" / "suite"


@pytest.fixture(scope="module")
def bbob_db(tmp_path_factory):
    """All 24 functions at d = 20, instances 1..3, both extractors (built once per module)."""
    db = Database(
        spec=DatabaseSpec.make(range(1, 25), (20,), 3),
        cache_dir=tmp_path_factory.mktemp("lamdb"),
        extractors=make_extractors(["ela", "learned"]),
    )
    db.build()
    return db


# ---------------------------------------------------------------- cache
def test_build_is_cached_and_resumable(tmp_path):
    spec = DatabaseSpec.make((1, 2, 3), (10,), 2)
    db = Database(spec=spec, cache_dir=tmp_path, extractors=make_extractors(["ela"]))
    first = db.chunks()[0]
    # an interrupted build: one chunk on disk
    calls = []
    db.build(progress=lambda done, total: calls.append((done, total)))
    assert calls[-1] == (3, 3)
    db.chunk_path(first, "ela").unlink()
    assert db.build() == 1  # only the missing chunk is computed again
    assert db.build() == 0
    keys, Z = db.load("ela")
    assert keys == spec.keys() and Z.shape == (6, 16)
    again = Database(spec=spec, cache_dir=tmp_path, extractors=make_extractors(["ela"]))
    np.testing.assert_array_equal(again.load("ela")[1], Z)
    # any change of content (here the probe size) is a different hash, so new files
    other = Database(spec=spec, n_probe=50, cache_dir=tmp_path, extractors=make_extractors(["ela"]))
    assert other.missing() == other.chunks()
    with pytest.raises(FileNotFoundError, match="lam build"):
        other.load("ela")


# ---------------------------------------------------------------- query
@pytest.mark.parametrize("features", ["ela", "learned"])
@pytest.mark.slow  # measured 10 s over 2 cases (issue 35: default suite <= 5 min)
def test_query_finds_the_function_of_bbob_tasks(bbob_db, features):
    """Tasks that are BBOB instances (held-out ids): the picks share their function far more
    often than chance (3 of 72 database instances belong to any one function)."""
    keys, Z = bbob_db.load(features)
    ext = bbob_db.extractors[features]
    from planner_core.learning.lam.query import standardiser, task_features

    mu, sd = standardiser(Z) if ext.standardise else (0.0, 1.0)
    hits = total = 0
    for f in range(1, 25):
        tasks = [BBOBProblem((f, 20, i)) for i in (51, 52)]
        tf = task_features(tasks, ["a", "b"], ext, seed=f)
        picks = match(keys, (Z - mu) / sd, (tf.z_f - mu) / sd, (tf.z_phi - mu) / sd, 3)
        hits += sum(keys[p.objective].function == f for p in picks)
        total += len(picks)
    chance = 1 / 24
    assert hits / total > 3 * chance


def test_selection_variants(bbob_db):
    keys, Z = bbob_db.load("ela")
    rng = np.random.default_rng(0)
    z_f, z_phi = rng.normal(size=(3, 16)), rng.normal(size=(3, 16))
    for selection in ("global", "random", "local"):
        picks = match(keys, Z, z_f, z_phi, 7, selection, seed=1)
        objs = [p.objective for p in picks]
        assert len(picks) == 7 and len(set(objs)) == 7
        for p in picks:
            assert keys[p.constraint].dimension == keys[p.objective].dimension
            assert p.constraint != p.objective
    # global: the K smallest mean distances, in order
    score = np.linalg.norm(z_f[:, None] - Z[None], axis=-1).mean(axis=0)
    glob = match(keys, Z, z_f, z_phi, 7, "global")
    assert [p.objective for p in glob] == list(np.argsort(score, kind="stable")[:7])
    # local: each task's nearest instance is among the picks
    local = {p.objective for p in match(keys, Z, z_f, z_phi, 7, "local")}
    D = np.linalg.norm(z_f[:, None] - Z[None], axis=-1)
    assert {int(np.argmin(D[m])) for m in range(3)} <= local
    # random depends on the seed
    r1 = [p.objective for p in match(keys, Z, z_f, z_phi, 7, "random", seed=1)]
    r2 = [p.objective for p in match(keys, Z, z_f, z_phi, 7, "random", seed=2)]
    assert r1 != r2
    with pytest.raises(ValueError, match="selection"):
        match(keys, Z, z_f, z_phi, 7, "nearest")
    with pytest.raises(ValueError, match="k"):
        match(keys, Z, z_f, z_phi, 0)


# ---------------------------------------------------------------- training problems
def test_pair_problem_feasible_region_neither_empty_nor_everything():
    con = InstanceKey(21, 20, 2)
    for rho in (0.0, 0.3, 1.0):  # clipped to [0.05, 0.95]
        t, scale = threshold_for(con, rho)
        p = PairProblem((8, 20, 1), con, t, scale)
        U = np.random.default_rng(0).random((2000, 20))
        f, phi = p.evaluate(U)
        assert f.shape == phi.shape == (2000,) and np.all(phi >= 0) and np.all(f >= 0)
        share = np.mean(phi == 0)
        assert 0.0 < share < 1.0
    with pytest.raises(ValueError, match="dimension"):
        PairProblem((8, 20, 1), (21, 40, 1), 0.0, 1.0)


def test_training_problems_run_through_de_and_env(tmp_path, bbob_db):
    from planner_core.learning.env import OptimizationEnv
    from planner_core.search.de import Config, run

    tasks = [BBOBProblem((3, 20, 60)), BBOBProblem((12, 20, 61))]
    doc, _ = select(bbob_db, tasks, ["x", "y"], k=4, features="ela")
    path = write_trainset(tmp_path / "ts.json", doc)
    problems = load_trainset(path)
    assert len(problems) == 4
    res = run(problems[0], configurator="adaptive", seed=3, population=20, budget=400)
    assert res.evaluations == 400 and np.isfinite(res.f)
    env = OptimizationEnv(population=20, budget=200)
    obs, _ = env.reset(seed=0, options={"problem": problems[1]})
    assert obs["X"].shape == (20, 20)
    n = 20
    done = False
    while not done:
        act = Config(np.zeros(n, int), np.zeros(n, int), np.full(n, 0.5), np.full(n, 0.9))
        obs, r, done, trunc, info = env.step(act)
        assert np.isfinite(r) and not trunc


def test_select_is_reproducible_and_file_round_trips(tmp_path, bbob_db):
    tasks = [BBOBProblem((7, 20, 70))]
    a, _ = select(bbob_db, tasks, ["t"], k=5, seed=4, features="ela")
    b, _ = select(bbob_db, tasks, ["t"], k=5, seed=4, features="ela")
    assert dumps_trainset(a) == dumps_trainset(b)
    assert a["options"]["rho"] == 0.95  # BBOB tasks have phi = 0: all feasible, clipped
    p = a["problems"][0]
    assert set(p) >= {"objective", "constraint", "threshold", "scale", "distance_f", "task"}
    path = write_trainset(tmp_path / "t.json", a)
    assert read_trainset(path) == json.loads(dumps_trainset(a))


@pytest.mark.parametrize(
    ("patch", "message"),
    [
        ({"format": "x"}, "format"),
        ({"problems": []}, "problems"),
        ({"problems": [{"objective": {"function": 30}}]}, r"problems\[0\]\.objective"),
    ],
)
def test_read_trainset_names_the_bad_field(tmp_path, patch, message):
    doc = {"format": "lamde-trainset/1", "options": {}, "problems": [
        {"objective": {"function": 1, "dimension": 2, "instance": 1},
         "constraint": {"function": 2, "dimension": 2, "instance": 1},
         "threshold": 1.0, "scale": 1.0}]}  # fmt: skip
    doc.update(patch)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=message):
        load_trainset(path)


# ---------------------------------------------------------------- CLI
def test_cli_select_on_maps_writes_the_same_file_twice(tmp_path):
    from lamde_mission.cli import main

    tasks = tmp_path / "tasks"
    tasks.mkdir()
    for name in ("T01.json", "T09.json"):
        shutil.copy(SUITE / name, tasks / name)
    common = ["--functions", "1-6", "--dims", "40,80", "--instances", "2",
              "--cache", str(tmp_path / "cache"), "--features", "ela", "--quiet"]  # fmt: skip
    out1, out2 = tmp_path / "a.json", tmp_path / "b.json"
    args = ["lam", "select", "--tasks", str(tasks), "--k", "5", "--seed", "0", *common]
    assert main([*args, "-o", str(out1), "--plot", str(tmp_path / "p.png")]) == 0
    assert main([*args, "-o", str(out2)]) == 0
    assert out1.read_bytes() == out2.read_bytes()
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
    doc = json.loads(out1.read_text())
    assert doc["options"]["tasks"] == ["T01", "T09"]
    assert {p["task"] for p in doc["problems"]} <= {"T01", "T09"}
    assert len(load_trainset(out1)) == 5


def test_cli_bad_input_exits_2(tmp_path, capsys):
    from lamde_mission.cli import main

    assert main(["lam", "select", "--tasks", str(tmp_path / "none"), "-o", "x.json"]) == 2
    assert "--tasks" in capsys.readouterr().err
    assert main(["lam", "build", "--dims", "a,b", "--cache", str(tmp_path)]) == 2
    assert "--dims" in capsys.readouterr().err
    assert main(["lam", "build", "--functions", "30", "--cache", str(tmp_path)]) == 2
    assert not any(tmp_path.iterdir())


@pytest.mark.slow  # measured 12 s (issue 35: default suite <= 5 min)
def test_bench_lam_runs_and_prints_the_estimates():
    import subprocess
    import sys

    r = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_lam.py"), "--dims", "20,40,80",
         "--functions", "1"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "estimate default database (360 instances)" in r.stdout
    assert "full (paper): dimensions [120, 160, 200] not timed" in r.stdout
    assert "task T16 (d=80)" in r.stdout


def test_pair_problem_pickles_as_content(tmp_path):
    """Jobs carry content, not handles: a pickled training problem evaluates the same."""
    import pickle

    p = PairProblem((2, 10, 1), (15, 10, 2), 100.0, 10.0)
    U = np.random.default_rng(0).random((8, 10))
    q = pickle.loads(pickle.dumps(p))
    for a, b in zip(p.evaluate(U), q.evaluate(U), strict=True):
        np.testing.assert_array_equal(a, b)


def test_cli_build_reports_progress_and_resumes(tmp_path, capsys):
    from lamde_mission.cli import main

    args = ["lam", "build", "--functions", "1,2", "--dims", "10", "--instances", "2",
            "--features", "ela", "--cache", str(tmp_path)]  # fmt: skip
    assert main(args) == 0
    cap = capsys.readouterr()
    assert "2/2 chunks" in cap.err and "(2 computed now)" in cap.out
    assert main(args) == 0
    assert "(0 computed now)" in capsys.readouterr().out


@pytest.mark.slow  # measured 11 s (issue 35: default suite <= 5 min)
def test_build_in_worker_processes_matches_this_process(tmp_path):
    from planner_core.execution import ProcessExecutor

    spec = DatabaseSpec.make((1, 6, 21), (10,), 2)
    serial = Database(spec=spec, cache_dir=tmp_path / "a")
    parallel = Database(spec=spec, cache_dir=tmp_path / "b")
    serial.build()
    with ProcessExecutor(2) as ex:
        assert parallel.build(executor=ex) == 3
    for name in ("ela", "learned"):
        np.testing.assert_array_equal(serial.load(name)[1], parallel.load(name)[1])


def test_selection_figure_says_what_it_shows():
    """`lam select --plot`: title with K, the tasks and the options; axes named; the legend
    names every marker and lies outside the data."""
    from matplotlib.text import Text

    from lamde_mission.commands.lam import selection_figure

    rng = np.random.default_rng(0)
    doc = {"options": {"k": 5, "tasks": ["T01", "T09"], "selection": "two-stage",
                       "features": "ela", "n_probe": 100, "seed": 0}}
    arrays = {"Z": rng.random((40, 6)), "z_f": rng.random((2, 6)), "z_phi": rng.random((2, 6)),
              "objective": np.arange(5), "constraint": np.arange(5, 10)}
    fig = selection_figure(doc, arrays)
    texts = " | ".join(t.get_text().replace("\n", " ") for t in fig.findobj(Text))
    # "task(s)": counts say their noun in the singular for 1 only (planner_core.textio.counted)
    for needle in ("K = 5 training problems for 2 tasks (T01, T09)", "selection two-stage",
                   "ela features", "principal component 1", "database D_syn (40 instances)",
                   "selected objective s_k", "selected constraint s'_k", "task objective z_f",
                   "task constraint z_phi"):
        assert needle in texts, needle
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    assert not fig.legends[0].get_window_extent(r).overlaps(fig.axes[0].get_window_extent(r))
