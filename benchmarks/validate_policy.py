"""Validate a policy checkpoint: lamde vs adaptive vs random vs fixed, both start modes.

Runs each configurator on each map for R seeds and reports, per map and start mode, the mean
penalised score f + 10 phi (lower is better), the feasible runs, and the Wilcoxon rank-sum mark
of lamde (or `--reference`) against each other configurator ("+": lamde significantly better,
"-": significantly worse, "~": no significant difference; alpha 0.05, two-sided,
`planner_core.bench.stats.wilcoxon_mark`).

Pipelines (every configurator always gets the same one): "de" (default), the DE alone, no
memetic step, no polish: the configurators' own effect; "memetic", the DE with the memetic
step on the elite every 10 generations (from a uniform start: `memetic="auto"`, with its repair
of unserved sensors) and the hover-time LP on the final population's elite, no constructive
starts and no descents (`baselines.de.planner(..., starts=0, descent=False)`: the DE decides the
plan's structure, the repair makes it feasible); "planner", what `plan` does: the
benchmark's `planner` entry (`planner_core.bench.baselines.REGISTRY["planner"]`, its keyword
arguments: constructive starts and their descents, the DE with the memetic step from a uniform
start, the hover-time LP on the final population's elite, the final plan's descent, structural
search and kicks) with the configurator under test; "repair", the DE with only the memetic
step's repair of an infeasible elite (`planner_core.search.refine.repair`: a hover point for each
unserved sensor, blocked legs re-routed; no 2-opt, LP or removal moves on feasible plans, no
polish). Records carry their pipeline; one JSONL may hold several (records written before the
planner entry had starts and descents are the pipeline of their time).

Configurators: "lamde" (the policy `--checkpoint`), "adaptive", "random", "fixed" (DE/rand/1/bin,
0.5, 0.9), any static "fixed:<mutation>:<crossover>:<F>:<Cr>", or "grid" for the 42 of `GRID`.
`--reference` names the one whose Wilcoxon marks are printed (default lamde); with more than 6
configurators the summary is one line per configurator (`compact`). `--best-of SCAN` adds
"best-of-scan": on each map, the configurator with the lowest median score in the runs file SCAN
(`best_of`; its records name the one it ran as "chosen"); with `--first-seed` after the scan's
seeds it validates that per-map choice on held-out runs. `--jobs N` runs on N worker processes
(`planner_core.execution`); the records do not depend on it.

Maps: "validation" (generator seeds 8000 + k, disjoint from the suite's 2025 and the training
maps' 7000 + k; see planner_core.learning.policy.problems), "training" (the first `--count` training
maps, `default_training_specs`), "suite" (the 16 committed suite maps), or map files. Each run
is appended to a JSONL file as it finishes, so an interrupted validation resumes where it
stopped.

    python benchmarks/validate_policy.py --maps validation --runs 25 -o val.jsonl
    python benchmarks/validate_policy.py --maps suite --modes uniform --runs 25 -o suite.jsonl
    python benchmarks/validate_policy.py --maps suite --modes uniform --pipeline memetic \
        --configurators lamde random adaptive --runs 25 -o suite-memetic.jsonl
    python benchmarks/validate_policy.py --maps suite --modes uniform --pipeline planner \
        --configurators lamde random adaptive --runs 25 -o suite-planner.jsonl
    python benchmarks/validate_policy.py --maps suite --modes uniform --pipeline memetic \
        --configurators random adaptive lamde grid --reference random --runs 8 --jobs 2 \
        -o scan-memetic.jsonl
    python benchmarks/validate_policy.py --maps suite --modes uniform --pipeline memetic \
        --configurators random --best-of scan-memetic.jsonl --reference random \
        --first-seed 8 --runs 25 --jobs 2 -o heldout-memetic.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.bench._io import read_jsonl
from planner_core.bench.baselines.de import planner
from planner_core.bench.stats import wilcoxon_mark
from planner_core.execution import make_executor
from planner_core.learning.policy import PolicyConfigurator
from planner_core.learning.policy.problems import build, spec_name, validation_specs
from planner_core.model.problem import penalised_score
from planner_core.search.de import make_configurator, run
from planner_core.search.de.operators import MUTATIONS
from planner_core.search.init_modes import with_init

ROOT = Path(__file__).resolve().parent.parent
SUITE = ROOT / "examples" / "maps" / "suite"
#: evaluations per run and DE population unless told otherwise (docs/make_figures.py states them
#: in the titles of the figures drawn from this script's runs)
BUDGET = 10_000
POPULATION = 100
PIPELINES = ("de", "memetic", "repair", "planner")
#: the label of `--best-of`'s configurator: per map, the best of a scan's configurators
BEST_OF = "best-of-scan"
#: `--configurators grid`: static configurations, every mutation x (binomial Cr 0.9, binomial
#: Cr 0.2, exponential Cr 0.75: a block of ~4 genes, one hover point) x F 0.4, 0.8
GRID = tuple(f"fixed:{m}:{cx}:{F}:{cr}" for m in MUTATIONS
             for cx, cr in (("bin", 0.9), ("bin", 0.2), ("exp", 0.75)) for F in (0.4, 0.8))


def _specs(which: list[str], count: int) -> dict[str, dict[str, Any]]:
    """Problem specs (JSON-able, `planner_core.learning.policy.problems`) by map name."""
    if which == ["validation"]:
        return {spec_name(s): s for s in validation_specs(count)}
    if which == ["training"]:
        from planner_core.learning.policy.problems import default_training_specs

        return {spec_name(s): s for s in default_training_specs(count)}
    paths = sorted(SUITE.glob("T*.json")) if which == ["suite"] else [Path(p) for p in which]
    return {p.stem: {"kind": "map", "map": json.loads(p.read_text(encoding="utf-8"))}
            for p in paths}


def configurator(label: str, checkpoint: str) -> Any:
    """A configurator from its label: "lamde" (the policy `checkpoint`), a registry name
    ("adaptive", "random", "fixed"), or "fixed:<mutation>:<crossover>:<F>:<Cr>". Raises
    ValueError naming the label when it is none of these."""
    if label == "lamde":
        return PolicyConfigurator(checkpoint=checkpoint)
    if label.startswith("fixed:"):
        try:
            _, mutation, crossover, F, Cr = label.split(":")
            return make_configurator("fixed", mutation=mutation, crossover=crossover,
                                     F=float(F), Cr=float(Cr))
        except (ValueError, KeyError) as e:
            raise ValueError(f"configurator {label!r}: expected "
                             f"fixed:<mutation>:<crossover>:<F>:<Cr> ({e})") from None
    return make_configurator(label)


def run_pipeline(problem: Any, mode: str, pipeline: str, conf: Any, seed: int, budget: int,
                 population: int) -> Any:
    """One run of `conf` in `pipeline` (module docstring) from start `mode`; returns the
    optimiser's result (.f, .phi)."""
    if pipeline == "planner":
        return planner(with_init(problem, mode), budget, seed, configurator=conf)
    if pipeline == "memetic":
        return planner(with_init(problem, mode), budget, seed, configurator=conf, starts=0,
                       descent=False)
    refine = None
    if pipeline == "repair":
        from functools import partial

        from planner_core.search.refine import repair

        refine = partial(repair, problem)
    return run(with_init(problem, mode), configurator=conf, seed=seed, population=population,
               budget=budget, refine=refine)


