"""Two benchmark record files of one optimiser, map by map: is the new one better?

Reads two `results.jsonl` of `lamde-mission bench` (e.g. the `planner` entry run by two
checkouts of this project with the same command, so with the same seeds) and prints, per map
and start mode, the mean gap to the best-known f (of the suite: `--suite`, else the one OLD's
meta.json records, then NEW's, else examples/maps/suite; its `<suite>_best_known.json`; an
infeasible run scores f + 10 phi; a map without a best-known f gets "-" gaps and is named, its
marks from the scores), the paper's two-sided Wilcoxon rank-sum mark on the scores
(`planner_core.bench.stats.wilcoxon_mark`, alpha 0.05: "+" new significantly better, "-"
significantly worse, "~" neither), the paired comparison (runs with the same seed where
new < old) and the paired Wilcoxon signed-rank mark on the same-seed differences (two-sided,
alpha 0.05; zero differences dropped, `scipy.stats.wilcoxon`): the two files run the same seeds,
so the signed-rank test pairs each run with its own. Then the verdict against issue 30's target
(lower mean gap, significantly, on at least 3/4 of the maps compared, 12 of the 16 suite maps,
and significantly worse on none, in every start mode) by each test; the exit status follows the
paired test.

    python benchmarks/compare_runs.py OLD/results.jsonl NEW/results.jsonl [--optimiser planner]

(either file may be gzip-compressed, `.jsonl.gz`, as the records kept in docs/search/ are).
"""

from __future__ import annotations

import argparse
import math
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


def needed(maps: int) -> int:
    """Maps that must be significantly better to meet the target: 3/4 of those compared,
    rounded up (12 of the suite's 16, as issue 30 set it).

    Args:
        maps: maps compared in a start mode.

    Returns:
        ceil(0.75 maps), at least 1.
    """
    return max(1, math.ceil(0.75 * maps))


def compare(old: list[dict[str, Any]], new: list[dict[str, Any]], best: dict[str, float],
            ) -> tuple[list[str], dict[str, tuple[int, int, int, int]],
                       dict[str, tuple[int, int]]]:
    """Table lines; per start mode (maps significantly better by rank-sum, maps with a lower
    mean gap, maps significantly worse by rank-sum, maps compared); per start mode (maps
    significantly better, significantly worse) by the paired signed-rank test. A map without
    a best-known f (not in `best`) is compared on its scores (the marks and counts are the
    same as on gaps, which only shift and scale the scores) and its gaps print as "-"."""
    from planner_core.bench.stats import wilcoxon_mark

    lines = ["mode     task  runs  gap old %  gap new %  rank-sum  paired better  signed-rank"]
    counts: dict[str, tuple[int, int, int, int]] = {}
    paired_counts: dict[str, tuple[int, int]] = {}
    for mode in sorted({r["init"] for r in old} & {r["init"] for r in new}):
        sig = lower = worse = psig = pworse = maps = 0
        for task in sorted({r["task"] for r in old if r["init"] == mode}):
            a = {r["seed"]: r for r in old if r["init"] == mode and r["task"] == task}
            b = {r["seed"]: r for r in new if r["init"] == mode and r["task"] == task}
            seeds = sorted(a.keys() & b.keys())
            if not seeds:
                continue
            maps += 1
            fb = best.get(task)
            if fb:
                ga = [100.0 * (a[s]["score"] - fb) / fb for s in seeds]
                gb = [100.0 * (b[s]["score"] - fb) / fb for s in seeds]
            else:  # no best-known: the scores themselves (same ranks, same marks)
                ga = [float(a[s]["score"]) for s in seeds]
                gb = [float(b[s]["score"]) for s in seeds]
            mark = wilcoxon_mark(gb, ga)  # "+": new (the reference here) better than old
            paired = sum(b[s]["score"] < a[s]["score"] for s in seeds)
            pmark = signed_rank_mark(gb, ga)
            psig += pmark == "+"
            pworse += pmark == "-"
            ma, mb = statistics.fmean(ga), statistics.fmean(gb)
            sig += mark == "+"
            lower += mb < ma
            worse += mark == "-"
            gaps = f"{ma:9.4f}  {mb:9.4f}" if fb else f"{'-':>9}  {'-':>9}"
            lines.append(f"{mode:<8} {task:<5} {len(seeds):>4}  {gaps}  "
                         f"{mark:>8}  {paired:>5}/{len(seeds)}  {pmark:>11}")
        counts[mode] = (sig, lower, worse, maps)
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
    ap.add_argument("--suite", default=None,
                    help="map folder whose best-known file gives the gaps (default: the suite "
                    "OLD's, else NEW's meta.json records, else examples/maps/suite)")
    args = ap.parse_args(argv)
    from planner_core.bench.report import suite_of_results
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
    try:
        if args.suite is not None:
            suite, how = Path(args.suite), "--suite"
        else:
            found = suite_of_results(args.old) or suite_of_results(args.new)
            suite, how = ((found, "the runs' meta.json") if found is not None
                          else (ROOT / "examples" / "maps" / "suite", "the default suite"))
        if not suite.is_dir():
            ap.error(f"suite {suite} ({how}): no such folder of map files")
        bk_path = best_known_path(suite)
        best = BestKnown(bk_path).f_values(suite_task_files(suite))
    except ValueError as exc:  # a malformed meta.json or best-known file, named
        ap.error(str(exc))
    lines, counts, paired = compare(old, new, best)
    print("\n".join(lines))
    print(f"best-known: {bk_path} (suite {suite}, {how})"
          + ("" if bk_path.exists() else ": no such file"))
    tasks = sorted({r["task"] for r in old} & {r["task"] for r in new})
    unknown = [t for t in tasks if not best.get(t)]
    if unknown:
        print(f"no best-known f for {', '.join(unknown)} (or its map changed since): gaps '-', "
              "marks from the scores")
    ok_rank = all(s >= needed(n) and w == 0 for s, _, w, n in counts.values())
    ok = all(s >= needed(counts[m][3]) and w == 0 for m, (s, w) in paired.items())
    sizes = sorted({n for *_, n in counts.values()})
    target = "; ".join(f">= {needed(n)}/{n} maps" for n in sizes)
    print(f"target (significantly better on {target} and worse on none, every mode): "
          f"by rank-sum {'met' if ok_rank else 'NOT met'}; by the paired signed-rank test "
          f"{'met' if ok else 'NOT met'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
