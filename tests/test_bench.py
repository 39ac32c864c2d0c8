"""The benchmark runner (resume, executors, best-known updates), statistics and the report."""

from __future__ import annotations

import copy
import json
import os
import pickle
import re
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planner_core.bench import BenchError, run_bench
from planner_core.bench.limits import (
    BestKnown,
    best_known_path,
    file_sha256,
    suite_task_files,
    verify_plan,
)
from planner_core.bench.records import RESULTS_FILE, ResultsWriter, key_of, read_records
from planner_core.bench.report import format_table
from planner_core.bench.runner import downsample, execute, plan_jobs, run_seed
from planner_core.bench.stats import score_table, wilcoxon_mark
from planner_core.execution import ProcessExecutor, SerialExecutor
from planner_core.model.problem import Problem

OPTS = ["de-adaptive", "random-search"]
BUDGET = 300

_BASE = {
    "area": {"width": 1200, "height": 1000},
    "start": [50, 50],
    "end": [1150, 950],
    "sensors": [
        {"id": "a", "x": 250, "y": 300},
        {"id": "b", "x": 800, "y": 250},
        {"id": "c", "x": 700, "y": 800},
    ],
    "obstacles": {"circles": [{"x": 600, "y": 560, "radius": 80}]},
    "uav": {"max_hover_points": 3},
}


def _map(name: str, shift: float) -> dict[str, Any]:
    m = copy.deepcopy(_BASE)
    m["name"] = name
    for s in m["sensors"]:
        s["y"] += shift
    # a deliberately poor witness: hover 120 s over each sensor (easy to beat)
    m["witness"] = {"hover_points": [[s["x"], s["y"]] for s in m["sensors"]],
                    "hover_times": [120.0, 120.0, 120.0]}
    p = Problem(m)
    w = m["witness"]
    assert p.evaluate(p.encode(w["hover_points"], w["hover_times"])[None, :])[1][0] == 0.0
    return m


@pytest.fixture
def suite(tmp_path: Path) -> Path:
    folder = tmp_path / "suite"
    folder.mkdir()
    for name, shift in (("A1", 0.0), ("B2", 60.0)):
        (folder / f"{name}.json").write_text(json.dumps(_map(name, shift)))
    return folder


def _run(suite: Path, out: Path, executor: Any = None, optimisers: list[str] = OPTS,
         runs: int = 2, budget: int = BUDGET, log: Any = None) -> Any:
    return run_bench(suite, optimisers, runs=runs, budget=budget, out=out, command="test",
                     executor=executor or SerialExecutor(), log=log)


def _scores(out: Path) -> dict[Any, float]:
    return {key_of(r): r["score"] for r in read_records(out / RESULTS_FILE).records}


# ----------------------------------------------------------------------------- runner


def test_runner_two_tasks_two_runs_two_optimisers(suite: Path, tmp_path: Path) -> None:
    out = tmp_path / "res"
    s = _run(suite, out)
    assert (s.planned, s.done, s.skipped, s.failed) == (8, 8, 0, [])
    recs = read_records(out / RESULTS_FILE).records
    assert len(recs) == 8 and len({key_of(r) for r in recs}) == 8
    for r in recs:
        assert r["evaluations"] == BUDGET and r["budget"] == BUDGET
        assert r["score"] == pytest.approx(r["f"] + 10 * r["phi"])
        assert r["feasible"] == (r["phi"] == 0.0) and r["wall_s"] >= 0
        assert r["seed"] == run_seed(0, r["task"], r["run"])
        h = r["history"]
        assert h["evaluations"][-1] == BUDGET and len(h["best_f"]) == len(h["evaluations"])
        f, phi = verify_plan(suite / f"{r['task']}.json", r["hover_points"], r["hover_times"])
        assert f == pytest.approx(r["f"], rel=1e-9) and phi == pytest.approx(r["phi"], abs=1e-9)
    meta = json.loads((out / "meta.json").read_text())
    assert meta["budget"] == BUDGET and meta["commands"][0]["command"] == "test"
    # nothing left to do: a rerun is a no-op
    s2 = _run(suite, out)
    assert (s2.planned, s2.done, s2.skipped) == (0, 0, 8)