_CACHE: dict[Any, Any] = {}


def _job(item: tuple[Any, ...]) -> dict[str, Any]:
    """Executor job: one run, as its JSONL record. The problem and the configurator are built
    once per worker process."""
    name, spec, mode, label, seed, pipeline, budget, population, checkpoint, chosen = item
    runs = chosen or label  # BEST_OF runs the configurator chosen for this map
    if ("p", name) not in _CACHE:
        _CACHE[("p", name)] = build(spec)
    if ("c", runs) not in _CACHE:
        _CACHE[("c", runs)] = configurator(runs, checkpoint)
    t0 = time.perf_counter()
    r = run_pipeline(_CACHE[("p", name)], mode, pipeline, _CACHE[("c", runs)], seed, budget,
                     population)
    rec = {"map": name, "mode": mode, "configurator": label, "seed": seed,
           "pipeline": pipeline, "f": r.f, "phi": r.phi,
           "score": float(penalised_score(r.f, r.phi)), "seconds": time.perf_counter() - t0}
    if chosen:
        rec["chosen"] = chosen
    if runs == "lamde":
        rec["checkpoint"] = checkpoint
    return rec


def best_of(records: list[dict[str, Any]], mode: str) -> dict[str, str]:
    """Per map, the configurator with the lowest median score among `records` of start `mode`
    (one pipeline's runs of a scan; earlier `BEST_OF` records are left out), on the seeds every
    configurator run on that map completed; ties go to the first label in sorted order. For
    `--best-of`: the per-map choice made on these runs, to be validated on other seeds."""
    recs = [r for r in records if r["mode"] == mode and r["configurator"] != BEST_OF]
    scores: dict[tuple[str, str], list[float]] = {}
    for name in sorted({r["map"] for r in recs}):
        own = [r for r in recs if r["map"] == name]
        for r in complete_seeds(own, sorted({r["configurator"] for r in own})):
            scores.setdefault((name, r["configurator"]), []).append(r["score"])
    best: dict[str, tuple[float, str]] = {}
    for (name, label), xs in sorted(scores.items()):
        med = float(np.median(xs))
        if name not in best or med < best[name][0]:
            best[name] = (med, label)
    return {name: label for name, (_, label) in best.items()}


