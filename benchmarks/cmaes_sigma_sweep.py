"""Issue 14's sigma0 sweep of the seeded CMA-ES peer (`cmaes-seeded-lp`).

Runs `cmaes-seeded-lp` with each initial step size sigma0 (in the unit box) as its own benchmark
entry `cmaes-seeded-lp-s<sigma0>` through `planner_core.bench.run_bench` (resumable, same seeds
for every sigma0, so the runs are paired; `<out>/meta.json` records each entry's sigma0), then
prints per map the mean penalised score f + 10 phi of each sigma0 and, per sigma0, its mean rank
over the maps (ties share their mean rank) and the number of maps where its mean is lowest (ties
all count).

    python benchmarks/cmaes_sigma_sweep.py --out /work/runs/sigma [--sigma0 0.01 0.02 0.05 0.1 0.2]
        [--tasks T02 T05 T07 T12 T16] [--runs 5] [--budget 10000] [--jobs 1]

The best-known file is never touched.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.stats import rankdata

from planner_core.bench.baselines import OptimiserSpec
from planner_core.model.formulas import penalised_score
from planner_core.textio import read_jsonl

ROOT = Path(__file__).resolve().parents[1]


def entry(sigma0: float) -> OptimiserSpec:
    """The benchmark entry of `cmaes-seeded-lp` with this sigma0."""
    return OptimiserSpec(
        f"cmaes-seeded-lp-s{sigma0:g}",
        "planner_core.bench.baselines.cmaes:optimise",
        f"cmaes-seeded-lp with sigma0 {sigma0:g} in the unit box (issue 14's sweep)",
        kwargs={"seeded": True, "sigma0": float(sigma0)},
    )


def table(results: Path, names: list[str]) -> tuple[list[str], dict[str, float]]:
    """Markdown lines of the per-map means and the mean rank of each entry."""
    score: dict[tuple[str, str], list[float]] = defaultdict(list)
    for r in read_jsonl(results):  # results.jsonl, or its .gz stored in its place
        if r.get("optimiser") in names and r.get("f") is not None:
            score[(r["task"], r["optimiser"])].append(
                penalised_score(float(r["f"]), float(r["phi"])))
    tasks = sorted({t for t, _ in score})
    lines = ["| map | " + " | ".join(n.removeprefix("cmaes-seeded-lp-") for n in names) + " |",
             "|" + "---|" * (len(names) + 1)]
    ranks: dict[str, list[float]] = defaultdict(list)
    best_count: dict[str, int] = defaultdict(int)
    for t in tasks:
        means = [float(np.mean(score[(t, n)])) if score[(t, n)] else np.nan for n in names]
        lowest = np.nanmin(means)
        for n, m, k in zip(names, means, rankdata(means, nan_policy="omit"), strict=True):
            ranks[n].append(float(k))  # ties share their mean rank
            best_count[n] += int(m == lowest)  # ties all count
        lines.append(f"| {t} | " + " | ".join(
            f"**{m:.2f}**" if m == lowest else f"{m:.2f}" for m in means) + " |")
    mean_rank = {n: float(np.mean(ranks[n])) for n in names}
    lines.append("")
    for n in names:
        lines.append(f"- {n}: mean rank {mean_rank[n]:.2f}, lowest mean on "
                     f"{best_count[n]}/{len(tasks)} maps")
    return lines, mean_rank


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--sigma0", type=float, nargs="+", default=[0.01, 0.02, 0.05, 0.1, 0.2])
    ap.add_argument("--tasks", nargs="+", default=["T02", "T05", "T07", "T12", "T16"])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--budget", type=int, default=10_000)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--suite", default=str(ROOT / "examples/maps/suite"))
    ap.add_argument("--table-only", action="store_true", help="print the table, run nothing")
    a = ap.parse_args()
    specs = [entry(s) for s in a.sigma0]
    names = [s.name for s in specs]
    if not a.table_only:
        from planner_core.bench.runner import run_bench

        run_bench(a.suite, names, runs=a.runs, budget=a.budget, out=a.out, tasks=a.tasks,
                  jobs=a.jobs, base_seed=a.seed, best_known=False, extra=specs,
                  command="python benchmarks/cmaes_sigma_sweep.py", log=print)
    lines, _ = table(a.out / "results.jsonl", names)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
