"""Smoke test for the on-demand benchmark scripts: they run and print their verdict lines.

No timing is asserted here (targets belong to the benchmarks, run on a quiet machine)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import ROOT


def test_bench_plan_runs_on_a_small_map() -> None:
    r = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_plan.py"),
         str(ROOT / "examples" / "maps" / "tiny.json"), "--budget", "300", "--cold", "1",
         "--warm", "1"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "cold (median of 1 fresh processes)" in out and "warm (median of 1" in out
    assert "optimiser/evaluation ratio" in out and out.rstrip().splitlines()[-1].startswith(
        "targets:"
    )
    assert "neither torch nor matplotlib" in out  # the planning path stays light


@pytest.mark.slow  # two short trainings and a process pool: about 25 s on a busy machine
def test_bench_executor_train_mode_runs_on_local_backends() -> None:
    """`bench_executor.py --train` (tiny settings, local backends): timings, ratio, verdict."""
    r = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_executor.py"), "--train",
         "--backends", "local", "--train-maps", "2", "--train-envs", "2", "--train-population",
         "10", "--train-budget", "40", "--train-epochs", "1"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stdout + r.stderr
    out = r.stdout
    assert "local x 1 worker(s) (this process):" in out and "local x 2 worker(s):" in out
    assert "ratio local x 2 / local x 1: training" in out
    assert "same checkpoint on every backend and worker count: yes" in out
    assert "16 epochs x 3200 problems at 3000 evaluations" in out