def _read(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return read_jsonl(path)  # a .gz name: gzip-compressed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", nargs="+", default=["validation"],
                    help="validation, training, suite, or map files")
    ap.add_argument("--count", type=int, default=4,
                    help="maps (with --maps validation or training)")
    ap.add_argument("--runs", type=int, default=25)
    ap.add_argument("--modes", nargs="+", default=["seeded", "uniform"])
    ap.add_argument("--configurators", nargs="+", default=["lamde", "adaptive", "random", "fixed"],
                    help="lamde, adaptive, random, fixed, fixed:<mutation>:<crossover>:<F>:<Cr>, "
                    "or grid (the 42 static configurations of GRID)")
    ap.add_argument("--reference", default="lamde",
                    help="the configurator the Wilcoxon marks compare with every other one")
    ap.add_argument("--checkpoint", default="lamde-v2")
    ap.add_argument("--budget", type=int, default=BUDGET)
    ap.add_argument("--population", type=int, default=POPULATION)
    ap.add_argument("--pipeline", choices=PIPELINES, default="de",
                    help="de: the DE alone; memetic: the DE with the memetic step and the "
                    "polish LP, no constructive starts or descents; repair: the DE with the "
                    "memetic step's repair of an infeasible elite only; planner: what plan does")
    ap.add_argument("--jobs", type=int, default=0,
                    help="worker processes (0: runs in this process)")
    ap.add_argument("--first-seed", type=int, default=0,
                    help="the runs' seeds are FIRST_SEED .. FIRST_SEED + RUNS - 1")
    ap.add_argument("--best-of", metavar="SCAN",
                    help=f"add the configurator {BEST_OF!r}: on each map, the one with the "
                    "lowest median score in the runs file SCAN (same pipeline and start mode)")
    ap.add_argument("-o", "--output", required=True, help="JSONL of runs (appended, resumable)")
    args = ap.parse_args()
    if min(args.jobs, args.first_seed) < 0 or min(args.runs, args.count, args.budget,
                                                  args.population) < 1:
        ap.error("--jobs and --first-seed must be >= 0; --runs, --count, --budget and "
                 "--population >= 1")
    labels = list(dict.fromkeys(c for name in args.configurators
                                for c in (GRID if name == "grid" else (name,))))
    if BEST_OF in labels:
        ap.error(f"--configurators: {BEST_OF!r} is added by --best-of SCAN, not named")
    out = Path(args.output)
    chosen: dict[tuple[str, str], str] = {}
    if args.best_of:
        if Path(args.best_of).resolve() == out.resolve():
            ap.error("--best-of: the scan must not be the output file (its held-out runs would "
                     "change the choice)")
        scan = [r for r in _read(Path(args.best_of)) if r.get("pipeline", "de") == args.pipeline]
        for mode in args.modes:
            for name, label in best_of(scan, mode).items():
                chosen[name, mode] = label
        labels.append(BEST_OF)
        for r in _read(out):
            if (r.get("pipeline", "de") == args.pipeline and r["configurator"] == BEST_OF
                    and r.get("chosen") != chosen.get((r["map"], r["mode"]))):
                ap.error(f"--best-of: {out} holds {BEST_OF} runs of {r['map']} with "
                         f"{r.get('chosen')!r}; {args.best_of} now chooses "
                         f"{chosen.get((r['map'], r['mode']))!r} (a changed scan: write to a "
                         "new file)")
    if args.reference not in labels:
        ap.error(f"--reference: {args.reference!r} is not among --configurators")
    for label in dict.fromkeys([c for c in labels if c != BEST_OF] + list(chosen.values())):
        try:
            configurator(label, args.checkpoint)
        except ValueError as e:
            ap.error(str(e))
    done = {(r["map"], r["mode"], r["configurator"], r["seed"]) for r in _read(out)
            if r.get("pipeline", "de") == args.pipeline}
    specs = _specs(args.maps, args.count)
    missing = sorted({f"{name} ({mode})" for name in specs for mode in args.modes
                      if BEST_OF in labels and (name, mode) not in chosen})
    if missing:
        ap.error(f"--best-of: {args.best_of} has no {args.pipeline} runs of "
                 f"{', '.join(missing)}")
    seeds = range(args.first_seed, args.first_seed + args.runs)
    items = [(name, spec, mode, c, seed, args.pipeline, args.budget, args.population,
              args.checkpoint, chosen.get((name, mode)) if c == BEST_OF else None)
             for seed in seeds  # seeds outermost: a cut-short run has even counts
             for name, spec in specs.items() for mode in args.modes for c in labels
             if (name, mode, c, seed) not in done]
    with out.open("a") as fh, make_executor(args.jobs) as ex:
        for rec in ex.map_unordered(_job, items):
            fh.write(json.dumps(rec) + "\n")
            fh.flush()
    summarise([r for r in _read(out) if r.get("pipeline", "de") == args.pipeline],
              labels, args.reference)


