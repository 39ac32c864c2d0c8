"""Planning speed and memory: `plan` on the largest suite map at 10,000 evaluations.

Prints wall time split into evaluation, seeding (the sensor- and obstacle-aware initial
population), optimiser overhead (DE ask/tell/configurator) and polish, plus the process's peak
memory (ru_maxrss) and whether torch or matplotlib were imported on the planning path.

Two measurements in one process:

* cold: the first `plan` call, as `lamde-mission plan` makes it. It includes one-off costs:
  numba loads each compiled kernel from its on-disk cache at first use (a few ms per kernel),
  which lands in whichever phase calls the kernel first (evaluation, seeding, optimiser).
* warm: further `plan` calls (seeds seed+1 .. seed+N, medians), the per-plan cost a notebook,
  a benchmark run or a batch of maps pays.

Targets on a 2-core machine: cold plan() <= 2 s; optimiser overhead below evaluation time
(warm medians; the cold ratio is printed too); peak memory <= 300 MB.

    python benchmarks/bench_plan.py [MAP] [--seed 0] [--budget 10000] [--warm 5]

Run it as its own process: peak memory and the cold call are the whole process's.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MAP = ROOT / "examples" / "maps" / "suite" / "T16.json"
PHASES = ("evaluation", "seeding", "optimiser", "polish")


def _split(t: dict[str, float]) -> str:
    other = t["total"] - sum(t[k] for k in PHASES)
    return (f"plan() {t['total']:.3f} s = " + " + ".join(f"{k} {t[k]:.3f} s" for k in PHASES)
            + f" + other (map, set-up) {other:.3f} s")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("map", nargs="?", default=str(DEFAULT_MAP))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget", type=int, default=10_000)
    ap.add_argument("--warm", type=int, default=5, help="warm plan() calls after the first")
    args = ap.parse_args()
    t0 = time.perf_counter()
    import lamde_mission

    p = lamde_mission.plan(args.map, seed=args.seed, budget=args.budget)
    wall = time.perf_counter() - t0
    cold = p.timings
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"map {p.map_name}: f {p.f:.2f}, phi {p.phi:.3g}, feasible {p.feasible}, "
          f"{p.n_hover} hover points, {p.evaluations} evaluations")
    print(f"cold: wall time (incl. imports) {wall:.3f} s; {_split(cold)}")
    print(f"cold: optimiser/evaluation ratio {cold['optimiser'] / cold['evaluation']:.2f} "
          "(each includes loading its compiled kernels)")
    print(f"peak memory {rss_mb:.0f} MB; torch imported: {'torch' in sys.modules}; "
          f"matplotlib imported: {'matplotlib' in sys.modules}")
    ratio = None
    if args.warm > 0:
        runs = [lamde_mission.plan(args.map, seed=args.seed + 1 + i, budget=args.budget).timings
                for i in range(args.warm)]  # fmt: skip
        med = {k: statistics.median(r[k] for r in runs) for k in (*PHASES, "total")}
        ratio = med["optimiser"] / med["evaluation"]
        print(f"warm (median of {args.warm}): {_split(med)}")
        each = ", ".join(f"{r['optimiser'] / r['evaluation']:.2f}" for r in runs)
        print(f"warm: optimiser/evaluation ratio {ratio:.2f} (per run: {each})")
    ok = (cold["total"] <= 2.0, ratio is not None and ratio < 1.0, rss_mb <= 300)
    print("targets: cold plan() <= 2 s [{}], warm optimiser < evaluation [{}], "
          "<= 300 MB [{}]".format(*("met" if x else "NOT met" for x in ok)))


if __name__ == "__main__":
    main()
