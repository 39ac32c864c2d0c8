"""The Ray backend of the executor: same seeds, same results as the local backends; thread limits
in every worker through Ray's runtime environment; results stream back; the JSONL output stays
resumable. One local Ray instance (2 CPUs) for the whole module: Ray takes seconds to start."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from planner_core.bench import run_bench
from planner_core.bench.records import RESULTS_FILE, key_of, read_records
from planner_core.execution import SINGLE_THREAD_ENV, SerialExecutor, make_executor
from planner_core.execution.ray_executor import RayExecutor
from tests.conftest import SUITE

# the planner's imports above never import Ray; the backend is tested only where it is installed
ray = pytest.importorskip(
    "ray", reason="the ray extra is not installed (pip install -e '.[ray]'; `make setup` does)")

TASKS = ["T01", "T02"]
OPTS = ["de-adaptive", "random-search"]
BUDGET = 200


@pytest.fixture(scope="module")
def ray_runtime() -> Iterator[None]:
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        yield
    finally:
        ray.shutdown()


def _records(out: Path) -> dict[Any, dict[str, Any]]:
    """Records by (optimiser, task, run), without the fields that may differ (wall, CPU time)."""
    return {key_of(r): {k: v for k, v in r.items() if k not in ("wall_s", "cpu_s")}
            for r in read_records(out / RESULTS_FILE).records}


@pytest.mark.slow  # measured 23 s (issue 35: default suite <= 5 min)
def test_ray_workers_run_single_threaded(ray_runtime: None) -> None:
    names = list(SINGLE_THREAD_ENV) * 2
    ex = RayExecutor()
    got = list(ex.map_unordered(os.getenv, names))
    ex.close()  # the runtime is the fixture's: close leaves it running
    assert ray.is_initialized()
    assert got == ["1"] * len(names)


@pytest.mark.slow  # measured 0 s (issue 35: default suite <= 5 min)
def test_ray_streams_with_a_bounded_number_in_flight(ray_runtime: None) -> None:
    pulled = 0

    def items() -> Iterator[str]:
        nonlocal pulled
        for i in range(12):
            pulled += 1
            yield f"/a/b{i}"

    ex = RayExecutor(max_in_flight=3)
    results = ex.map_unordered(os.path.basename, items())
    first = next(results)
    assert pulled <= 3  # the first result came back before the rest were submitted
    rest = list(results)
    assert sorted([first, *rest]) == sorted(f"b{i}" for i in range(12))


@pytest.mark.slow  # measured 7 s (issue 35: default suite <= 5 min)
def test_same_seeds_same_results_on_ray_and_local(ray_runtime: None, tmp_path: Path) -> None:
    from lamde_mission.cli import main

    local = tmp_path / "local"
    run_bench(SUITE, OPTS, runs=2, budget=BUDGET, out=local, tasks=TASKS, best_known=False,
              executor=SerialExecutor())
    expected = _records(local)
    assert len(expected) == 8

    # the same benchmark on Ray through the CLI, stopped after run 0 and resumed for run 1
    out = tmp_path / "ray"
    base = ["bench", "--suite", str(SUITE), "--tasks", *TASKS, "--optimizers", ",".join(OPTS),
            "--budget", str(BUDGET), "--out", str(out), "--no-best-known-update", "--quiet",
            "--backend", "ray", "--jobs", "2"]
    assert main([*base, "--runs", "1"]) == 0
    assert len(_records(out)) == 4
    assert main([*base, "--runs", "2"]) == 0
    lines = (out / RESULTS_FILE).read_text().splitlines()
    assert len(lines) == 8  # run 0 was not run again
    assert _records(out) == expected


def test_make_executor_ray_uses_a_running_instance(ray_runtime: None) -> None:
    ex = make_executor(0, "ray")
    assert isinstance(ex, RayExecutor)
    assert ex.cluster_cpus() == 2
    ex.close()
    assert ray.is_initialized()


@pytest.mark.slow  # measured 3 s (issue 35: default suite <= 5 min)
def test_lam_build_on_ray_equals_this_process_and_resumes(ray_runtime: None,
                                                          tmp_path: Path) -> None:
    import numpy as np

    from lamde_mission.cli import main
    from planner_core.learning.lam.bbob import DatabaseSpec
    from planner_core.learning.lam.database import Database

    spec = DatabaseSpec.make((1, 6, 21), (10,), 2)
    here = Database(spec=spec, cache_dir=tmp_path / "here")
    assert here.build() == 3
    # on Ray through the CLI: one chunk first (an interrupted build), then the rest
    base = ["lam", "build", "--dims", "10", "--instances", "2", "--cache", str(tmp_path / "ray"),
            "--backend", "ray", "--jobs", "2", "--quiet"]
    assert main([*base, "--functions", "1"]) == 0
    assert main([*base, "--functions", "1,6,21"]) == 0
    on_ray = Database(spec=spec, cache_dir=tmp_path / "ray")
    assert on_ray.missing() == [] and on_ray.build() == 0
    for name in ("ela", "learned"):
        np.testing.assert_array_equal(here.load(name)[1], on_ray.load(name)[1])


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_train_on_ray_gives_the_checkpoint_of_this_process(ray_runtime: None,
                                                           tmp_path: Path) -> None:
    """Meta-training's rollouts on Ray (2 CPUs): the same seed gives the same checkpoint as the
    rollouts in this process (test_rollout.py checks two local worker processes)."""
    pytest.importorskip("torch")
    from tests.test_rollout import assert_same_checkpoint, train_cli

    here = train_cli(tmp_path, "here")
    on_ray = train_cli(tmp_path, "ray", "--backend", "ray", "--jobs", "2")
    assert_same_checkpoint(here, on_ray)
