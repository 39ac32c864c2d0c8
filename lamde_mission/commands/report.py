"""`lamde-mission report RESULTS [-o REPORT.md]`: the benchmark's markdown table and figures."""

from __future__ import annotations

import argparse
import shlex
import sys

from lamde_mission.errors import UsageError


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `lamde-mission report` (options, help).

    Args:
        sub: the subcommands of `lamde_mission.cli.build_parser`.

    Returns:
        The command's parser (`build_parser` sets `run` as its `_run`).
    """
    p = sub.add_parser(
        "report",
        help="write the markdown report of a benchmark folder (table, limits, figures)",
        description="Summarise RESULTS/results.jsonl like the paper's Table 2: mean ± std of "
        "f + 10 phi per task, best bold, Wilcoxon rank-sum marks (+ ~ -) against the reference "
        "column, feasibility, wall time, ratios to the best-known f and the lower bound, every "
        "run's score per task, a convergence plot per task and the best paths on four tasks "
        "(PNGs beside the report; titles name the protocol, log scores when they span a "
        "decade).",
    )
    p.add_argument("results", help="benchmark folder (written by `lamde-mission bench`)")
    p.add_argument("-o", "--output",
                   help="markdown file to write (default RESULTS/report.md, beside the "
                   "results: a report never lands in the working folder unasked; the "
                   "project's own table is `-o docs/results.md`)")
    p.add_argument("--reference", metavar="NAME",
                   help="the column the marks compare against (default de-adaptive; where "
                   "RESULTS holds no de-adaptive runs, the first optimiser it holds in the "
                   "order `bench --list` shows (names not listed there after, alphabetically), "
                   "named in a note on stderr; for an ablation folder written by "
                   "benchmarks/ablations.py: its reference, LAMDE). Any other NAME without "
                   "runs is refused (exit 2)")
    p.add_argument("--suite", help="map folder (default: the one recorded in RESULTS/meta.json)")
    p.add_argument("--figures", metavar="DIR",
                   help="folder for the PNGs (default: beside the report, e.g. docs/results/)")
    p.add_argument("--path-tasks", nargs="+", metavar="T",
                   help="tasks of the best-path figure (default: four spread over the suite)")
    p.add_argument("--policy-checkpoint", metavar="DIR",
                   help="policy checkpoint folder: its curve.csv gives the training cost in "
                   "the report's cost section")
    p.add_argument("--title", default="Benchmark results",
                   help="the report's first heading (default 'Benchmark results')")
    p.add_argument("--no-limits", action="store_true",
                   help="leave out the lower-bound / best-known section")
    p.add_argument("--update-lower-bounds", action="store_true",
                   help="store the lower bounds the report computes in the cache beside the "
                   "suite (<suite>_lower_bounds.json); by default in RESULTS/lower_bounds.json, "
                   "so nothing is written beside the suite")
    p.add_argument("--imax", metavar="DIR",
                   help="add the I_max study (paper Fig. 4) from this benchmark folder (`bench "
                   "--i-max ... --out DIR`, or its slim copy from benchmarks/store_runs.py)")
    p.add_argument("--ablations", metavar="DIR",
                   help="add the ablation study (paper Table 3, Fig. 3) from this folder "
                   "(`benchmarks/ablations.py --out DIR`, or its slim copy)")
    p.add_argument("--mkdir", action="store_true",
                   help="create missing folders of -o and --figures (otherwise exit 2)")
    return p


def _command(args: argparse.Namespace, tasks: list[str] | None) -> str:
    parts = ["lamde-mission", "report", args.results, "-o", args.output]
    if args.reference:
        parts += ["--reference", args.reference]
    if args.suite:
        parts += ["--suite", args.suite]
    if args.figures:
        parts += ["--figures", args.figures]
    if tasks:
        parts += ["--path-tasks", *tasks]
    if args.policy_checkpoint:
        parts += ["--policy-checkpoint", args.policy_checkpoint]
    if args.no_limits:
        parts.append("--no-limits")
    if args.update_lower_bounds:
        parts.append("--update-lower-bounds")
    if args.title != "Benchmark results":
        parts += ["--title", args.title]
    if args.imax:
        parts += ["--imax", args.imax]
    if args.ablations:
        parts += ["--ablations", args.ablations]
    return shlex.join(parts)


def run(args: argparse.Namespace) -> int:
    """`report RESULTS -o OUT`: the markdown report (`planner_core.bench.report.build_report`).

    Args:
        args: the parsed options.

    Returns:
        0 when the report is written.

    Raises:
        UsageError: RESULTS (or --imax, --ablations) holds no results.jsonl, -o or the
            figures' folder cannot be written (a file in the way, a missing folder without
            --mkdir, a read-only folder), or the report cannot be built from it (one line,
            exit 2).
    """
    from pathlib import Path

    from lamde_mission.commands._common import check_output_folder, check_outputs
    from planner_core.bench._io import stored_path
    from planner_core.bench.report import DEFAULT_REFERENCE, build_report, figures_folder

    def has_results(folder: str) -> bool:  # plain, or gzip-compressed as docs/ keeps them
        return stored_path(Path(folder) / "results.jsonl").exists()

    if not has_results(args.results):
        raise UsageError(f"{args.results}: no results.jsonl (run `lamde-mission bench` first)")
    for flag, folder in (("--imax", args.imax), ("--ablations", args.ablations)):
        if folder and not has_results(folder):
            raise UsageError(f"{flag} {folder}: no results.jsonl")
    tasks = [t for v in args.path_tasks for t in v.split(",") if t] if args.path_tasks else None
    if args.output is None:  # beside the results (a reviewer's `report RUNS` in the checkout
        # rewrote the tracked docs/results.md with a 2-task table)
        args.output = str(Path(args.results) / "report.md")
    # before any figure: a file in the way (a traceback after the first figures), a missing
    # folder without --mkdir (as plan, map and lam select), a read-only folder
    check_outputs([("-o/--output", args.output)], mkdir=args.mkdir)
    check_output_folder("--figures" if args.figures else "-o/--output (its figures' folder)",
                        figures_folder(args.output, args.figures), mkdir=args.mkdir)
    notes: list[str] = []  # lines not read in a results file: said once the report is made
    try:
        out = build_report(args.results, args.output,
                           reference=args.reference or DEFAULT_REFERENCE,
                           suite=args.suite, figures=args.figures, path_tasks=tasks,
                           limits=not args.no_limits, command=_command(args, tasks),
                           policy_checkpoint=args.policy_checkpoint, title=args.title,
                           imax=args.imax, ablations=args.ablations,
                           log=notes.append, update_lower_bounds=args.update_lower_bounds)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    for note in notes:  # as `bench` says them when it resumes the folder; the reference
        print(note, file=sys.stderr)
    pngs = figures_folder(args.output, args.figures)
    drawn = len(list(pngs.glob("*.png"))) if pngs.is_dir() else 0
    print(f"report: wrote {out}" + (f" and {drawn} figures in {pngs}/" if drawn else ""))
    return 0
