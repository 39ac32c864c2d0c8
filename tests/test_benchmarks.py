"""Smoke test for the on-demand benchmark scripts: they run and print their verdict lines.

No timing is asserted here (targets belong to the benchmarks, run on a quiet machine)."""

from __future__ import annotations

import subprocess
import sys

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
