"""Executor backends side by side: one benchmark sweep on the local process pool and on Ray.

The sweep is `lamde-mission bench`'s own runner (`planner_core.bench.run_bench`): every suite map
x RUNS runs x the optimisers, a small budget, best-known file untouched, results in a temporary
folder. It runs at each worker count (default 1 and 2) on each backend, interleaved (local, ray,
local, ray) so a drifting machine affects both alike, and prints per run:

* start-up: creating the executor until every worker answered a trivial task (process spawn;
  for Ray: `ray.init` of a local instance with that many CPUs plus its workers),
* sweep: the benchmark itself (first job's imports and compiled-kernel loads included),
* compute: the sum of the jobs' own optimiser time, wall (`wall_s` in each record) and CPU
  (`cpu_s`: what the job took of a CPU; on a busy machine wall is larger by the waits),
* driver CPU: this process's CPU time during the sweep (submitting, collecting, writing JSONL),

then the ratio ray/local of the sweep time at each worker count, whether both backends wrote the
same records (wall time aside), and a scaling model fitted to the measurements (see
docs/scaling.md):

    T(W) = start-up + max(N * (c + o) / W, N * d)

with N jobs, W workers, c the per-job compute (CPU time), o the per-job overhead on a worker
(sweep time at one worker / N - wall compute per job: problem set-up, pickling, scheduling,
scaled by the CPU share the jobs got, cpu/wall) and d the driver's CPU per job (the serial
part). On a dedicated machine cpu = wall and the scaling is the plain measured one. It
extrapolates T to more workers and to `--nodes` x `--cpus-per-node` for the full
paper protocol (16 tasks x 25 runs x 15 optimisers at 10,000 evaluations) with the per-job cost
at 10,000 evaluations read from docs/results.md (mean wall time per optimiser, measured by the
full `lamde-mission bench` run that produced that report).

    python benchmarks/bench_executor.py [--runs 5] [--budget 1000] [--workers 1 2]
        [--optimizers de-adaptive,random-search] [--backends local,ray] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from planner_core.bench import run_bench
from planner_core.bench.limits import suite_task_files
from planner_core.bench.records import RESULTS_FILE, key_of, read_records
from planner_core.execution import make_executor

ROOT = Path(__file__).resolve().parent.parent
SUITE = ROOT / "examples" / "maps" / "suite"
RESULTS_MD = ROOT / "docs" / "results.md"
#: the paper's protocol: 16 tasks x 25 runs x ~15 optimisers (baselines and ablations)
PAPER_JOBS = 16 * 25 * 15


def sweep(backend: str, workers: int, args: argparse.Namespace, out: Path) -> dict[str, Any]:
    """One timed sweep; returns the timings and the records (without wall_s)."""
    t0 = time.perf_counter()
    ex = make_executor(workers, backend)
    try:
        # start-up: every worker up and answering (Ray starts workers lazily, so ask 2W times)
        list(ex.map_unordered(os.path.basename, [f"/w/{i}" for i in range(2 * workers)]))
        t1 = time.perf_counter()
        c0 = time.process_time()
        summary = run_bench(SUITE, args.optimizers, runs=args.runs, budget=args.budget, out=out,
                            best_known=False, executor=ex, command="bench_executor")
        t2 = time.perf_counter()
        cpu = time.process_time() - c0
    finally:
        ex.close()
    recs = read_records(out / RESULTS_FILE).records
    if summary.failed or len(recs) != summary.planned:
        raise SystemExit(f"{backend} x {workers}: {len(summary.failed)} job(s) failed: "
                         f"{summary.failed[:1]}")
    return {"backend": backend, "workers": workers, "jobs": len(recs),
            "startup_s": t1 - t0, "sweep_s": t2 - t1, "compute_s": sum(r["wall_s"] for r in recs),
            "compute_cpu_s": sum(r["cpu_s"] for r in recs), "driver_cpu_s": cpu,
            "records": {key_of(r): {k: v for k, v in r.items() if k not in ("wall_s", "cpu_s")}
                        for r in recs}}


def cost_at_10k() -> tuple[float, float, int]:
    """(mean, max) per-optimiser mean wall time per run and the optimiser count, from the
    'Per optimiser' table of docs/results.md (runs at 10,000 evaluations)."""
    text = RESULTS_MD.read_text()
    if "--budget 10000" not in text:
        raise SystemExit(f"{RESULTS_MD}: not a 10,000-evaluation report")
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("| Optimiser | runs |"))
    col = [c.strip() for c in lines[start].strip("|").split("|")].index("mean wall time (s)")
    walls = []
    for ln in lines[start + 2:]:  # the table's rows, up to the blank line after it
        if not ln.startswith("|"):
            break
        walls.append(float([c.strip() for c in ln.strip("|").split("|")][col]))
    return statistics.mean(walls), max(walls), len(walls)


def model(m: dict[str, Any]) -> dict[str, float]:
    """Start-up s0, per-job compute c (CPU), per-job worker overhead o (wall, scaled by the CPU
    share cpu/wall the jobs got) and driver CPU per job d, from a one-worker measurement."""
    n = m["jobs"]
    share = m["compute_cpu_s"] / m["compute_s"]
    o_wall = m["sweep_s"] / n - m["compute_s"] / n
    return {"s0": m["startup_s"], "c": m["compute_cpu_s"] / n, "o": o_wall * share,
            "d": m["driver_cpu_s"] / n, "share": share}


def predict(p: dict[str, float], jobs: int, workers: int, c: float | None = None,
            longest: float = 0.0) -> float:
    c = p["c"] if c is None else c
    return p["s0"] + max(jobs * (c + p["o"]) / workers, jobs * p["d"], longest + p["o"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--budget", type=int, default=1000)
    ap.add_argument("--optimizers", default="de-adaptive,random-search")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--backends", default="local,ray")
    ap.add_argument("--nodes", type=int, default=100)
    ap.add_argument("--cpus-per-node", type=int, default=32)
    ap.add_argument("--json", help="also write the measurements to this file")
    args = ap.parse_args()
    args.optimizers = args.optimizers.split(",")
    backends = args.backends.split(",")
    tasks = len(suite_task_files(SUITE))
    n = tasks * args.runs * len(args.optimizers)
    print(f"sweep: {tasks} maps x {args.runs} runs x {len(args.optimizers)} optimisers "
          f"({', '.join(args.optimizers)}) = {n} jobs at {args.budget} evaluations; "
          f"backends {', '.join(backends)}; workers {args.workers}; "
          f"machine: {os.cpu_count()} CPUs (shared: timings are noisy)")
    got: dict[tuple[str, int], dict[str, Any]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for w in args.workers:
            for b in backends:
                m = sweep(b, w, args, Path(tmp) / f"{b}-{w}")
                got[(b, w)] = m
                print(f"{b:5s} x {w} worker(s): start-up {m['startup_s']:6.2f} s, sweep "
                      f"{m['sweep_s']:6.2f} s, compute {m['compute_s']:6.2f} s (CPU "
                      f"{m['compute_cpu_s']:6.2f} s), driver CPU "
                      f"{m['driver_cpu_s']:5.2f} s, {m['sweep_s'] / n * 1000:6.1f} ms/job",
                      flush=True)
    print()
    for w in args.workers:
        if all((b, w) in got for b in ("local", "ray")):
            r = got[("ray", w)]["sweep_s"] / got[("local", w)]["sweep_s"]
            r0 = ((got[("ray", w)]["sweep_s"] + got[("ray", w)]["startup_s"])
                  / (got[("local", w)]["sweep_s"] + got[("local", w)]["startup_s"]))
            print(f"ratio ray/local at {w} worker(s): sweep {r:.2f}, with start-up {r0:.2f}")
    recs = [m["records"] for m in got.values()]
    same = all(r == recs[0] for r in recs[1:])
    print(f"same records on every backend and worker count (wall time aside): "
          f"{'yes' if same else 'NO'}")
    if not same:
        raise SystemExit(1)

    mean10k, max10k, n_opt = cost_at_10k()
    cluster = args.nodes * args.cpus_per_node
    for b in backends:
        if (b, 1) not in got:
            continue
        p = model(got[(b, 1)])
        print(f"\n{b}: model from the 1-worker run (jobs got {p['share']:.0%} of a CPU while "
              f"running): start-up {p['s0']:.2f} s, compute c "
              f"{p['c'] * 1000:.1f} ms/job, worker overhead o {p['o'] * 1000:.1f} ms/job, "
              f"driver CPU d {p['d'] * 1000:.2f} ms/job")
        for w in args.workers[1:]:
            if (b, w) in got:
                m = got[(b, w)]
                meas = m["startup_s"] + m["sweep_s"]
                sh = m["compute_cpu_s"] / m["compute_s"]
                print(f"  check at {w} workers: predicted {predict(p, n, w):.1f} s on dedicated "
                      f"CPUs, measured {meas:.1f} s with jobs at {sh:.0%} of a CPU")
        print("  this sweep at W workers (predicted): " + ", ".join(
            f"W={w}: {predict(p, n, w):.1f} s" for w in (1, 2, 4, 8, 16, 64, 256)))
        lim = 1 / p["d"] if p["d"] > 0 else math.inf
        print(f"  driver-bound above ~{(p['c'] + p['o']) / p['d']:.0f} workers at this job size "
              f"(at most {lim:.0f} jobs/s through one driver)" if p["d"] > 0 else "")
        one = PAPER_JOBS * (mean10k + p["o"])
        t = predict(p, PAPER_JOBS, cluster, c=mean10k, longest=max10k)
        print(f"  paper protocol ({PAPER_JOBS} jobs at 10,000 evaluations, {mean10k:.2f} s/job "
              f"mean over {n_opt} optimisers in docs/results.md, slowest {max10k:.2f} s): "
              f"1 worker {one / 3600:.2f} h; {args.nodes} nodes x {args.cpus_per_node} CPUs "
              f"= {cluster} workers: {t:.1f} s (start-up on this machine; a cluster's own "
              f"start-up not included)")
    if args.json:
        Path(args.json).write_text(json.dumps(
            [{k: v for k, v in m.items() if k != "records"} for m in got.values()], indent=1))


if __name__ == "__main__":
    main()