def test_resume_after_truncated_write(suite: Path, tmp_path: Path) -> None:
    full = tmp_path / "full"
    _run(suite, full)
    lines = (full / RESULTS_FILE).read_bytes().splitlines(keepends=True)
    part = tmp_path / "part"
    part.mkdir()
    # three whole records, then a record cut off mid-line (the process was killed mid-write)
    (part / RESULTS_FILE).write_bytes(b"".join(lines[:3]) + lines[3][: len(lines[3]) // 2])
    read = read_records(part / RESULTS_FILE)
    assert len(read.records) == 3 and read.truncated_tail and not read.bad_lines
    said: list[str] = []
    s = _run(suite, part, log=said.append)
    assert (s.done, s.skipped) == (5, 3)
    # the wording `report` uses for the lines it skips (records.skipped_note)
    assert f"note: {part / RESULTS_FILE}: skipped a truncated last line (an interrupted " \
        "write)" in said
    again = read_records(part / RESULTS_FILE)
    assert not again.truncated_tail and not again.bad_lines and again.duplicates == 0
    assert len(again.records) == 8
    assert _scores(part) == _scores(full)  # same seeds, same results, whatever the order


class _Interrupting:
    """Yields `n` results, then fails like a Ctrl-C in the middle of the benchmark."""

    def __init__(self, n: int):
        self.n = n

    def map_unordered(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        for i, item in enumerate(items):
            if i == self.n:
                raise KeyboardInterrupt
            yield fn(item)

    def close(self) -> None:
        return None


def test_resume_after_interruption(suite: Path, tmp_path: Path) -> None:
    out = tmp_path / "res"
    with pytest.raises(KeyboardInterrupt):
        _run(suite, out, executor=_Interrupting(3))
    assert len(read_records(out / RESULTS_FILE).records) == 3
    s = _run(suite, out)
    assert (s.done, s.skipped) == (5, 3)
    recs = read_records(out / RESULTS_FILE)
    assert len(recs.records) == 8 and recs.duplicates == 0
    assert len((out / RESULTS_FILE).read_text().splitlines()) == 8


def test_refuses_to_mix_budgets_or_maps(suite: Path, tmp_path: Path) -> None:
    out = tmp_path / "res"
    _run(suite, out, runs=1, optimisers=["random-search"])
    with pytest.raises(BenchError, match="budget"):
        _run(suite, out, runs=1, budget=BUDGET + 1, optimisers=["random-search"])
    m = json.loads((suite / "A1.json").read_text())
    m["sensors"][0]["x"] += 1.0
    (suite / "A1.json").write_text(json.dumps(m))
    with pytest.raises(BenchError, match="different version"):
        _run(suite, out, runs=1, optimisers=["random-search"])
    with pytest.raises(BenchError, match="^unknown optimiser nope; choose from"):  # not "(s)"
        _run(suite, out, optimisers=["nope"])


def test_refuses_to_resume_under_another_base_seed(suite: Path, tmp_path: Path) -> None:
    """The folder's runs were of seed 0: resumed with seed 5 they would pass for seed 5's."""
    out = tmp_path / "res"
    run_bench(suite, ["random-search"], runs=1, budget=BUDGET, out=out, command="test",
              executor=SerialExecutor(), best_known=False)  # fmt: skip
    with pytest.raises(BenchError, match="holds runs of base seed 0, not 5"):
        run_bench(suite, ["random-search"], runs=1, budget=BUDGET, out=out, command="test",
                  executor=SerialExecutor(), best_known=False, base_seed=5)  # fmt: skip
    (out / "meta.json").unlink()  # the records' own seeds say it too
    with pytest.raises(BenchError, match="not 5"):
        run_bench(suite, ["random-search"], runs=1, budget=BUDGET, out=out, command="test",
                  executor=SerialExecutor(), best_known=False, base_seed=5)  # fmt: skip
    with pytest.raises(BenchError, match="base_seed must be an integer >= 0"):
        run_bench(suite, ["random-search"], runs=1, budget=BUDGET, out=tmp_path / "o",
                  executor=SerialExecutor(), best_known=False, base_seed=-1)  # fmt: skip


def test_run_bench_refuses_a_missing_suite_and_bad_executor_arguments_as_bench_errors(
        suite: Path, tmp_path: Path) -> None:
    """Every refusal of `run_bench` is a BenchError (the CLI's one line, exit 2), before
    anything is written: a missing suite folder (was FileNotFoundError), a bad `jobs`,
    `backend` or an address with the local backend (were ValueErrors from `make_executor`,
    raised after meta.json was written)."""
    out = tmp_path / "res"
    for kw, needle in (
        ({"jobs": -1}, "jobs must be >= 0"),
        ({"jobs": 257}, "jobs must be at most 256"),
        ({"jobs": 0, "runs": 1001}, r"runs must be an integer in \[1, 1,000\]"),
        ({"jobs": 0, "backend": "dask"}, "backend must be one of local, ray, got 'dask'"),
        ({"jobs": 0, "address": "auto"}, "an address is only for the ray backend"),
    ):
        with pytest.raises(BenchError, match=needle):
            run_bench(suite, ["random-search"], **{"runs": 1, **kw}, budget=BUDGET, out=out,
                      command="test", best_known=False)
    with pytest.raises(BenchError, match="none: no such folder of map files"):
        run_bench(tmp_path / "none", ["random-search"], runs=1, budget=BUDGET, out=out,
                  command="test", executor=SerialExecutor(), best_known=False)
    assert not out.exists()


def test_cli_bench_refuses_bad_options_before_any_run(suite: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    """One line, exit 2, nothing run or written: an empty --tasks / --optimizers list (it
    used to run the whole benchmark and rewrite the best-known file), a negative seed, an
    --out that is a file, a best-known file in a missing folder."""
    from lamde_mission.cli import main

    a_file = tmp_path / "notes.txt"
    a_file.write_text("mine")
    base = ["bench", "--suite", str(suite), "--runs", "1", "--budget", str(BUDGET)]
    for extra, needle in (
        (["--tasks", ","], "--tasks: no name given"),
        (["--tasks", ""], "--tasks: no name given"),
        (["--optimizers", ""], "--optimizers: no name given"),
        (["--i-max", ","], "--i-max: no name given"),
        (["--seed", "-1"], "--seed must be an integer >= 0"),
        (["--out", str(a_file)], f"--out: {a_file}: is a file, not a folder"),
        # under a file: a traceback at the first write (meta.json), exit 1
        (["--out", str(a_file / "sub")], f"--out: {a_file / 'sub'}: {a_file} is a file, not "
         "a folder"),
        (["--best-known-file", str(tmp_path / "no" / "bk.json")], "no folder"),
        (["--suite", str(tmp_path / "none")], "none: no such folder of map files"),
        (["--suite", str(a_file)], "notes.txt: no such folder of map files"),
        (["--jobs", "-1"], "--jobs must be >= 0"),
        (["--jobs", "257"], "--jobs: must be at most 256"),
        (["--runs", "1001"], "--runs must be an integer in [1, 1,000]"),
    ):
        out = ["--out", str(tmp_path / "res")] if "--out" not in extra else []
        assert main([*base, *out, *extra]) == 2, extra
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and needle in err[0], (extra, err)
    assert not (tmp_path / "res").exists() and not (tmp_path / "no").exists()
    assert not best_known_path(suite).exists() and a_file.read_text() == "mine"


def test_an_optimiser_whose_extra_is_missing_is_refused_before_any_run(
        suite: Path, tmp_path: Path, capsys: pytest.CaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Without the `baselines` extra, `bench --optimizers engineering` started and failed run
    by run ("ModuleNotFoundError: No module named 'ortools'", exit 1); now one line names the
    optimiser, the module and the pip extra, exit 2, nothing run or written (as `train` says
    it needs torch). The modules are hidden as an uninstalled one is (sys.modules[m] = None)."""
    import sys
    import tomllib

    from lamde_mission.cli import main
    from planner_core.bench.baselines import REGISTRY, missing_extras

    # every entry that needs more than the core names an extra of pyproject.toml providing it
    extras = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text(
        encoding="utf-8"))["project"]["optional-dependencies"]
    needing = {n: s for n, s in REGISTRY.items() if s.requires}
    assert set(needing) == {"engineering", "planner-eng-start", "pymoo-ga"}
    for name, spec in needing.items():
        for module in spec.requires:
            assert any(r.startswith(module) for r in extras[spec.extra]), (name, module)
    assert missing_extras(list(REGISTRY)) is None  # this venv has them
    assert main(["bench", "--list"]) == 0  # --list says which need an extra
    listed = [x for x in capsys.readouterr().out.splitlines() if "[needs " in x]
    assert [x.split()[0] for x in listed] == list(needing)
    assert listed[0].endswith(" [needs ortools: pip install 'lamde-mission[baselines]']")
    monkeypatch.setitem(sys.modules, "ortools", None)
    monkeypatch.setitem(sys.modules, "pymoo", None)
    assert missing_extras(["de-adaptive", "engineering-own-order"]) is None  # no OR-Tools
    # per optimiser the module it needs (the union read as if each needed both)
    assert missing_extras(["engineering", "pymoo-ga", "planner-eng-start", "engineering"]) == (
        "engineering needs ortools, pymoo-ga needs pymoo, planner-eng-start needs ortools, not "
        "installed: pip install 'lamde-mission[baselines]'")
    out = tmp_path / "res"
    assert main(["bench", "--suite", str(suite), "--optimizers", "random-search,engineering",
                 "--runs", "1", "--budget", str(BUDGET), "--jobs", "0", "--out",
                 str(out)]) == 2  # fmt: skip
    cap = capsys.readouterr()
    assert cap.err == ("lamde-mission bench: --optimizers: engineering needs ortools, not "
                       "installed: pip install 'lamde-mission[baselines]'\n") and cap.out == ""
    with pytest.raises(BenchError, match=r"^optimisers: pymoo-ga needs pymoo, not installed: "
                       r"pip install 'lamde-mission\[baselines\]'$"):
        run_bench(suite, ["pymoo-ga"], runs=1, budget=BUDGET, out=out, command="test",
                  executor=SerialExecutor(), best_known=False)
    assert not out.exists() and not best_known_path(suite).exists()


def test_plain_bench_without_an_extra_runs_the_others_with_a_note(
        suite: Path, tmp_path: Path, capsys: pytest.CaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    """`bench` with no --optimizers (all by default) in a venv without the baselines extra
    (the `make demo` one) was refused outright, exit 2, naming --optimizers the user never
    typed; it now runs every optimiser that can run here and says in one note which it left
    out and the pip extra. Modules hidden as in the test above; run_bench is replaced by one
    that records what it was asked to run."""
    import sys
    from types import SimpleNamespace

    import planner_core.bench.runner as runner
    from lamde_mission.cli import main
    from planner_core.bench.baselines import REGISTRY

    asked: list[list[str]] = []

    def fake_run_bench(suite_: Any, optimisers: list[str], **kw: Any) -> Any:
        asked.append(list(optimisers))
        return SimpleNamespace(done=0, skipped=0, failed=[], results=tmp_path,
                               best_known_updates=[])  # fmt: skip

    monkeypatch.setattr(runner, "run_bench", fake_run_bench)
    monkeypatch.setitem(sys.modules, "ortools", None)
    monkeypatch.setitem(sys.modules, "pymoo", None)
    args = ["bench", "--suite", str(suite), "--runs", "1", "--budget", str(BUDGET), "--jobs",
            "0", "--out", str(tmp_path / "res"), "--quiet"]  # fmt: skip
    assert main(args) == 0
    others = [n for n in REGISTRY if n not in ("engineering", "planner-eng-start", "pymoo-ga")]
    assert asked == [others]
    err = capsys.readouterr().err
    assert err == ("note: engineering needs ortools, planner-eng-start needs ortools, pymoo-ga "
                   "needs pymoo, not installed: pip install 'lamde-mission[baselines]'; running "
                   f"the other {len(others)} optimisers\n")
    assert main([*args, "--optimizers", "pymoo-ga"]) == 2  # named: refused, as before
    assert capsys.readouterr().err == ("lamde-mission bench: --optimizers: pymoo-ga needs "
                                       "pymoo, not installed: pip install "
                                       "'lamde-mission[baselines]'\n")
    assert asked == [others]


def test_records_reader_tolerates_damage(tmp_path: Path) -> None:
    path = tmp_path / RESULTS_FILE
    rec = {"optimiser": "o", "task": "t", "run": 0, "f": 1.0, "phi": 0.0, "score": 1.0,
           "evaluations": 5}
    with ResultsWriter(path) as w:
        w.write(rec)
        w.write({**rec, "run": 1})
        w.write(rec)  # duplicate key: the first one counts
    with path.open("a") as fh:
        fh.write("not json\n")
        fh.write(json.dumps({**rec, "run": 2}))  # complete, but no newline
    r = read_records(path)
    assert [x["run"] for x in r.records] == [0, 1, 2]
    assert r.duplicates == 1 and r.bad_lines == [4] and not r.truncated_tail
    with ResultsWriter(path) as w:  # terminates the last line instead of cutting it
        w.write({**rec, "run": 3})
    assert [x["run"] for x in read_records(path).records] == [0, 1, 2, 3]


def test_a_run_folder_stored_compressed_is_read_by_its_plain_name(suite: Path,
                                                                   tmp_path: Path) -> None:
    """A folder holding only results.jsonl.gz (as docs/ keeps them): `read_records` of the
    plain name reads it, so `store_runs` (and the report) find its runs; the runner refuses
    to add runs there (they would go to a plain results.jsonl that readers then prefer)."""
    import gzip

    from planner_core.bench.store import store_runs

    folder = tmp_path / "stored"
    rec = {"optimiser": "o", "task": "t", "run": 0, "f": 1.0, "phi": 0.0, "score": 1.0,
           "evaluations": 5}
    with ResultsWriter(folder / RESULTS_FILE) as w:
        w.write(rec)
        w.write({**rec, "run": 1})
    plain = folder / RESULTS_FILE
    (folder / (RESULTS_FILE + ".gz")).write_bytes(gzip.compress(plain.read_bytes()))
    plain.unlink()
    assert [x["run"] for x in read_records(plain).records] == [0, 1]
    assert store_runs(folder, tmp_path / "slim") == 2
    assert [x["run"] for x in read_records(tmp_path / "slim" / RESULTS_FILE).records] == [0, 1]
    with pytest.raises(BenchError, match=r"results\.jsonl\.gz, runs stored compressed"):
        _run(suite, folder)
    assert not plain.exists()


def test_downsample_keeps_a_step_function() -> None:
    ev = np.arange(1, 1001) * 10
    val = -np.arange(1000.0)
    e, (v,) = downsample(ev, [val], 10_000, points=10)
    assert e[0] == 10 and e[-1] == 10_000 and len(e) == 11
    assert np.all(v == -(e // 10 - 1))


@pytest.mark.slow  # measured 7 s (issue 35: default suite <= 5 min)
def test_jobs_carry_the_map_content_not_its_path(suite: Path, tmp_path: Path) -> None:
    files = suite_task_files(suite)
    jobs = plan_jobs(files, ["random-search"], runs=1, budget=50)
    for job in jobs:
        assert job.map == json.loads(files[job.task].read_text())
        assert job.map_sha256 == file_sha256(files[job.task])
        assert str(suite).encode() not in pickle.dumps(job)  # nothing for a remote worker to open
    moved = tmp_path / "elsewhere"
    suite.rename(moved)  # the files are gone from where they were planned: jobs still run
    with ProcessExecutor(1) as ex:
        recs = list(ex.map_unordered(execute, jobs))
    assert sorted(r["task"] for r in recs) == ["A1", "B2"]
    assert all("error" not in r and r["evaluations"] == 50 for r in recs), recs
    # a worker result equals the in-process one (same seed, same content)
    local = execute(jobs[0])
    (same,) = [r for r in recs if r["task"] == jobs[0].task]
    assert (same["score"], same["x"]) == (local["score"], local["x"])


def test_bad_map_json_fails_before_any_run(suite: Path, tmp_path: Path) -> None:
    (suite / "C3.json").write_text("{not json")
    with pytest.raises(BenchError, match="C3.json: not valid JSON"):
        _run(suite, tmp_path / "res")
    assert not (tmp_path / "res" / RESULTS_FILE).exists()


def test_process_executor_runs_workers_single_threaded() -> None:
    before = os.environ.get("OPENBLAS_NUM_THREADS")
    with ProcessExecutor(2) as ex:
        names = ["OPENBLAS_NUM_THREADS"] * 3 + ["NUMBA_NUM_THREADS"]
        got = list(ex.map_unordered(os.getenv, names))
    assert got == ["1"] * 4
    assert os.environ.get("OPENBLAS_NUM_THREADS") == before


# ----------------------------------------------------------------------------- best known


def test_best_known_seeded_from_witness_and_improved(suite: Path, tmp_path: Path) -> None:
    files = suite_task_files(suite)
    bk = BestKnown(best_known_path(suite))
    assert bk.path == suite.parent / "suite_best_known.json"
    start = bk.ensure(files)
    assert set(start) == {"A1", "B2"}
    assert all(e["optimiser"] == "witness" for e in bk.load().values())
    s = _run(suite, tmp_path / "res", optimisers=["de-adaptive"], budget=1000, runs=1)
    assert s.best_known_updates  # the witness is poor: the DE beats it
    entries = bk.load()
    for task in s.best_known_updates:
        e = entries[task]
        assert e["optimiser"] == "de-adaptive" and e["budget"] == 1000 and e["f"] < start[task]
        assert e["map_sha256"] == file_sha256(files[task])
        f, phi = verify_plan(files[task], e["hover_points"], e["hover_times"])
        assert phi == 0.0 and f == pytest.approx(e["f"])
    # a worse plan or an infeasible one never replaces the entry
    task = s.best_known_updates[0]
    w = json.loads(files[task].read_text())["witness"]
    assert not bk.offer(task, files[task], w["hover_points"], w["hover_times"],
                        optimiser="x", seed=0, budget=1)
    assert not bk.offer(task, files[task], w["hover_points"], [0.0, 0.0, 0.0],
                        optimiser="x", seed=0, budget=1)
    assert bk.load()[task] == entries[task]


# ----------------------------------------------------------------------------- statistics


def test_wilcoxon_marks_on_a_hand_made_table() -> None:
    ref = [float(v) for v in range(10, 20)]
    assert wilcoxon_mark(ref, [v + 100 for v in ref]) == "+"  # reference clearly better
    assert wilcoxon_mark(ref, [v - 100 for v in ref]) == "-"  # reference clearly worse
    assert wilcoxon_mark(ref, ref[::-1]) == "~"
    assert wilcoxon_mark(ref, [v + 0.5 for v in ref]) == "~"  # overlapping: not significant
    scores = {
        "T1": {"ref": ref, "worse": [v + 100 for v in ref], "better": [v - 100 for v in ref]},
        "T2": {"ref": ref, "worse": [v + 100 for v in ref], "better": ref[::-1]},
        "T3": {"ref": ref, "worse": [v + 0.5 for v in ref], "better": [v - 5 for v in ref]},
    }
    t = score_table(scores, ["T1", "T2", "T3"], ["ref", "worse", "better"], "ref")
    assert t.counts["worse"] == (2, 1, 0)
    assert t.counts["better"] == (0, 1, 2)
    assert [o for o in t.optimisers if t.cells["T1"][o].best] == ["better"]
    assert {o for o in t.optimisers if t.cells["T2"][o].best} == {"ref", "better"}
    c = t.cells["T1"]["worse"]
    assert (c.mean, c.n, c.mark) == (pytest.approx(114.5), 10, "+")
    assert c.std == pytest.approx(np.std(ref))
    lines = format_table(t)
    assert lines[0] == "| Task | ref (ref) | worse | better |"
    assert lines[2] == "| T1 | 14.5 ± 2.9 | 114.5 ± 2.9 + | **-85.5 ± 2.9** - |"
    assert lines[-1] == "| +/~/- | (reference) | 2/1/0 | 0/1/2 |"


# ----------------------------------------------------------------------------- CLI + report


@pytest.mark.slow  # measured 20 s (issue 35: default suite <= 5 min)
def test_cli_bench_then_report(suite: Path, tmp_path: Path) -> None:
    from lamde_mission.cli import main

    out = tmp_path / "res"
    args = ["bench", "--suite", str(suite), "--optimizers", "de-adaptive,random-search",
            "--runs", "2", "--budget", str(BUDGET), "--jobs", "2", "--out", str(out), "--quiet"]
    assert main(args) == 0
    assert len(read_records(out / RESULTS_FILE).records) == 8
    md = tmp_path / "docs" / "results.md"
    # -o in a missing folder needs --mkdir, as plan's, map's and lam select's
    assert main(["report", str(out), "-o", str(md), "--reference", "random-search"]) == 2
    assert not md.parent.exists()
    assert main(["report", str(out), "-o", str(md), "--reference", "random-search",
                 "--mkdir"]) == 0
    text = md.read_text()
    head = text.splitlines()[:8]
    assert any(line.strip().startswith("lamde-mission bench --suite") for line in head)
    assert "--budget 300" in text and "| +/~/- | (reference) |" in text
    assert "| Task | random-search (ref) | de-adaptive |" in text
    assert "Mean feasible f / LB" in text
    figs = tmp_path / "docs" / "results"
    assert (figs / "convergence_A1.png").stat().st_size > 0
    assert (figs / "best_paths.png").stat().st_size > 0
    assert "](results/best_paths.png)" in text
    # a slim copy (benchmarks/store_runs.py) as the main folder: its tables, and a sentence in
    # place of the best paths it keeps no plans for (it raised KeyError 'hover_points')
    from planner_core.bench.store import store_runs

    store_runs(out, tmp_path / "slim")
    md2 = tmp_path / "docs" / "slim.md"
    assert main(["report", str(tmp_path / "slim"), "-o", str(md2),
                 "--reference", "random-search"]) == 0
    assert "Not drawn: these records are slim copies" in md2.read_text()
    # bad input: exit status 2
    assert main(["report", str(tmp_path / "missing"), "-o", str(md)]) == 2
    # refused before a figure is written: -o a folder (it wrote the figures there, then
    # failed with a traceback), an unknown path task (silently left out), a checkpoint with
    # no curve.csv (refused after writing the figures)
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    for extra in (["-o", str(fresh)], ["-o", str(fresh / "r.md"), "--path-tasks", "T99"],
                  ["-o", str(fresh / "r.md"), "--policy-checkpoint", str(tmp_path / "nope")]):
        assert main(["report", str(out), "--reference", "random-search", *extra]) == 2, extra
        assert list(fresh.iterdir()) == [], extra
    assert main(["report", str(out), "-o", str(md), "--reference", "cmaes"]) == 2
    assert main(["bench", "--suite", str(suite), "--optimizers", "nope", "--out", str(out)]) == 2
    # a budget below the population every DE-based optimiser starts from, as `plan` refuses it
    assert main(["bench", "--suite", str(suite), "--budget", "50", "--out", str(out)]) == 2


@pytest.mark.slow  # measured 8 s beside a CI run (issue 35: default suite <= 5 min)
def test_report_names_the_reference_it_falls_back_to(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`report DIR` without --reference on records with no de-adaptive run took the first
    optimiser as the reference silently; now a note on stderr names it, and --help says what
    the default is and what happens when it has no runs."""
    import gzip

    from lamde_mission.cli import build_parser, main

    runs = Path(__file__).resolve().parent.parent / "docs" / "reduced" / "runs"
    recs = [json.loads(s) for s in gzip.decompress((runs / "results.jsonl.gz").read_bytes())
            .decode().splitlines()]
    folder = tmp_path / "runs"
    folder.mkdir()
    keep = ("scipy-de", "random-search", "cmaes")
    (folder / RESULTS_FILE).write_text("".join(json.dumps(r) + "\n" for r in recs
                                               if r["optimiser"] in keep and r["task"] == "T01"))
    (folder / "meta.json").write_text((runs / "meta.json").read_text())
    md = tmp_path / "r.md"
    assert main(["report", str(folder), "-o", str(md), "--no-limits"]) == 0
    err = capsys.readouterr().err
    assert err.splitlines() == [f"note: {folder / RESULTS_FILE} holds no de-adaptive runs: the "
                                "reference (--reference) is cmaes, the first optimiser present "
                                "in the registry's order (`bench --list`)"]
    assert "| Task | cmaes (ref) | scipy-de | random-search |" in md.read_text()
    # an explicit reference: no note; one without runs: refused
    assert main(["report", str(folder), "-o", str(md), "--no-limits",
                 "--reference", "scipy-de"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["report", str(folder), "-o", str(md), "--reference", "lsrtde"]) == 2
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    (ref,) = [a for a in sub.choices["report"]._actions if a.dest == "reference"]
    assert ref.help.startswith("the column the marks compare against (default de-adaptive; "
                               "where RESULTS holds no de-adaptive runs, the first optimiser it "
                               "holds in the order `bench --list` shows")
    assert "named in a note on stderr" in ref.help and "refused (exit 2)" in ref.help


def test_report_finds_the_suite_from_another_folder(
        suite: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`bench --suite examples/maps/large --out /tmp/B` from the repository root, then `report
    B` from /tmp, said "Safety margins: unknown (the suite folder is not here...)" and "(suite
    folder examples/maps/large not found)": meta.json kept only the relative path. bench now
    records the absolute one too, and report tries the path as given from here, then the
    absolute one, then the given one from the results folder; the report names the suite as
    given, wherever it is made (an old meta.json without the absolute path works as before)."""
    from planner_core.bench.report import build_report, suite_folder

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "B"
    run_bench(Path("suite"), ["random-search"], runs=1, budget=BUDGET, out=out, command="t",
              executor=SerialExecutor())
    meta = json.loads((out / "meta.json").read_text())
    assert meta["suite"] == "suite" and meta["suite_absolute"] == str(suite.resolve())
    assert suite_folder(meta, out) == Path("suite")  # from here, as given
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert suite_folder(meta, out) == suite.resolve()
    md = build_report(out, elsewhere / "r.md", reference="random-search")
    text = md.read_text()
    assert "from `suite`;" in text and "Safety margins: unknown" not in text, text
    assert "- Safety margins: none" in text or "- Safety margins (planned" in text
    assert "not found" not in text and "best-known: `suite_best_known.json`" in text
    # an old meta.json: the given path from here, else from the results folder, else as given
    old = {"suite": "suite"}
    assert suite_folder(old, out) == Path("suite")  # not here: said not found, as before
    assert suite_folder(old, tmp_path) == tmp_path / "suite"
    monkeypatch.chdir(tmp_path)
    assert suite_folder(old, elsewhere) == Path("suite")
    assert suite_folder({}, out) is None
    # the path as given wins over the absolute one recorded (a moved checkout: its own suite)
    assert suite_folder({**meta, "suite_absolute": str(elsewhere)}, out) == Path("suite")


# ----------------------------------------------------------------------------- the manual's records


def _benchmarks_page() -> str:
    from tests.conftest import ROOT

    return (ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8")


def _documented(text: str, start: str, end: str) -> set[str]:
    """The backticked names in the first column of the table between `start` and `end`."""
    part = text[text.index(start):text.index(end, text.index(start))]
    names: set[str] = set()
    for line in part.splitlines():
        if line.startswith("| `"):
            names.update(re.findall(r"`([^`]+)`", line.split("|")[1]))
    return names


def _record_fields() -> set[str]:
    return _documented(_benchmarks_page(), "## Records", "**Deterministic and timing fields.**")


def _meta_fields() -> set[str]:
    return _documented(_benchmarks_page(), "**meta.json**", "## Your own optimiser")


def _timing_fields() -> set[str]:
    (said,) = re.findall(r"\*\*Deterministic and timing fields\.\*\* (.*?) are timings",
                         _benchmarks_page(), re.S)
    return set(re.findall(r"`([^`]+)`", said))


def test_every_field_of_a_record_is_documented_and_all_but_the_timings_repeat(
        suite: Path) -> None:
    """docs/benchmarks.md's Records table names every field a run record has (one with an I_max
    override, the only optional field, and one without), and every field but the ones it calls
    timings is the same when the run is run again (they were listed only in the code)."""
    documented, timing = _record_fields(), _timing_fields()
    assert timing == {"wall_s", "cpu_s"}
    files = suite_task_files(suite)
    for i_max in (None, 2):
        (job,) = plan_jobs({"A1": files["A1"]}, ["de-adaptive"], runs=1, budget=BUDGET,
                           inits=("uniform",), i_max=(i_max,))
        a, b = execute(job), execute(job)
        assert "error" not in a, a
        want = documented if i_max is not None else documented - {"i_max"}
        assert set(a) == want, f"documented but not written: {sorted(want - set(a))}; " \
            f"written but not documented: {sorted(set(a) - want)}"  # fmt: skip
        assert {k: v for k, v in a.items() if k not in timing} == \
            {k: v for k, v in b.items() if k not in timing}  # fmt: skip
        assert set(a["history"]) == {"evaluations", "best_f", "best_phi"}


def _own_optimiser_example() -> str:
    text = _benchmarks_page()
    part = text[text.index("## Your own optimiser"):]
    (code,) = re.findall(r"```python\n(.*?)```", part, re.S)
    return code


def test_the_own_optimiser_example_runs_and_writes_what_the_records_section_says(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The manual's `run_bench(extra=)` example, run as a script in a scratch folder (its own
    `__main__`, where its entry's target points; tests/test_readme.py also pastes it into a new
    interpreter, slow): it prints what its comment says, its entry's runs are in the results
    beside the registry's, with the documented fields, and meta.json records the entry with
    documented fields only."""
    import sys
    import types

    from tests.conftest import ROOT

    code = _own_optimiser_example()
    (said,) = re.findall(r"print\(.*\)\s*#\s*(.*)", code)
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    script = types.ModuleType("__main__")
    monkeypatch.setitem(sys.modules, "__main__", script)
    exec(compile(code, "docs/benchmarks.md", "exec"), script.__dict__)
    assert capsys.readouterr().out.strip() == said.strip()
    recs = read_records(tmp_path / "my-bench" / RESULTS_FILE).records
    assert sorted((x["optimiser"], x["task"], x["run"]) for x in recs) == sorted(
        (o, t, k) for o in ("my-sampler", "random-search") for t in ("T01", "T02")
        for k in range(2))
    # an optimiser of its own, not random search under another name (the example first was)
    score = {(x["optimiser"], x["task"], x["run"]): x["score"] for x in recs}
    assert any(score["my-sampler", t, k] != score["random-search", t, k]
               for t in ("T01", "T02") for k in range(2))
    fields = _record_fields() - {"i_max"}
    for x in recs:
        assert set(x) == fields and x["evaluations"] == x["budget"] == 300
        assert x["seed"] == run_seed(0, x["task"], x["run"])
    meta = json.loads((tmp_path / "my-bench" / "meta.json").read_text())
    assert set(meta) <= _meta_fields(), sorted(set(meta) - _meta_fields())
    assert meta["optimisers"]["my-sampler"]["kwargs"] == {"batch": 50}
    assert set(meta["commands"][0]) == {"command", "started", "jobs_planned"}


def test_cli_bench_updates_the_best_known_file_beside_the_suite_unless_told_not_to(
        suite: Path, tmp_path: Path) -> None:
    """As docs/benchmarks.md says next to its `bench --runs 25` line: a plain `bench` writes
    SUITE_best_known.json beside the suite (the poor witnesses are beaten), and
    `--no-best-known-update` leaves it as it was."""
    from lamde_mission.cli import main

    bk = suite.parent / "suite_best_known.json"
    args = ["bench", "--suite", str(suite), "--optimizers", "de-adaptive", "--runs", "1",
            "--budget", "1000", "--jobs", "0", "--quiet", "--init", "seeded"]
    assert main([*args, "--out", str(tmp_path / "a"), "--no-best-known-update"]) == 0
    assert not bk.exists()
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    entries = json.loads(bk.read_text())["tasks"]
    assert {e["optimiser"] for e in entries.values()} == {"de-adaptive"}
    before = bk.read_bytes()
    assert main([*args, "--seed", "1", "--out", str(tmp_path / "c"),
                 "--no-best-known-update"]) == 0
    assert bk.read_bytes() == before


def test_a_run_compiles_its_kernels_before_its_timer_starts_once_per_process(
        suite: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`execute` warms up the compiled kernels its optimiser needs before the timed call
    (a reviewer's first runs on an empty numba cache took 19-27 s against 0.03-0.13 s, the
    compile inside wall_s): our DE with its own configurator, any other optimiser with the
    default one; once per process, not once per run. Counted by a stand-in for
    `warm_up`, not timed."""
    import planner_core.bench.baselines as baselines
    from planner_core.pipeline import warmup

    events: list[str] = []

    def fake_warm_up(configurator: Any = "adaptive") -> float:
        events.append(f"warm {configurator}")
        warmup._WARM.add(configurator)
        return 0.0

    real = baselines.optimise

    def counted(name: str, *args: Any, **kwargs: Any) -> Any:
        events.append(f"run {name}")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(warmup, "_WARM", set())
    monkeypatch.setattr(warmup, "warm_up", fake_warm_up)
    monkeypatch.setattr(baselines, "optimise", counted)
    files = suite_task_files(suite)
    jobs = plan_jobs({"A1": files["A1"]}, ["random-search", "de-fixed", "lsrtde",
                                           "de-fixed"], runs=1, budget=BUDGET)
    for job in jobs:
        assert "error" not in execute(job)
    assert events == ["warm adaptive", "run random-search", "warm fixed", "run de-fixed",
                      "run lsrtde", "run de-fixed"]


@pytest.mark.slow  # measured 4.5 s beside a CI run (issue 35: default suite <= 5 min)
def test_report_keeps_its_lower_bounds_in_the_run_folder_not_beside_the_suite(
        suite: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A report on a suite without a lower-bound cache wrote `<suite>_lower_bounds.json` beside
    the suite (`git status` showed examples/maps/large_lower_bounds.json after a report on the
    large suite, even with --no-best-known-update). It now reads the cache beside the suite,
    stores what it computes in the run's folder (read back by the next report: no second
    computation) and writes beside the suite only when asked (`update_lower_bounds`)."""
    from planner_core.bench.limits import lower_bounds_path
    from planner_core.bench.report import build_report
    from planner_core.model import bounds

    lb_cache = "lower_bounds.json"  # `report.LB_CACHE_FILE`

    out, rep = tmp_path / "runs", tmp_path / "rep"
    rep.mkdir()
    run_bench(suite, ["random-search"], runs=1, budget=BUDGET, out=out, command="t",
              executor=SerialExecutor(), best_known=None)
    beside = sorted(p.name for p in suite.parent.iterdir())
    computed: list[str] = []
    real = bounds.lower_bound

    def counted(m: Any, *args: Any, **kwargs: Any) -> Any:
        computed.append(Path(m).stem)
        return real(m, *args, **kwargs)

    monkeypatch.setattr(bounds, "lower_bound", counted)
    text = build_report(out, rep / "r.md", reference="random-search").read_text()
    assert sorted(p.name for p in suite.parent.iterdir()) == beside  # nothing beside the suite
    assert not lower_bounds_path(suite).exists() and (out / lb_cache).is_file()
    assert computed == ["A1", "B2"]
    again = build_report(out, rep / "r2.md", reference="random-search").read_text()
    def limits(page: str) -> str:
        return page.split("### Against the limits")[1].split("###")[0]

    assert computed == ["A1", "B2"] and limits(again) == limits(text)
    assert "| A1 | " in limits(text) and "| A1 | - |" not in limits(text)  # an LB shown
    # asked: the cache beside the suite, as the repository's own suite keeps it
    (out / lb_cache).unlink()
    build_report(out, rep / "r3.md", reference="random-search", update_lower_bounds=True)
    assert lower_bounds_path(suite).is_file() and not (out / lb_cache).exists()
    # the cache beside the suite is read: nothing computed, nothing written in the run folder
    build_report(out, rep / "r4.md", reference="random-search")
    assert computed == ["A1", "B2"] * 2 and not (out / lb_cache).exists()


def test_the_raw_de_sentence_only_with_a_de_variant(suite: Path, tmp_path: Path) -> None:
    """"Our DE variants report the raw DE result (no hover-time polish)" was printed whatever
    the columns, also for a report of `planner` and `engineering` alone, which both polish:
    now only when one of our raw DE entries is in the report."""
    from planner_core.bench.report import build_report

    out = tmp_path / "runs"
    run_bench(suite, ["random-search"], runs=1, budget=BUDGET, out=out, command="t",
              executor=SerialExecutor(), best_known=None)
    sentence = "Our DE variants report the raw DE result"
    text = build_report(out, tmp_path / "r.md", reference="random-search", limits=False)
    assert sentence not in text.read_text()
    run_bench(suite, ["de-fixed"], runs=1, budget=BUDGET, out=out, command="t",
              executor=SerialExecutor(), best_known=None)
    text = build_report(out, tmp_path / "r.md", reference="random-search", limits=False)
    assert sentence in text.read_text()


def test_the_lower_bound_prints_no_highs_banner(tmp_path: Path) -> None:
    """`report` printed "Running HiGHS 1.16.0 ... Copyright" when it computed lower bounds:
    `bounds.lower_bound` solves its LP through cvxpy's HiGHS, whose first solver in a process
    prints highspy's banner to fd 1. A fresh process (the banner comes once per process)."""
    import subprocess
    import sys

    from tests.conftest import ROOT

    code = ("from planner_core.model.bounds import lower_bound, DEFAULT_SPACING; "
            "print(lower_bound('examples/maps/tiny.json', DEFAULT_SPACING).lb)")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr
    assert "HiGHS" not in r.stdout + r.stderr, r.stdout
    float(r.stdout.strip())  # the bound alone
