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

``--train`` times meta-training instead (`lamde-mission train`'s own `ppo.train`, rollouts
behind the executor, PPO update in this process): a short training (default 2 epochs of 4
built-in maps rolled out together, population 50, 1,000 evaluations per episode) at each worker
count on each backend, where one local worker means the rollouts run in this process (as
`train --jobs 1`). Per run it prints the training's wall time split into the rollout phases
(waiting for the segments) and the rest (the learner's PPO updates, checkpoint writing), the
segments' own CPU and wall time, the bytes a job and a segment pickle to, the ratios to local x
1 and whether every run wrote the same weights. Its model (docs/scaling.md, "Meta-training"):

    T(W) = R * ( ceil(B / W) * (s + o) + B * l )

with R rounds (n-step segments per chunk x chunks x epochs), B episodes per chunk (--envs), s
the CPU of one segment, o the per-segment overhead of the backend (a round's rollout wall beyond
its segments' own, scaled by the CPU share) and l the learner's CPU per episode-segment. It
gives the time per episode at W workers with B = W episodes per chunk, and extrapolates the
training --train-plan EPOCHS,PROBLEMS,BUDGET (default lamde-v1's recipe: 16 epochs of 16 maps at
3,000 evaluations; at the measured population) to one worker, to min(PROBLEMS, cluster) workers
and, with a training set as large as the cluster, to --nodes x --cpus-per-node.

    python benchmarks/bench_executor.py --train [--train-maps 4] [--train-envs 4]
        [--train-epochs 2] [--train-budget 1000] [--train-plan 16,16,3000] [--workers 1 2]
        [--backends local,ray]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pickle
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from planner_core.bench import run_bench
from planner_core.bench.limits import suite_task_files
from planner_core.bench.records import RESULTS_FILE, key_of, read_records
from planner_core.execution import SerialExecutor, make_executor

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
    ap.add_argument("--train", action="store_true",
                    help="time a short meta-training instead of the benchmark sweep")
    ap.add_argument("--train-maps", type=int, default=4)
    ap.add_argument("--train-envs", type=int, default=4)
    ap.add_argument("--train-epochs", type=int, default=2)
    ap.add_argument("--train-population", type=int, default=50)
    ap.add_argument("--train-budget", type=int, default=1000)
    ap.add_argument("--train-plan", default="16,16,3000", metavar="EPOCHS,PROBLEMS,BUDGET",
                    help="the training to extrapolate to (default: lamde-v1's recipe)")
    args = ap.parse_args()
    if args.train:
        train_main(args)
        return
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


# ---------------------------------------------------------------------------------- --train


class TimedExecutor:
    """Wraps an executor: the wall time of each round (one `map_unordered` call, from the first
    submission to the last result), every result's own CPU and wall time (a rollout segment's
    ``cpu_s`` and ``wall_s``) and the pickled size of every job and result."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.rounds: list[float] = []
        self.seg_cpu: list[float] = []
        self.seg_wall: list[float] = []
        self.job_bytes: list[int] = []
        self.seg_bytes: list[int] = []

    def map_unordered(self, fn: Any, items: Any) -> Any:
        items = list(items)
        self.job_bytes += [len(pickle.dumps(i)) for i in items]
        t0 = time.perf_counter()
        for r in self.inner.map_unordered(fn, items):
            self.seg_cpu.append(r.cpu_s)
            self.seg_wall.append(r.wall_s)
            self.seg_bytes.append(len(pickle.dumps(r)))
            yield r
        self.rounds.append(time.perf_counter() - t0)

    def close(self) -> None:
        self.inner.close()


def _load_rollout(_: int) -> int:
    """Start-up task: the worker imports the rollout code (the planner, numba's cached kernels)."""
    import planner_core.learning.policy.rollout  # noqa: F401

    return os.getpid()


def train_run(backend: str, workers: int, args: argparse.Namespace, out: Path) -> dict[str, Any]:
    """One timed short training; returns the timings and the weights' bytes."""
    from planner_core.learning.policy import ppo, rollout
    from planner_core.learning.policy.problems import default_training_specs

    cfg = ppo.PPOConfig(epochs=args.train_epochs, envs=args.train_envs,
                        population=args.train_population, budget=args.train_budget, seed=0)
    specs = default_training_specs(args.train_maps)
    # every run builds its problems afresh: here first (as train does), in each worker again
    rollout._built.cache_clear()
    b0 = time.perf_counter()
    for spec in specs:
        rollout.problem_of(rollout.portable_spec(spec))
    build_s = time.perf_counter() - b0
    # the PPO updates' own CPU time
    update_cpu: list[float] = []
    update = ppo.ppo_update

    def timed_update(*a: Any, **kw: Any) -> Any:
        c = time.process_time()
        try:
            return update(*a, **kw)
        finally:
            update_cpu.append(time.process_time() - c)

    t0 = time.perf_counter()
    inner = (SerialExecutor() if backend == "local" and workers == 1
             else make_executor(workers, backend))
    ex = TimedExecutor(inner)
    ppo.ppo_update = timed_update
    try:
        list(inner.map_unordered(_load_rollout, range(2 * workers)))
        t1 = time.perf_counter()
        c0 = time.process_time()
        ppo.train(cfg, specs, out, executor=ex)
        t2 = time.perf_counter()
        cpu = time.process_time() - c0
    finally:
        ppo.ppo_update = update
        ex.close()
    in_process = isinstance(inner, SerialExecutor)
    return {"backend": backend, "workers": workers, "in_process": in_process,
            "episodes": cfg.epochs * len(specs), "segments": len(ex.seg_cpu),
            "rounds": len(ex.rounds), "envs": cfg.envs, "build_s": build_s,
            "startup_s": t1 - t0, "train_s": t2 - t1,
            "rollout_s": sum(ex.rounds), "seg_cpu_s": sum(ex.seg_cpu),
            "seg_wall_s": sum(ex.seg_wall), "driver_cpu_s": cpu,
            # the learner's CPU: the driver's, less the rollouts when they ran here
            "learner_cpu_s": cpu - (sum(ex.seg_cpu) if in_process else 0.0),
            "update_cpu_s": sum(update_cpu),
            "job_kb": statistics.mean(ex.job_bytes) / 1000,
            "seg_kb": statistics.mean(ex.seg_bytes) / 1000,
            "weights": (out / "weights.npz").read_bytes()}


def warm_up(args: argparse.Namespace) -> None:
    """A tiny untimed training in this process: torch's and numba's first-call costs."""
    from planner_core.learning.policy import ppo
    from planner_core.learning.policy.problems import default_training_specs

    cfg = ppo.PPOConfig(epochs=1, envs=1, population=args.train_population,
                        budget=2 * args.train_population, n_steps=1)
    with tempfile.TemporaryDirectory() as tmp:
        ppo.train(cfg, default_training_specs(1), Path(tmp) / "w")


def train_model(ms: dict[tuple[str, int], dict[str, Any]], backend: str) -> dict[str, float]:
    """Per-segment CPU s, per-segment backend overhead o and learner CPU per episode-segment l.

    s and l come from the in-process run (local x 1) when there is one; o from this backend's
    run at the most workers (0 in this process: nothing is shipped), a round's rollout wall
    beyond its segments' own wall (ceil(B / W) segments in a row per worker), scaled by the CPU
    share the segments got."""
    base = ms.get(("local", 1)) or next(iter(ms.values()))
    s = base["seg_cpu_s"] / base["segments"]
    seg_per_round = base["segments"] / base["rounds"]
    l_cpu = base["learner_cpu_s"] / base["rounds"] / seg_per_round
    runs = [m for (b, _), m in ms.items() if b == backend and not m["in_process"]]
    o = 0.0
    if runs:
        m = max(runs, key=lambda m: m["workers"])
        per_round = m["segments"] / m["rounds"]
        waves = math.ceil(per_round / m["workers"])
        share = m["seg_cpu_s"] / m["seg_wall_s"]
        seg_wall = m["seg_wall_s"] / m["segments"]
        o = max(0.0, (m["rollout_s"] / m["rounds"] / waves - seg_wall) * share)
    return {"s": s, "o": o, "l": l_cpu, "share": base["seg_cpu_s"] / base["seg_wall_s"]}


def episode_time(p: dict[str, float], segments: int, B: int, W: int) -> float:
    """Training time per episode (the model): ``segments`` n-step segments, each round running
    the chunk's B segments on min(W, B) workers, then the update on all B."""
    return segments * ((p["s"] + p["o"]) * math.ceil(B / W) / B + p["l"])


def train_main(args: argparse.Namespace) -> None:
    backends = args.backends.split(",")
    G = max(1, math.ceil((args.train_budget - args.train_population) / args.train_population))
    n_steps = 10
    print(f"training: {args.train_epochs} epoch(s) x {args.train_maps} built-in maps, "
          f"{args.train_envs} rolled out together, population {args.train_population}, "
          f"{args.train_budget} evaluations = {G} generations per episode in segments of "
          f"{n_steps}; backends {', '.join(backends)}; workers {args.workers} (local x 1 = "
          f"this process); machine: {os.cpu_count()} CPUs (shared: timings are noisy)")
    warm_up(args)
    got: dict[tuple[str, int], dict[str, Any]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for w in args.workers:
            for b in backends:
                m = train_run(b, w, args, Path(tmp) / f"{b}-{w}")
                got[(b, w)] = m
                share = m["seg_cpu_s"] / m["seg_wall_s"]
                print(f"{b:5s} x {w} worker(s){' (this process)' if m['in_process'] else ''}: "
                      f"start-up {m['startup_s']:5.2f} s, training {m['train_s']:6.1f} s = "
                      f"rollouts {m['rollout_s']:6.1f} s + learner and rest "
                      f"{m['train_s'] - m['rollout_s']:5.1f} s; {m['segments']} segments: CPU "
                      f"{m['seg_cpu_s']:5.1f} s, wall {m['seg_wall_s']:6.1f} s ({share:.0%} of "
                      f"a CPU); learner CPU {m['learner_cpu_s']:5.1f} s (PPO updates "
                      f"{m['update_cpu_s']:5.1f} s); problems built here in {m['build_s']:.1f} s;"
                      f" job "
                      f"{m['job_kb']:.0f} kB, segment {m['seg_kb']:.0f} kB", flush=True)
    print()
    base = got.get(("local", 1))
    if base is not None:
        for (b, w), m in got.items():
            if (b, w) != ("local", 1):
                r0 = (m["train_s"] + m["startup_s"]) / (base["train_s"] + base["startup_s"])
                print(f"ratio {b} x {w} / local x 1: training "
                      f"{m['train_s'] / base['train_s']:.2f}, with start-up {r0:.2f}, rollout "
                      f"phases {m['rollout_s'] / base['rollout_s']:.2f}")
    first = next(iter(got.values()))
    same = all(m["weights"] == first["weights"] for m in got.values())
    print(f"same checkpoint on every backend and worker count: {'yes' if same else 'NO'}")
    if not same:
        raise SystemExit(1)

    base = base or first
    B = args.train_envs
    seg_ep = base["segments"] / base["episodes"]
    print(f"\nper episode ({G} generations, population {args.train_population}, "
          f"{seg_ep:.0f} segments), from local x 1: rollout CPU "
          f"{base['seg_cpu_s'] / base['episodes']:.2f} s, learner CPU "
          f"{base['learner_cpu_s'] / base['episodes']:.2f} s")
    epochs, problems, budget = (int(v) for v in args.train_plan.split(","))
    plan_seg = math.ceil(max(1, math.ceil((budget - args.train_population)
                                          / args.train_population)) / n_steps)
    cluster = args.nodes * args.cpus_per_node
    for b in backends:
        p = train_model(got, b)
        print(f"{b}: model (share of a CPU {p['share']:.0%}): segment CPU s "
              f"{p['s'] * 1000:.0f} ms, backend overhead o {p['o'] * 1000:.0f} ms per segment, "
              f"learner CPU l {p['l'] * 1000:.0f} ms per episode-segment")
        for w in args.workers:
            if (b, w) in got:
                m = got[(b, w)]
                pred = base["episodes"] * episode_time(p, seg_ep, B, w)
                print(f"  check at {w} worker(s): predicted {pred:.1f} s on dedicated CPUs, "
                      f"measured {m['train_s']:.1f} s with segments at "
                      f"{m['seg_cpu_s'] / m['seg_wall_s']:.0%} of a CPU")
        print(f"  per episode with --envs = W = min(workers, problems) (learner-bound at "
              f"{seg_ep * p['l']:.2f} s): " + ", ".join(
                  f"W={w}: {episode_time(p, seg_ep, w, w):.2f} s"
                  for w in (1, 2, 4, 16, 64, 256)))
        for P, w in sorted({(problems, 1), (problems, min(problems, cluster)),
                            (cluster, 1), (cluster, cluster)}):
            t = epochs * P * episode_time(p, plan_seg, w, w)
            where = (f"{args.nodes} nodes x {args.cpus_per_node} CPUs" if w == cluster
                     else f"{w} worker(s)")
            print(f"  {epochs} epochs x {P} problems at {budget} evaluations ({plan_seg} "
                  f"segments per episode), --envs {w} on {where}: {t / 3600:.2f} h")
    if args.json:
        Path(args.json).write_text(json.dumps(
            [{k: v for k, v in m.items() if k != "weights"} for m in got.values()], indent=1))


if __name__ == "__main__":
    main()
