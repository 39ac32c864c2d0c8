"""Evaluator speed: the fast (compiled) evaluator against the shapely reference, in one run.

Times 10,000 evaluations (100 populations of 100) on the densest 10 km suite task (T16) and, in
the same run, on a generated campus of 500 non-convex building footprints (`campus-500`:
`lamde_mission.gis.synthetic.campus_map(500, seed=0)`, L-, U-, T-shapes and blocks with a
courtyard on a 5 km grid of lots, seeded; the same map `lamde-mission map campus -o FILE` writes).
The reference evaluator is the same model with L_vio from `geometry.overlap_lengths_reference`
(shapely, one leg and one obstacle at a time); it is timed on a subset and reported per solution.
Target on a 2-core machine: >= 100,000 solutions/s and >= 50x the reference on T16.

    python benchmarks/bench_evaluate.py [MAP ...] [--reference-solutions 100]

MAP may be a file or `campus-N` (a generated campus of N footprints, seed 0).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from planner_core import Problem, load_map
from planner_core import defaults as D
from planner_core.model.geometry import overlap_lengths_reference

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MAPS = [str(ROOT / "examples" / "maps" / "suite" / "T16.json"), "campus-500"]


def load(spec: str):
    """A map from a file, or `campus-N`: the generated campus of N footprints (seed 0)."""
    if spec.startswith("campus-") and spec[7:].isdigit():
        from lamde_mission.gis.synthetic import campus_map

        return load_map(campus_map(int(spec[7:]), seed=0))
    return load_map(spec)


class ReferenceProblem(Problem):
    """The same model with the slow shapely overlap lengths."""

    def _overlap(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return overlap_lengths_reference(a, b, self.obstacles)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("maps", nargs="*", default=DEFAULT_MAPS, metavar="MAP")
    ap.add_argument("--batches", type=int, default=100)
    ap.add_argument("--population", type=int, default=D.POPULATION)
    ap.add_argument("--reference-solutions", type=int, default=100)
    args = ap.parse_args()
    for k, spec in enumerate(args.maps):
        if k:
            print()
        measure(load(spec), args, target=k == 0)


def measure(m, args: argparse.Namespace, target: bool) -> None:
    """Time the fast evaluator and the reference on one map; print the figures."""
    fast = Problem(m)
    ref = ReferenceProblem(m)
    rng = np.random.default_rng(0)
    n = args.batches * args.population
    X = fast.lower + rng.random((n, fast.dim)) * (fast.upper - fast.lower)
    fast.evaluate(X[: args.population])  # compile / warm caches outside the timing
    t0 = time.perf_counter()
    for k in range(args.batches):
        fast.evaluate(X[k * args.population:(k + 1) * args.population])
    t_fast = time.perf_counter() - t0
    k = args.reference_solutions
    t0 = time.perf_counter()
    f_ref, phi_ref = ref.evaluate(X[:k])
    t_ref = time.perf_counter() - t0
    f_fast, phi_fast = fast.evaluate(X[:k])
    agree = np.allclose(f_fast, f_ref) and np.allclose(phi_fast, phi_ref, rtol=1e-9, atol=1e-6)
    obs = m.spec.obstacles
    print(f"map {m.name}: {len(obs.circles)} circles, {len(obs.rectangles)} rectangles, "
          f"{len(obs.no_fly_zones)} no-fly zones, {len(obs.polygons)} polygon footprints "
          f"({m.obstacles.n_polygons} convex pieces and polygons in the kernel), "
          f"{len(m.sensor_ids)} sensors, I_max {m.max_hover_points}")
    fast_rate = n / t_fast
    ref_rate = k / t_ref
    print(f"fast evaluator:      {n} solutions in {t_fast:.3f} s = {fast_rate:,.0f} solutions/s")
    print(f"shapely reference:   {k} solutions in {t_ref:.3f} s = {ref_rate:,.0f} solutions/s")
    print(f"ratio fast/reference: {fast_rate / ref_rate:,.0f}x   (results agree: {agree})")
    if target:
        print(f"targets: >= 100,000 solutions/s [{'met' if fast_rate >= 1e5 else 'NOT met'}], "
              f">= 50x reference [{'met' if fast_rate / ref_rate >= 50 else 'NOT met'}]")


if __name__ == "__main__":
    main()
