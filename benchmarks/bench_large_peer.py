"""Issue 31: the planner against the `engineering` peer given the same wall time, large suite.

For each map of the large suite (`examples/maps/large`) and run r, the planner runs first
(`planner`, default budget, seeded start, seed `run_seed(seed, map, r)`: the plan of run r of
`lamde-mission bench --suite examples/maps/large --optimizers planner`), then the `engineering`
peer runs with that run's planner wall time as its clock (`engineering.optimise(...,
time_limit=)`: after its first round of candidates it builds more rounds from new seeds while
the time lasts; its first round alone may take longer). Both go through the benchmark's own
runner (`planner_core.bench.runner.execute`), so the records are `bench` records, with the peer
named `engineering-same-time` and its limit in `time_limit_s`.

Prints per map: feasible runs, mean f and mean wall of each, the mean gap of the planner below
the peer, the one-sided rank-sum p (Mann-Whitney U, planner lower) and the paired signed-rank p
(Wilcoxon, one-sided, pairs by run), and whether the planner is significantly lower (p < 0.05)
on every map.

    python benchmarks/bench_large_peer.py [--maps L01 L02 ...] [--runs 10] [--seed 0]
        [-o runs.jsonl]
    python benchmarks/bench_large_peer.py --summary runs.jsonl [...]

Runs one process (CPU-bound; run it under `nice`). `-o` appends each run as it ends, and a
file that already holds a (map, run) pair skips it, so an interrupted run resumes.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
LARGE = ROOT / "examples" / "maps" / "large"
PEER = "engineering-same-time"


def _read(paths: list[str]) -> list[dict[str, Any]]:
    """The records of bench JSON lines files (plain or .gz), in order."""
    from planner_core.bench._io import read_jsonl

    return [r for p in paths for r in read_jsonl(p)]


def run_pairs(maps: list[str], runs: int, seed: int, out: str | None) -> list[dict[str, Any]]:
    """Planner then peer for each map and run (module docstring); the records, old and new."""
    from planner_core.bench.baselines import OptimiserSpec, get
    from planner_core.bench.runner import Job, execute, read_map_file, run_seed

    done = _read([out]) if out and Path(out).exists() else []
    have = {(r["task"], r["run"], r["optimiser"]) for r in done}
    eng = get("engineering")
    records = list(done)
    for name in maps:
        content, sha = read_map_file(LARGE / f"{name}.json")
        for r in range(runs):
            if (name, r, PEER) in have:
                continue
            s = run_seed(seed, name, r)
            mine = execute(Job("planner", name, r, s, 10_000, content, sha))
            if "error" in mine:
                raise RuntimeError(f"{name} run {r}: planner: {mine['error']}")
            spec = OptimiserSpec(PEER, eng.target, eng.description,
                                 kwargs={**eng.kwargs, "time_limit": mine["wall_s"]},
                                 spends_budget=False, constructive=True)
            theirs = execute(Job(PEER, name, r, s, 10_000, content, sha, spec=spec))
            if "error" in theirs:
                raise RuntimeError(f"{name} run {r}: {PEER}: {theirs['error']}")
            theirs["time_limit_s"] = mine["wall_s"]
            for rec in (mine, theirs):
                rec = {k: v for k, v in rec.items() if k not in ("x", "history")}
                records.append(rec)
                if out:
                    with open(out, "a") as fh:
                        fh.write(json.dumps(rec) + "\n")
            print(f"{name} run {r}: planner f {mine['f']:.2f} in {mine['wall_s']:.1f} s, "
                  f"peer f {theirs['f']:.2f} in {theirs['wall_s']:.1f} s "
                  f"({theirs['evaluations']} plans)", file=sys.stderr, flush=True)
    return records


def summarise(records: list[dict[str, Any]]) -> tuple[str, bool]:
    """The table of the module docstring, and whether the planner is significantly lower on
    every map (both tests, p < 0.05, every run of both feasible)."""
    from scipy.stats import mannwhitneyu, wilcoxon

    lines = ["| map | runs | planner feasible | peer feasible | planner mean f | peer mean f "
             "| planner below peer % | planner s | peer s | rank-sum p | signed-rank p |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    ok = True
    for name in sorted({r["task"] for r in records}):
        mine = {r["run"]: r for r in records if r["task"] == name and r["optimiser"] == "planner"}
        theirs = {r["run"]: r for r in records if r["task"] == name and r["optimiser"] == PEER}
        runs = sorted(set(mine) & set(theirs))
        if not runs:
            continue
        a = [mine[k]["score"] for k in runs]
        b = [theirs[k]["score"] for k in runs]
        fa = sum(mine[k]["feasible"] for k in runs)
        fb = sum(theirs[k]["feasible"] for k in runs)
        p_rank = mannwhitneyu(a, b, alternative="less").pvalue
        p_pair = wilcoxon(a, b, alternative="less").pvalue if any(
            x != y for x, y in zip(a, b, strict=True)) else 1.0
        below = (1 - statistics.fmean(a) / statistics.fmean(b)) * 100
        ok &= p_rank < 0.05 and p_pair < 0.05 and fa == len(runs)
        lines.append(
            f"| {name} | {len(runs)} | {fa}/{len(runs)} | {fb}/{len(runs)} | "
            f"{statistics.fmean(a):.1f} | {statistics.fmean(b):.1f} | {below:.2f} | "
            f"{statistics.fmean(mine[k]['wall_s'] for k in runs):.1f} | "
            f"{statistics.fmean(theirs[k]['wall_s'] for k in runs):.1f} | {p_rank:.2g} | "
            f"{p_pair:.2g} |")
    lines.append(f"planner significantly lower than the peer at the same wall time on every map: "
                 f"{'yes' if ok else 'NO'}")
    return "\n".join(lines), ok


def main(argv: list[str] | None = None) -> int:
    """The command line (module docstring). Returns 0, 1 when the planner is not significantly
    lower on every map, 2 for bad arguments."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", nargs="+", help="large-suite maps (default all: L01..L08)")
    ap.add_argument("--runs", type=int, default=10, help="runs a map (10)")
    ap.add_argument("--seed", type=int, default=0, help="the benchmark's base seed (0)")
    ap.add_argument("-o", "--output", help="JSON lines file to append the runs to (resumes)")
    ap.add_argument("--summary", nargs="+", metavar="JSONL",
                    help="print the table of earlier records (plain or .gz) and exit")
    args = ap.parse_args(argv)
    if args.summary:
        table, ok = summarise(_read(args.summary))
        print(table)
        return 0 if ok else 1
    names = args.maps or sorted(p.stem for p in LARGE.glob("*.json"))
    bad = [m for m in names if not (LARGE / f"{m}.json").exists()]
    if bad or args.runs < 2:
        print(f"bench_large_peer: --maps: no such large map {bad}" if bad else
              "bench_large_peer: --runs: must be >= 2", file=sys.stderr)
        return 2
    table, ok = summarise(run_pairs(names, args.runs, args.seed, args.output))
    print(table)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