def complete_seeds(records: list[dict[str, Any]], configurators: list[str]) -> list[dict[str, Any]]:
    """The records of the seeds that every (map, mode, configurator) cell has (a validation cut
    short keeps even counts), so that every Wilcoxon test compares the same seeds."""
    cells = {(r["map"], r["mode"], c) for r in records for c in configurators}
    have: dict[int, set] = {}
    for r in records:
        have.setdefault(r["seed"], set()).add((r["map"], r["mode"], r["configurator"]))
    keep = {s for s, got in have.items() if cells <= got}
    return [r for r in records if r["seed"] in keep and r["configurator"] in configurators]


def summarise(records: list[dict[str, Any]], configurators: list[str],
              reference: str = "lamde") -> None:
    """Print one table per start mode: mean score (feasible runs / runs) and the reference's
    marks against every other configurator, on the seeds complete for every cell. With more
    than `WIDE` configurators, one line per configurator instead (`compact`)."""
    others = [c for c in configurators if c != reference]
    records = complete_seeds(records, configurators)
    seeds = sorted({r["seed"] for r in records})
    print(f"complete seeds: {len(seeds)} ({', '.join(map(str, seeds))}), {len(records)} runs")
    if len(configurators) > WIDE:
        compact(records, configurators, reference)
        return
    for mode in sorted({r["mode"] for r in records}):
        for c in configurators:
            rs = [r for r in records if r["mode"] == mode and r["configurator"] == c]
            feas = sum(r["phi"] == 0 for r in rs)
            print(f"start mode {mode}: {c} feasible in {feas}/{len(rs)} runs "
                  f"({100 * feas / max(len(rs), 1):.1f} %)")
        print(f"\nstart mode {mode}: mean f + 10 phi (feasible/runs); mark = {reference} vs that "
              f"configurator ('+' {reference} significantly better, '-' worse, '~' no difference)")
        print("map".ljust(26) + "".join(c.rjust(26) for c in configurators))
        wins = {c: [0, 0, 0] for c in others}
        for name in sorted({r["map"] for r in records if r["mode"] == mode}):
            cells = []
            runs = {c: [r for r in records if r["map"] == name and r["mode"] == mode
                        and r["configurator"] == c] for c in configurators}
            scores = {c: [r["score"] for r in rs] for c, rs in runs.items()}
            for c in configurators:
                rs = runs[c]
                feas = sum(r["phi"] == 0 for r in rs)
                mark = ""
                if c != reference:
                    mark = wilcoxon_mark(scores[reference], scores[c])
                    if mark:
                        wins[c]["+-~".index(mark)] += 1
                cells.append(f"{np.mean(scores[c]) if rs else float('nan'):.1f} "
                             f"({feas}/{len(rs)}) {mark}".rjust(26))
            print(name.ljust(26) + "".join(cells))
        for c, (better, worse, same) in wins.items():
            print(f"{reference} vs {c}: significantly better on {better}, worse on {worse}, "
                  f"no difference on {same}")


