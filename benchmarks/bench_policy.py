"""Cost of the learned policy (configurator "lamde") per DE generation, against the evaluation.

Runs the DE with the policy on each map for a few generations and times, in the same run and
the same generations, (a) the policy's numpy inference (observation + forward pass + drawing the
actions: `PolicyConfigurator.configure`) and (b) the population's evaluation. Prints the
medians per generation and their ratio (policy / evaluation; < 1 means the policy costs less
than the evaluations it configures), and what the policy adds to a plan of 10,000 evaluations
with that population (its generations x the median). The policy's CPU time (this process's)
is printed beside its wall time: on a shared machine the wall time includes waiting for a core.

    python benchmarks/bench_policy.py [MAP ...] [--checkpoint lamde-v2] [--generations 30]

With `--scheduler lamde-s` (or `lamde-s-ppo`) it times instead, in each of `--plans` whole
plans per map (after one warm-up plan), the learned scheduler's decisions (`choose`: for
lamde-s the features at the improving stage's first decision, the neighbours in the shipped
table, then the chosen template's choices; for lamde-s-ppo the features and the network's
forward pass at every decision; lamde-s's `configure` too, its DE share from the map's
features before the first stage) against the plan's own time, and prints their ratio (issue
34's "<= 5 %").

    python benchmarks/bench_policy.py --scheduler lamde-s|lamde-s-ppo [MAP ...] [--plans 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path
from typing import Any

from planner_core import Problem, load_map
from planner_core.learning.policy import PolicyConfigurator, param_count
from planner_core.search.de import run
from planner_core.search.de.types import max_generations

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MAPS = [ROOT / "examples" / "maps" / "suite" / n for n in ("T08.json", "T16.json")]


class _Timed:
    """Records the wall time and this process's CPU time of each call of `fn`."""

    def __init__(self) -> None:
        self.times: list[float] = []
        self.cpu: list[float] = []

    def wrap(self, fn: Any) -> Any:
        def timed(*a: Any) -> Any:
            t0, c0 = time.perf_counter(), time.process_time()
            out = fn(*a)
            self.times.append(time.perf_counter() - t0)
            self.cpu.append(time.process_time() - c0)
            return out

        return timed


class _TimedProblem:
    def __init__(self, problem: Problem, timer: _Timed) -> None:
        self.lower, self.upper = problem.lower, problem.upper
        self.evaluate = timer.wrap(problem.evaluate)


class _TimedPolicy:
    def __init__(self, policy: PolicyConfigurator, timer: _Timed) -> None:
        self.init, self.update = policy.init, policy.update
        self.configure = timer.wrap(policy.configure)


def scheduler_cost(maps: list[str], name: str, plans: int) -> None:
    """Print, per map, the scheduler's decision time per plan and its ratio to the plan's
    time (wall and this process's CPU), medians over `plans` plans (seeds 0..plans-1)."""
    import lamde_mission
    from planner_core.pipeline.schedule import make_scheduler

    lamde_mission.plan(maps[0], seed=0, scheduler=name)  # compile the kernels, load the table
    for path in maps:
        rows = []
        for seed in range(plans):
            sched, timer = make_scheduler(name), _Timed()
            sched.choose = timer.wrap(sched.choose)
            if hasattr(sched, "configure"):  # lamde-s's DE share, before the first stage
                sched.configure = timer.wrap(sched.configure)
            t0, c0 = time.perf_counter(), time.process_time()
            p = lamde_mission.plan(path, seed=seed, scheduler=sched)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            rows.append((sum(timer.times), sum(timer.cpu), wall, cpu, len(timer.times),
                         getattr(sched, "template", None), p.config["de_share"]))
        t_s, c_s, wall, cpu = (statistics.median(r[k] for r in rows) for k in range(4))
        print(f"{Path(path).stem}: {name} {1e3 * t_s:.2f} ms (CPU {1e3 * c_s:.2f} ms) per plan "
              f"in {statistics.median(r[4] for r in rows):.0f} decisions; plan {wall:.2f} s "
              f"(CPU {cpu:.2f} s); scheduler / plan = {100 * t_s / wall:.2f} % (CPU "
              f"{100 * c_s / cpu:.2f} %); templates {[r[5] for r in rows]}, DE shares "
              f"{sorted({r[6] for r in rows})} (medians of {plans} plans)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("maps", nargs="*", default=[str(p) for p in DEFAULT_MAPS])
    ap.add_argument("--checkpoint", default="lamde-v2")
    ap.add_argument("--population", type=int, default=100)
    ap.add_argument("--generations", type=int, default=30)
    ap.add_argument("--scheduler", default=None, metavar="NAME",
                    help="time a learned scheduler (lamde-s, lamde-s-ppo) in whole plans "
                    "instead")
    ap.add_argument("--plans", type=int, default=3, help="plans per map with --scheduler (3)")
    args = ap.parse_args()
    if args.scheduler:
        scheduler_cost(args.maps, args.scheduler, args.plans)
        return
    policy = PolicyConfigurator(checkpoint=args.checkpoint)
    print(f"checkpoint {args.checkpoint}: {param_count(policy.net)} parameters, "
          f"net {policy.net.to_dict()}")
    for path in args.maps:
        problem = Problem(load_map(path))
        ev, pol = _Timed(), _Timed()
        budget = args.population * (args.generations + 1)
        run(_TimedProblem(problem, ev), configurator=_TimedPolicy(policy, pol), seed=0,
            population=args.population, budget=budget)
        # drop the first generation of each (compilation, caches) and the initial population
        t_eval = statistics.median(ev.times[2:])
        t_pol = statistics.median(pol.times[1:])
        c_pol = statistics.median(pol.cpu[1:])
        gens = max_generations(args.population, 10_000)
        print(f"{Path(path).stem}: N {args.population} x d {problem.dim}: policy "
              f"{1e3 * t_pol:.2f} ms (CPU {1e3 * c_pol:.2f} ms), evaluation "
              f"{1e3 * t_eval:.2f} ms per generation (medians of {len(pol.times) - 1}); "
              f"policy / evaluation = {t_pol / t_eval:.1f}; policy per 10,000-evaluation plan "
              f"({gens} generations): {gens * t_pol:.2f} s (CPU {gens * c_pol:.2f} s)")


if __name__ == "__main__":
    main()
