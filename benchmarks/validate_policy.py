"""Validate a policy checkpoint: lamde vs adaptive vs random vs fixed, both start modes.

Runs each configurator on each map for R seeds and reports, per map and start mode, the mean
penalised score f + 10 phi (lower is better), the feasible runs, and the Wilcoxon rank-sum mark
of lamde against each other configurator ("+": lamde significantly better, "-": significantly
worse, "~": no significant difference; alpha 0.05, two-sided,
`planner_core.bench.stats.wilcoxon_mark`).

Pipelines (every configurator always gets the same one): "de" (default), the DE alone, no
memetic step, no polish: the configurators' own effect; "memetic", the DE with the memetic
step on the elite every 10 generations (from a uniform start: `memetic="auto"`, with its repair
of unserved sensors) and the hover-time LP on the final population's elite, no constructive
starts and no descents (`optimise(..., lp=True, memetic="auto")`: the DE still decides the
plan's structure, the repair makes it feasible); "planner", what `plan` does: the
benchmark's `planner` entry (`planner_core.baselines.REGISTRY["planner"]`, its keyword
arguments: constructive starts and their descents, the DE with the memetic step from a uniform
start, the hover-time LP on the final population's elite, the final plan's descent, structural
search and kicks) with the configurator under test. Records carry their pipeline; one JSONL
may hold both (records written before the planner entry had starts and descents are the
pipeline of their time).

Maps: "validation" (generator seeds 8000 + k, disjoint from the suite's 2025 and the training
maps' 7000 + k; see planner_core.policy.problems), "suite" (the 16 committed suite maps), or
map files. Each run is appended to a JSONL file as it finishes, so an interrupted validation
resumes where it stopped.

    python benchmarks/validate_policy.py --maps validation --runs 25 -o val.jsonl
    python benchmarks/validate_policy.py --maps suite --modes uniform --runs 25 -o suite.jsonl
    python benchmarks/validate_policy.py --maps suite --modes uniform --pipeline memetic \
        --configurators lamde random adaptive --runs 25 -o suite-memetic.jsonl
    python benchmarks/validate_policy.py --maps suite --modes uniform --pipeline planner \
        --configurators lamde random adaptive --runs 25 -o suite-planner.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.baselines import REGISTRY
from planner_core.baselines.de import optimise
from planner_core.bench.stats import wilcoxon_mark
from planner_core.de import make_configurator, run
from planner_core.policy import PolicyConfigurator
from planner_core.policy.problems import build, spec_name, validation_specs
from planner_core.problem import Problem, penalised_score
from planner_core.starts import with_init

ROOT = Path(__file__).resolve().parent.parent
SUITE = ROOT / "examples" / "maps" / "suite"
#: evaluations per run and DE population unless told otherwise (docs/make_figures.py states them
#: in the titles of the figures drawn from this script's runs)
BUDGET = 10_000
POPULATION = 100


def _maps(which: list[str], count: int) -> dict[str, Any]:
    if which == ["validation"]:
        return {spec_name(s): build(s) for s in validation_specs(count)}
    if which == ["suite"]:
        return {p.stem: Problem(p) for p in sorted(SUITE.glob("T*.json"))}
    return {Path(p).stem: Problem(p) for p in which}


def _read(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", nargs="+", default=["validation"])
    ap.add_argument("--count", type=int, default=4, help="validation maps (with --maps validation)")
    ap.add_argument("--runs", type=int, default=25)
    ap.add_argument("--modes", nargs="+", default=["seeded", "uniform"])
    ap.add_argument("--configurators", nargs="+", default=["lamde", "adaptive", "random", "fixed"])
    ap.add_argument("--checkpoint", default="lamde-v2")
    ap.add_argument("--budget", type=int, default=BUDGET)
    ap.add_argument("--population", type=int, default=POPULATION)
    ap.add_argument("--pipeline", choices=("de", "memetic", "planner"), default="de",
                    help="de: the DE alone; memetic: the DE with the memetic step and the "
                    "polish LP, no constructive starts or descents; planner: what plan does")
    ap.add_argument("-o", "--output", required=True, help="JSONL of runs (appended, resumable)")
    args = ap.parse_args()
    out = Path(args.output)
    done = {(r["map"], r["mode"], r["configurator"], r["seed"]) for r in _read(out)
            if r.get("pipeline", "de") == args.pipeline}
    maps = _maps(args.maps, args.count)
    confs = {c: (PolicyConfigurator(checkpoint=args.checkpoint) if c == "lamde"
                 else make_configurator(c)) for c in args.configurators}
    with out.open("a") as fh:
        for seed in range(args.runs):  # seeds outermost: a cut-short run has even counts
            for name, problem in maps.items():
                for mode in args.modes:
                    for c, conf in confs.items():
                        if (name, mode, c, seed) in done:
                            continue
                        t0 = time.perf_counter()
                        if args.pipeline == "planner":
                            kw = {**REGISTRY["planner"].kwargs, "configurator": conf}
                            r = optimise(with_init(problem, mode), args.budget, seed, **kw)
                        elif args.pipeline == "memetic":
                            r = optimise(with_init(problem, mode), args.budget, seed,
                                         configurator=conf, lp=True, memetic="auto")
                        else:
                            r = run(with_init(problem, mode), configurator=conf, seed=seed,
                                    population=args.population, budget=args.budget)
                        rec = {"map": name, "mode": mode, "configurator": c, "seed": seed,
                               "pipeline": args.pipeline, "f": r.f, "phi": r.phi,
                               "score": float(penalised_score(r.f, r.phi)),
                               "seconds": time.perf_counter() - t0}
                        fh.write(json.dumps(rec) + "\n")
                        fh.flush()
    summarise([r for r in _read(out) if r.get("pipeline", "de") == args.pipeline],
              args.configurators)


def complete_seeds(records: list[dict[str, Any]], configurators: list[str]) -> list[dict[str, Any]]:
    """The records of the seeds that every (map, mode, configurator) cell has (a validation cut
    short keeps even counts), so that every Wilcoxon test compares the same seeds."""
    cells = {(r["map"], r["mode"], c) for r in records for c in configurators}
    have: dict[int, set] = {}
    for r in records:
        have.setdefault(r["seed"], set()).add((r["map"], r["mode"], r["configurator"]))
    keep = {s for s, got in have.items() if cells <= got}
    return [r for r in records if r["seed"] in keep and r["configurator"] in configurators]


def summarise(records: list[dict[str, Any]], configurators: list[str]) -> None:
    """Print one table per start mode: mean score (feasible runs / runs) and lamde's marks,
    on the seeds complete for every cell."""
    others = [c for c in configurators if c != "lamde"]
    records = complete_seeds(records, configurators)
    seeds = sorted({r["seed"] for r in records})
    print(f"complete seeds: {len(seeds)} ({', '.join(map(str, seeds))}), {len(records)} runs")
    for mode in sorted({r["mode"] for r in records}):
        for c in configurators:
            rs = [r for r in records if r["mode"] == mode and r["configurator"] == c]
            feas = sum(r["phi"] == 0 for r in rs)
            print(f"start mode {mode}: {c} feasible in {feas}/{len(rs)} runs "
                  f"({100 * feas / max(len(rs), 1):.1f} %)")
        print(f"\nstart mode {mode}: mean f + 10 phi (feasible/runs); mark = lamde vs that "
              "configurator ('+' lamde significantly better, '-' worse, '~' no difference)")
        print("map".ljust(26) + "".join(c.rjust(26) for c in configurators))
        wins = {c: [0, 0, 0] for c in others}
        for name in sorted({r["map"] for r in records if r["mode"] == mode}):
            cells = []
            scores: dict[str, list[float]] = {}
            for c in configurators:
                rs = [r for r in records if r["map"] == name and r["mode"] == mode
                      and r["configurator"] == c]
                scores[c] = [r["score"] for r in rs]
                feas = sum(r["phi"] == 0 for r in rs)
                mark = ""
                if c != "lamde" and "lamde" in scores:
                    mark = wilcoxon_mark(scores["lamde"], scores[c])
                    if mark:
                        wins[c]["+-~".index(mark)] += 1
                cells.append(f"{np.mean(scores[c]) if rs else float('nan'):.1f} "
                             f"({feas}/{len(rs)}) {mark}".rjust(26))
            print(name.ljust(26) + "".join(cells))
        for c, (better, worse, same) in wins.items():
            print(f"lamde vs {c}: significantly better on {better}, worse on {worse}, "
                  f"no difference on {same}")


if __name__ == "__main__":
    main()
