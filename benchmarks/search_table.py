"""Issue 14's comparison table: per-map means of the planner vs its peers, Wilcoxon, gap.

Reads one or more bench results files (`lamde-mission bench ... --out DIR` writes
DIR/results.jsonl) and prints a Markdown table: per task, each optimiser's mean penalised score
f + 10 phi over its runs, feasible runs, and for every peer the two-sided Wilcoxon signed-rank p
of the planner against it, paired by run seed (same seed = same seeded start); then the planner's
gap to the best-known f of the runs' suite: `--best-known F`, else the best-known file beside the
suite the first results file's meta.json records (`bench --suite examples/maps/large` ->
examples/maps/large_best_known.json; entries of a changed map left out), else
examples/maps/suite_best_known.json. The file used is printed, and a map without a best-known f
is named (its gap "no best-known", left out of the within-1 % count).

    python benchmarks/search_table.py results/results.jsonl [...] [--planner planner]
        [--best-known F] [--init seeded|uniform] [--runs N] [--optimizers A B ...] [--gaps]

A name ending in .gz is read gzip-compressed (the records kept under docs/ are).
`--init` keeps only the runs of that start mode (a results file of `bench --init both` holds
both, with the same seeds). Several files are merged (a run recorded twice counts once).
A file given as `PATH:NAME,NAME=LABEL,...` contributes only those optimisers, each under its
LABEL when given (e.g.
`docs/search/seeded-25runs.jsonl.gz:planner,seed-lp,cmaes-seeded-lp=cmaes-s0.05` keeps an older
cmaes-seeded-lp as its own column).
`--runs N` keeps runs 0 .. N-1 of every optimiser (so entries with more runs on record are
compared on the same seeds), `--optimizers` only these columns (the planner always),
`--gaps` adds a row of every column's gap to the best-known below the table (mean over maps)
and a gap column per optimiser.

A gap is that of the mean score over all runs, infeasible ones penalised; an optimiser with no
feasible run on a map has no gap there ("-", as `lamde-mission report` shows a ratio without a
feasible run; its column keeps the count, e.g. "(0/25)"). Records with no run of the compared
optimiser (`--planner`, default planner) give the table of the optimisers they hold and a line
saying so, with no p values and no comparison lines.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.stats import wilcoxon

from planner_core.bench._io import read_maybe_gz
from planner_core.model.formulas import penalised_score

ROOT = Path(__file__).resolve().parents[1]


def _source(arg: str) -> tuple[Path, dict[str, str] | None]:
    """(file, {optimiser: label} to keep, or None for all) of a `PATH[:NAME[=LABEL],...]`."""
    if Path(arg).exists() or ":" not in arg:
        return Path(arg), None
    path, _, names = arg.rpartition(":")
    keep = {}
    for item in names.split(","):
        name, _, label = item.partition("=")
        keep[name] = label or name
    return Path(path), keep


def best_known_f(given: Path | None, first_results: Path) -> tuple[dict[str, float], str]:
    """The best-known f per task, and the line saying where it comes from.

    Args:
        given: `--best-known` (a file whose `tasks` map task -> {"f": ...}), or None: the file
            beside the suite that `first_results`' meta.json records (entries of a map file
            that changed since left out, `BestKnown.f_values`), else the default suite's.
        first_results: the first results file given.

    Returns:
        ({task: f}, "best-known: PATH ..."); {} with the line saying why when the file is
        missing.

    Raises:
        ValueError: an unreadable or malformed best-known file or meta.json (naming it).
    """
    from planner_core.bench.limits import BestKnown, best_known_path, suite_task_files
    from planner_core.bench.report import suite_of_results

    if given is None:
        suite = suite_of_results(first_results)
        if suite is not None:
            path = best_known_path(suite)
            if not path.exists():
                return {}, f"best-known: {path} (the runs' suite {suite}, from meta.json) " \
                    "does not exist"
            return (BestKnown(path).f_values(suite_task_files(suite)),
                    f"best-known: {path} (the runs' suite {suite}, from meta.json)")
        given = ROOT / "examples/maps/suite_best_known.json"
        how = "the default suite's: no meta.json with a suite beside the first results file"
    else:
        how = "--best-known"
    if not given.exists():
        return {}, f"best-known: {given} ({how}) does not exist"
    data = json.loads(given.read_text())
    tasks = data.get("tasks") if isinstance(data, dict) else None
    if not isinstance(tasks, dict):
        raise ValueError(f"{given}: no \"tasks\" object")
    out = {t: float(e["f"]) for t, e in tasks.items() if isinstance(e, dict) and "f" in e}
    return out, f"best-known: {given} ({how})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="+", help="results JSONL, optionally PATH:NAME[=LABEL],...")
    ap.add_argument("--planner", default="planner",
                    help="the optimiser compared with every other, its first column (default "
                    "planner)")
    ap.add_argument("--best-known", type=Path, default=None,
                    help="best-known file (default: beside the suite in the runs' meta.json, "
                    "else examples/maps/suite_best_known.json)")
    ap.add_argument("--init", choices=("seeded", "uniform"), default=None,
                    help="only the runs of this start mode (default: all runs)")
    ap.add_argument("--runs", type=int, default=None, help="only runs 0 .. N-1")
    ap.add_argument("--optimizers", nargs="+", default=None, help="only these columns")
    ap.add_argument("--gaps", action="store_true",
                    help="a gap-to-best-known column per optimiser")
    a = ap.parse_args()
    runs: dict[tuple[str, str], dict[int, float]] = defaultdict(dict)
    feasible: dict[tuple[str, str], dict[int, bool]] = defaultdict(dict)
    for arg in a.results:
        path, keep = _source(arg)
        for line in read_maybe_gz(path).decode("utf-8").splitlines():  # .gz: compressed
            if not line.strip():
                continue
            r = json.loads(line)
            if "f" not in r or r.get("f") is None:
                continue
            if keep is not None:
                if r["optimiser"] not in keep:
                    continue
                r["optimiser"] = keep[r["optimiser"]]
            if a.init is not None and r.get("init", "seeded") != a.init:
                continue
            if a.runs is not None and "run" in r and int(r["run"]) >= a.runs:
                continue
            if (a.optimizers is not None and r["optimiser"] != a.planner
                    and r["optimiser"] not in a.optimizers):
                continue
            key = (r["task"], r["optimiser"])
            runs[key][int(r["seed"])] = penalised_score(float(r["f"]), float(r["phi"]))
            feasible[key][int(r["seed"])] = r["phi"] == 0.0
    feas = {k: sum(v.values()) for k, v in feasible.items()}
    try:
        best, source = best_known_f(a.best_known, _source(a.results[0])[0])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        sys.exit(f"search_table: best-known: {exc}")
    tasks = sorted({t for t, _ in runs})
    held = sorted({o for _, o in runs})
    compared = a.planner in held  # else nothing to compare: no p values, no comparison lines
    opts = [a.planner] + [o for o in held if o != a.planner] if compared else held
    peers = opts[1:] if compared else []
    gap_cols = opts if a.gaps else [a.planner] if compared else []
    head = ["map", *(f"{o}" for o in opts), *(f"p vs {o}" for o in peers),
            *(f"gap {o}" if a.gaps else "gap to best-known" for o in gap_cols)]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    wins: dict[str, int] = defaultdict(int)
    within: dict[str, int] = defaultdict(int)
    sig_better: dict[str, int] = defaultdict(int)
    sig_worse: dict[str, int] = defaultdict(int)
    infeasible: dict[str, list[str]] = defaultdict(list)  # maps without a feasible run
    for t in tasks:
        cells = [t]
        for o in opts:
            v = list(runs[(t, o)].values())
            cells.append(f"{np.mean(v):.2f} ({feas[(t, o)]}/{len(v)})" if v else "-")
        mine = runs[(t, a.planner)]
        for o in peers:
            other = runs[(t, o)]
            seeds = sorted(set(mine) & set(other))
            x = np.array([mine[s] for s in seeds])
            y = np.array([other[s] for s in seeds])
            if len(seeds) and np.mean(x) < np.mean(y):
                wins[o] += 1
            if len(seeds) < 2 or np.all(x == y):
                cells.append("-")
                continue
            p = wilcoxon(x, y).pvalue
            if p < 0.05:
                (sig_better if np.mean(x) < np.mean(y) else sig_worse)[o] += 1
            cells.append(f"{p:.3g}{' *' if p < 0.05 and np.mean(x) < np.mean(y) else ''}")
        bk = best.get(t)
        for o in gap_cols:
            v = list(runs[(t, o)].values())
            m = np.mean(v) if v else np.nan
            if not bk:
                cells.append("no best-known")
                continue
            if v and not feas[(t, o)]:  # penalised scores only: no gap, as `report` says it
                cells.append("-")
                infeasible[o].append(t)
                continue
            gap = 100 * (m - bk) / bk
            within[o] += int(bool(np.isfinite(gap) and gap <= 1.0))
            cells.append(f"{gap:+.2f} %" if np.isfinite(gap) else "-")
        print("| " + " | ".join(cells) + " |")
    print()
    print(f"- {source}")
    unknown = [t for t in tasks if not best.get(t)]
    if unknown and gap_cols:
        print(f"- no best-known f for {', '.join(unknown)} ({len(unknown)}/{len(tasks)} maps): "
              "no gap, not counted below; give --best-known FILE, or run `bench` with its "
              "best-known update on")
    known = len(tasks) - len(unknown)
    if not compared:
        mode = f" of start mode {a.init}" if a.init else ""
        print(f"- no runs of {a.planner} (the optimiser compared with the others, --planner) "
              f"in these records{mode}: nothing compared; "
              + (f"they hold {', '.join(held)}: give --planner NAME to compare one of them "
                 "with the others" if held else "they hold no runs"))
    for o in gap_cols:
        if infeasible[o]:
            print(f"- gap \"-\" for {o} on {', '.join(infeasible[o])}: no feasible run (its "
                  "mean is of penalised scores only; its column counts the feasible runs)")
    for o in peers:
        print(f"- {a.planner} has the lower mean than {o} on {wins[o]}/{len(tasks)} maps "
              f"(p < 0.05: better on {sig_better[o]}, worse on {sig_worse[o]})")
    for o in gap_cols:
        print(f"- {o}'s mean is within 1 % of the best-known on {within[o]}/{known} maps"
              + (f" with a best-known ({len(unknown)} without)" if unknown else "")
              + (f" (no gap on {len(infeasible[o])}: no feasible run)" if infeasible[o] else ""))


if __name__ == "__main__":
    main()
