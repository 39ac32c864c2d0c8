"""Two benchmark record files of one optimiser, map by map: is the new one better?

Reads two `results.jsonl` of `lamde-mission bench` (e.g. the `planner` entry run by two
checkouts of this project with the same command, so with the same seeds) and prints, per map
and start mode, the mean gap to the best-known f (`examples/maps/suite_best_known.json`; an
infeasible run scores f + 10 phi), the paper's two-sided Wilcoxon rank-sum mark on the scores
(`planner_core.bench.stats.wilcoxon_mark`, alpha 0.05: "+" new significantly better, "-"
significantly worse, "~" neither), the paired comparison (runs with the same seed where
new < old) and the paired Wilcoxon signed-rank mark on the same-seed differences (two-sided,
alpha 0.05; zero differences dropped, `scipy.stats.wilcoxon`): the two files run the same seeds,
so the signed-rank test pairs each run with its own. Then the verdict against issue 30's target
(lower mean gap on at least 12 of the 16 maps, significantly, and significantly worse on none,
in every start mode) by each test; the exit status follows the paired test.

    python benchmarks/compare_runs.py OLD/results.jsonl NEW/results.jsonl [--optimiser planner]

(either file may be gzip-compressed, `.jsonl.gz`, as the records kept in docs/search/ are).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def load(path: str, optimiser: str) -> list[dict[str, Any]]:
    """The records of `optimiser` in a results file."""
    from planner_core.bench._io import read_jsonl

    rows = read_jsonl(path)  # a .gz name: gzip-compressed, as the records docs/ keeps are
    return [r for r in rows if r.get("optimiser") == optimiser]


def signed_rank_mark(new: list[float], old: list[float], alpha: float = 0.05) -> str:
    """"+" / "-" / "~": are the paired scores `new` significantly lower / higher than `old`?
    The two-sided Wilcoxon signed-rank test at `alpha` on new - old (zero differences
    dropped), its direction from the one-sided test that rejects at alpha / 2; "~" also when
    every difference is zero."""
    from scipy.stats import wilcoxon

    if not any(b != a for a, b in zip(old, new, strict=True)):
        return "~"
    if wilcoxon(new, old, alternative="less").pvalue < alpha / 2:
        return "+"
    if wilcoxon(new, old, alternative="greater").pvalue < alpha / 2:
        return "-"
    return "~"


def compare(old: list[dict[str, Any]], new: list[dict[str, Any]], best: dict[str, float],
            ) -> tuple[list[str], dict[str, tuple[int, int, int]],
                       dict[str, tuple[int, int]]]:
    """Table lines; per start mode (maps significantly better by rank-sum, maps with a lower
    mean gap, maps significantly worse by rank-sum); per start mode (maps significantly better,
    significantly worse) by the paired signed-rank test."""
    from planner_core.bench.stats import wilcoxon_mark

    lines = ["mode     task  runs  gap old %  gap new %  rank-sum  paired better  signed-rank"]
    counts: dict[str, tuple[int, int, int]] = {}
    paired_counts: dict[str, tuple[int, int]] = {}
    for mode in sorted({r["init"] for r in old} & {r["init"] for r in new}):
        sig = lower = worse = psig = pworse = 0
        for task in sorted({r["task"] for r in old if r["init"] == mode}):
            a = {r["seed"]: r for r in old if r["init"] == mode and r["task"] == task}
            b = {r["seed"]: r for r in new if r["init"] == mode and r["task"] == task}
            seeds = sorted(a.keys() & b.keys())
            if not seeds:
                continue
            fb = best[task]
            ga = [100.0 * (a[s]["score"] - fb) / fb for s in seeds]
            gb = [100.0 * (b[s]["score"] - fb) / fb for s in seeds]
            mark = wilcoxon_mark(gb, ga)  # "+": new (the reference here) better than old
            paired = sum(b[s]["score"] < a[s]["score"] for s in seeds)
            pmark = signed_rank_mark(gb, ga)
            psig += pmark == "+"
            pworse += pmark == "-"
            ma, mb = statistics.fmean(ga), statistics.fmean(gb)
            sig += mark == "+"
            lower += mb < ma
            worse += mark == "-"
            lines.append(f"{mode:<8} {task:<5} {len(seeds):>4}  {ma:9.4f}  {mb:9.4f}  "
                         f"{mark:>8}  {paired:>5}/{len(seeds)}  {pmark:>11}")
        counts[mode] = (sig, lower, worse)
        paired_counts[mode] = (psig, pworse)
        lines.append(f"{mode}: new significantly better on {sig} maps, lower mean gap on "
                     f"{lower}, significantly worse on {worse}")
        lines.append(f"{mode}: paired signed-rank: new significantly better on {psig} maps, "
                     f"significantly worse on {pworse}")
    return lines, counts, paired_counts


def main(argv: list[str] | None = None) -> int:
    from planner_core.bench.limits import BestKnown, best_known_path, suite_task_files

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", help="results.jsonl of the reference (e.g. an earlier checkout)")
    ap.add_argument("new", help="results.jsonl to compare with it")
    ap.add_argument("--optimiser", default="planner",
                    help="the optimiser whose records are compared (default planner)")
    ap.add_argument("--suite", default=str(ROOT / "examples" / "maps" / "suite"),
                    help="map folder whose best-known file gives the gaps (default the suite)")
    args = ap.parse_args(argv)
    from planner_core.textio import stored_path

    for name, path in (("old", args.old), ("new", args.new)):
        if not stored_path(path).is_file():  # results.jsonl: or its .gz stored in its place
            ap.error(f"{name}: {path}: no such file (give a results.jsonl, or .jsonl.gz)")
    old, new = load(args.old, args.optimiser), load(args.new, args.optimiser)
    if not old or not new:
        ap.error(f"--optimiser: no {args.optimiser!r} records in "
                 f"{args.old if not old else args.new}")
    pairs = ({(r["init"], r["task"], r["seed"]) for r in old}
             & {(r["init"], r["task"], r["seed"]) for r in new})
    if not pairs:  # the comparison pairs each run with the other file's run of its seed
        seeds = sorted({r["seed"] for r in old}), sorted({r["seed"] for r in new})
        ap.error(f"no run in {args.new} has a run of the same start mode, task and seed in "
                 f"{args.old} to pair with (seeds {seeds[0][:5]} against {seeds[1][:5]}): "
                 "run both with the same --seed")
    budgets = ({int(r["budget"]) for r in old if "budget" in r},
               {int(r["budget"]) for r in new if "budget" in r})
    if budgets[0] != budgets[1]:  # the seeds pair runs whatever their budget: not comparable
        ap.error(f"the files ran other budgets ({sorted(budgets[0])} in {args.old}, "
                 f"{sorted(budgets[1])} in {args.new}): compare runs of one protocol")
    best = BestKnown(best_known_path(args.suite)).f_values(suite_task_files(args.suite))
    lines, counts, paired = compare(old, new, best)
    print("\n".join(lines))
    ok_rank = all(s >= 12 and w == 0 for s, _, w in counts.values())
    ok = all(s >= 12 and w == 0 for s, w in paired.values())
    print(f"target (significantly better on >= 12/16 maps and worse on none, every mode): "
          f"by rank-sum {'met' if ok_rank else 'NOT met'}; by the paired signed-rank test "
          f"{'met' if ok else 'NOT met'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