#: above this many configurators `summarise` prints the compact form
WIDE = 6


def scan_rows(records: list[dict[str, Any]], configurators: list[str], reference: str,
              mode: str) -> list[tuple[float, str, int, int, list[str]]]:
    """Per configurator, best first, for start `mode`: (the geometric mean over the maps of its
    median score over the reference's: below 1 is better; medians, because one infeasible
    run's f + 10 phi would outweigh the rest of a mean; label; feasible runs; runs; the
    per-map `wilcoxon_mark` of it against the reference, "+" = it is significantly better)."""
    recs = [r for r in records if r["mode"] == mode]
    maps = sorted({r["map"] for r in recs})
    cell: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in recs:
        cell.setdefault((r["map"], r["configurator"]), []).append(r)
    rows = []
    for c in configurators:
        ratio = np.exp(np.mean([np.log(np.median([r["score"] for r in cell[m, c]])
                                       / np.median([r["score"] for r in cell[m, reference]]))
                                for m in maps]))
        marks = [wilcoxon_mark([r["score"] for r in cell[m, c]],
                               [r["score"] for r in cell[m, reference]]) for m in maps]
        feas = sum(r["phi"] == 0 for m in maps for r in cell[m, c])
        rows.append((float(ratio), c, feas, sum(len(cell[m, c]) for m in maps), marks))
    return sorted(rows)


def compact(records: list[dict[str, Any]], configurators: list[str], reference: str) -> None:
    """One line per configurator and start mode, best first (`scan_rows`): the geometric mean
    of its median score over the reference's, its feasible runs, and on how many maps it is
    significantly better / worse than the reference / no different."""
    for mode in sorted({r["mode"] for r in records}):
        maps = {r["map"] for r in records if r["mode"] == mode}
        print(f"\nstart mode {mode}, {len(maps)} maps: geometric mean of median f + 10 phi "
              f"over {reference}'s (< 1 better); feasible runs; maps significantly better / "
              f"worse than {reference} / no different")
        for row in scan_rows(records, configurators, reference, mode):
            print(scan_line(row))


def scan_line(row: tuple[float, str, int, int, list[str]]) -> str:
    """One `scan_rows` row as `compact` prints it (docs/policy.md quotes these lines)."""
    ratio, c, feas, runs, marks = row
    return (f"{c:36s} {ratio:6.3f}  feasible {feas:4d}/{runs:<4d} "
            f"({100 * feas / max(runs, 1):5.1f} %)  {marks.count('+'):2d} / "
            f"{marks.count('-'):2d} / {marks.count('~'):2d}")


if __name__ == "__main__":
    main()
