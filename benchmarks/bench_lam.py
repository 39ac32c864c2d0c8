"""Landscape-aware module cost: probe + features per BBOB instance, and the database estimates.

For each dimension of the paper's database (20 .. 200), times on a sample of BBOB functions
(one instance each, a fresh instance id so nothing is cached): building the ``ioh`` instance,
evaluating the N_probe LHS points, the classical ELA subset and the learned encoder. Prints the
mean per instance and the single-core estimates for the default (360) and the paper's full
(14,400) database, and the cost of probing the suite's UAV tasks. BLAS runs on one thread
(as in ``lam build``).

    python benchmarks/bench_lam.py [--functions 1,3,8,15,21,24] [--dims 20,40,...]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from planner_core.learning.lam import DEFAULT, FULL, BBOBProblem, probe
from planner_core.learning.lam.ela import ela_features
from planner_core.learning.lam.encoder import LearnedExtractor
from planner_core.learning.lam.probe import N_PROBE, blas_single_thread
from planner_core.model.problem import Problem

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--functions", default="1,3,8,15,21,24")
    ap.add_argument("--dims", default=",".join(str(d) for d in FULL.dimensions))
    ap.add_argument("--n-probe", type=int, default=N_PROBE)
    args = ap.parse_args()
    fids = [int(v) for v in args.functions.split(",")]
    dims = [int(v) for v in args.dims.split(",")]
    enc = LearnedExtractor()
    per_dim: dict[int, float] = {}
    cpu_dim: dict[int, float] = {}
    print(f"N_probe = {args.n_probe}; functions {fids}; one core, BLAS single-threaded")
    print("wall-clock per instance (mean); 'cpu' is this process's CPU time (robust to load)")
    print(f"{'d':>5} {'build ioh':>10} {'evaluate':>10} {'ELA':>10} {'learned':>10} {'total':>10}"
          f" {'cpu':>10}")  # fmt: skip
    with blas_single_thread():
        for d in dims:
            t = np.zeros(4)
            c0 = time.process_time()
            for f in fids:
                prob = BBOBProblem((f, d, 977))  # an id no database uses: a cold instance
                t0 = time.perf_counter()
                prob.evaluate(np.full((1, d), 0.5))  # builds the ioh instance
                t1 = time.perf_counter()
                p = probe(prob, args.n_probe, 0)
                t2 = time.perf_counter()
                ela_features(p.U, p.f)
                t3 = time.perf_counter()
                enc(p.U, p.f)
                t4 = time.perf_counter()
                t += [t1 - t0, t2 - t1, t3 - t2, t4 - t3]
            t /= len(fids)
            per_dim[d] = float(t.sum())
            cpu_dim[d] = (time.process_time() - c0) / len(fids)
            print(f"{d:>5} " + " ".join(f"{v * 1e3:>8.1f}ms" for v in (*t, t.sum(), cpu_dim[d])))
        for name, spec in (("default", DEFAULT), ("full (paper)", FULL)):
            known = [d for d in spec.dimensions if d in per_dim]
            if len(known) < len(spec.dimensions):
                print(f"{name}: dimensions {sorted(set(spec.dimensions) - set(known))} not timed")
                continue
            per_chunk = len(spec.functions) * len(spec.instances)
            total = sum(per_dim[d] * per_chunk for d in spec.dimensions)
            cpu = sum(cpu_dim[d] * per_chunk for d in spec.dimensions)
            print(f"estimate {name} database ({len(spec)} instances): {total / 60:.1f} min "
                  f"wall-clock, {cpu / 60:.1f} min CPU, on one core")  # fmt: skip
        for name in ("T01", "T16"):
            task = Problem(ROOT / "examples" / "maps" / "suite" / f"{name}.json")
            task.evaluate(task.lower[None] + 0.5 * (task.upper - task.lower)[None])  # warm up
            t0 = time.perf_counter()
            p = probe(task, args.n_probe, 0)
            for y in (p.f, p.phi):
                ela_features(p.U, y)
                enc(p.U, y)
            print(f"task {name} (d={task.dim}): probe + z_f + z_phi (both extractors) "
                  f"{(time.perf_counter() - t0) * 1e3:.0f} ms")  # fmt: skip


if __name__ == "__main__":
    main()
