"""`lamde-mission bench`: every optimiser x task x run on the same budget (resumable JSON lines)."""

from __future__ import annotations

import argparse
import os
import shlex
import sys
from pathlib import Path

from lamde_mission.commands._common import (
    add_executor_args,
    check_executor_args,
    check_output_folder,
)
from lamde_mission.errors import UsageError
from planner_core import defaults as D

_DEFAULT_SUITE = "examples/maps/suite"
_DEFAULT_OUT = "results"
_DEFAULT_RUNS = D.RUNS
_DEFAULT_BUDGET = D.BUDGET
# --best-known: the protocol for the best-known solutions (100 x the budget, 5 runs each, the
# strongest optimisers)
_BK_RUNS = D.BEST_KNOWN_RUNS
_BK_BUDGET = D.BEST_KNOWN_BUDGET
_BK_OUT = "results-best-known"


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission bench` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "bench",
        help="compare optimisers on the benchmark suite (same maps, same budget)",
        description="Run every optimiser x task x run with the same evaluation budget and "
        "independent seeds; each finished run is appended to OUT/results.jsonl at once, so an "
        "interrupted benchmark resumes where it stopped (runs already there are skipped). A "
        "feasible run that beats a task's best-known f updates SUITE_best_known.json beside the "
        "suite folder (e.g. examples/maps/suite_best_known.json). "
        "Then: `lamde-mission report OUT -o docs/results.md`.",
    )
    p.add_argument("--suite", default=_DEFAULT_SUITE, help=f"map folder (default {_DEFAULT_SUITE})")
    p.add_argument("--tasks", nargs="+", metavar="T", help="only these tasks (file stems, e.g. "
                   "T01 T02 or T01,T02; default all maps in the suite)")
    p.add_argument("--optimizers", "--optimisers", nargs="+", metavar="NAME", dest="optimizers",
                   help="optimisers to run (space or comma separated; default all those "
                   "that can run here; --list shows them, and the pip extra each needs beyond "
                   "the core: one named whose extra is not installed is refused before "
                   "anything runs, by default it is left out with a note)")
    p.add_argument("--runs", type=int, help=f"runs per optimiser and task (default "
                   f"{_DEFAULT_RUNS}; {_BK_RUNS} with --best-known; at most {D.MAX_RUNS:,})")
    p.add_argument("--budget", type=int, help=f"evaluations per run, initial population "
                   f"included (default {_DEFAULT_BUDGET:,}; {_BK_BUDGET:,} with --best-known; "
                   f"from the population, {D.POPULATION}, to {D.MAX_BUDGET:,})")
    p.add_argument("--jobs", type=int, help="worker processes (default: the CPU count; 0 = run "
                   "in this process); with --backend ray and no --address: the CPUs of the Ray "
                   "instance started here (0 = all); ignored with --address")
    add_executor_args(p, "runs")
    p.add_argument("--out", help=f"results folder (default {_DEFAULT_OUT}/; {_BK_OUT}/ with "
                   "--best-known)")
    p.add_argument("--seed", type=int, default=0, help="base seed; run r of task t uses a "
                   "seed derived from (seed, t, r) (default 0)")
    p.add_argument("--best-known", action="store_true", help="the best-known protocol: "
                   f"budget {_BK_BUDGET:,}, {_BK_RUNS} runs, the strongest optimisers (cmaes, "
                   "de-adaptive, de-adaptive-fixedlen), out "
                   f"{_BK_OUT}/ (each can still be overridden)")
    p.add_argument("--best-known-file", metavar="PATH", help="best-known file to update "
                   "(default SUITE_best_known.json beside the suite folder)")
    p.add_argument("--no-best-known-update", action="store_true",
                   help="do not touch the best-known file")
    p.add_argument("--init", choices=("seeded", "uniform", "both"), default="seeded",
                   help="start mode: seeded (the product's sensor-aware starts), uniform (the "
                   "paper's protocol: every optimiser starts uniform in the box), or both; "
                   "recorded per run, the report gives each its own section (default seeded)")
    p.add_argument("--i-max", nargs="+", metavar="N", dest="i_max",
                   help="the I_max study (paper Fig. 4): override every map's I_max "
                   "(uav.max_hover_points) with each of these values, e.g. 20 40 60 80 100 or "
                   "20,40; records the last population's feasible rate (default: the maps' own)")
    p.add_argument("--list", action="store_true", help="list the optimisers and exit")
    p.add_argument("--quiet", action="store_true", help="print only the summary")
    return p


def _names(values: list[str] | None, option: str) -> list[str] | None:
    """The names of a space- or comma-separated option; None where it was not given."""
    if values is None:
        return None
    names = [n.strip() for v in values for n in v.split(",") if n.strip()]
    if not names:  # `--tasks ,` or `--tasks ""`: not "all of them"
        raise UsageError(f"{option}: no name given (leave the option out for the default)")
    return names


def _command(args: argparse.Namespace, optimisers: list[str], tasks: list[str] | None) -> str:
    """The exact command (every option spelled out), recorded with the results."""
    parts = ["lamde-mission", "bench", "--suite", args.suite]
    if tasks:
        parts += ["--tasks", *tasks]
    parts += ["--optimizers", ",".join(optimisers), "--runs", str(args.runs),
              "--budget", str(args.budget), "--jobs", str(args.jobs), "--out", args.out,
              "--seed", str(args.seed), "--init", args.init, "--backend", args.backend]
    if args.i_max_values:
        parts += ["--i-max", *map(str, args.i_max_values)]
    if args.address is not None:
        parts += ["--address", args.address]
    if args.best_known_file:
        parts += ["--best-known-file", args.best_known_file]
    if args.no_best_known_update:
        parts.append("--no-best-known-update")
    return shlex.join(parts)


def run(args: argparse.Namespace) -> int:
    """`bench` (or `bench --list`): every option is checked before any run.

    Args:
        args: the parsed options; `runs`, `budget`, `out`, `jobs` and `i_max_values` are
            filled in on it (the defaults, or the --best-known protocol's).

    Returns:
        0 when every run is done or already present (and for --list), 1 when any failed.

    Raises:
        UsageError: a bad option, or a suite or results folder `run_bench` refuses (one
            line, exit 2).
    """
    from planner_core.bench.baselines import REGISTRY, missing_extras
    from planner_core.bench.runner import BEST_KNOWN_OPTIMISERS, BenchError, run_bench
    from planner_core.textio import counted

    if args.list:
        for name, spec in REGISTRY.items():
            needs = (f" [needs {', '.join(spec.requires)}: pip install "
                     f"'lamde-mission[{spec.extra}]']" if spec.requires else "")  # fmt: skip
            print(f"{name:22s} {spec.description}{needs}")
        return 0
    bk = args.best_known
    args.runs = args.runs if args.runs is not None else (_BK_RUNS if bk else _DEFAULT_RUNS)
    args.budget = (args.budget if args.budget is not None
                   else (_BK_BUDGET if bk else _DEFAULT_BUDGET))
    args.out = args.out or (_BK_OUT if bk else _DEFAULT_OUT)
    if args.jobs is None:
        args.jobs = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
            os.cpu_count() or 1)
    named = _names(args.optimizers, "--optimizers")
    optimisers = named or (list(BEST_KNOWN_OPTIMISERS) if bk else list(REGISTRY))
    tasks = _names(args.tasks, "--tasks")
    args.i_max_values = []
    for v in _names(args.i_max, "--i-max") or []:
        try:
            k = int(v)
        except ValueError:
            raise UsageError(f"--i-max: {v!r} is not an integer") from None
        if not 1 <= k <= 200:
            raise UsageError(f"--i-max: {k} outside [1, 200]")
        args.i_max_values.append(k)
    inits = ("seeded", "uniform") if args.init == "both" else (args.init,)
    if not 1 <= args.runs <= D.MAX_RUNS:
        raise UsageError(f"--runs must be an integer in [1, {D.MAX_RUNS:,}] (got {args.runs})")
    try:  # as plan's budget: the DE-based optimisers' first population fits in it
        D.check_budget(args.budget, D.POPULATION)
    except ValueError as exc:
        raise UsageError(f"--{exc}") from None
    if args.jobs < 0:
        raise UsageError(f"--jobs must be >= 0 (got {args.jobs})")
    if args.seed < 0:
        raise UsageError(f"--seed must be an integer >= 0 (got {args.seed})")
    if args.best_known_file and not args.no_best_known_update:
        folder = Path(args.best_known_file).parent
        if not folder.is_dir():
            raise UsageError(f"--best-known-file {args.best_known_file}: no folder {folder}")
    check_executor_args(args)
    unknown = [o for o in optimisers if o not in REGISTRY]
    if unknown:
        raise UsageError(f"--optimizers: unknown {', '.join(unknown)}; choose from "
                         f"{', '.join(REGISTRY)}")
    lacking = missing_extras(optimisers)  # as train's torch: before anything starts
    if lacking and named:
        raise UsageError(f"--optimizers: {lacking}")
    if lacking:  # the default set: those that can run here, and a note on the others
        optimisers = [o for o in optimisers if not REGISTRY[o].missing()]
        if not optimisers:
            raise UsageError(f"no optimiser of the default set can run here: {lacking}")
        print(f"note: {lacking}; running the other {counted(len(optimisers), 'optimiser')}",
              file=sys.stderr)
    # the results folder last of the options, before any run: a file in the way (a traceback
    # at the first write), a read-only folder; a missing one is made, as every run's write does
    check_output_folder("--out", args.out, mkdir=True)
    command = _command(args, optimisers, tasks)
    best_known: str | bool = False if args.no_best_known_update else (
        args.best_known_file or True)

    def log(msg: str) -> None:
        if not args.quiet:
            print(msg, flush=True)

    log(command)
    try:
        s = run_bench(args.suite, optimisers, runs=args.runs, budget=args.budget, out=args.out,
                      tasks=tasks, jobs=args.jobs, base_seed=args.seed, best_known=best_known,
                      command=command, log=log, inits=inits,
                      i_max=tuple(args.i_max_values) or (None,), backend=args.backend,
                      address=args.address)
    except BenchError as exc:
        raise UsageError(str(exc)) from None
    print(f"bench: {counted(s.done, 'run')} done, {s.skipped} already present, "
          f"{len(s.failed)} failed; results in {s.results}")
    if s.best_known_updates:
        print(f"bench: best-known improved on {', '.join(sorted(set(s.best_known_updates)))}")
    for rec in s.failed:
        print(f"failed: {rec['optimiser']} {rec['task']} run {rec['run']}: {rec['error']}",
              file=sys.stderr)
    return 1 if s.failed else 0
