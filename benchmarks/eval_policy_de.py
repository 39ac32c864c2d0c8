"""A policy in the paper's DE-alone uniform protocol, against adaptive, random and lamde-v2.

The DE alone (population 100, no polish, variable-length encoding), uniform start, the given
budget, through the benchmark runner (``planner_core.bench.runner.run_bench``: the same run seeds
for every optimiser, so run r of two optimisers starts from the same population), on a map
folder: the 16 suite maps, or held-out generated maps written by ``--generate K`` (generator
seeds ``--map-seed`` + k, outside the training maps' 7000 + k and the validation maps' 8000 + k;
sizes alternate 5 km / 10 km, densities cycle 0..7). The new checkpoint runs as the benchmark
entry ``--name`` (``planner_core.bench.baselines.policy_spec``); the others are the registry's
``de-adaptive``, ``de-random`` and ``de-lamde`` (the shipped default ``lamde-v2``).

Printed: per task the mean penalised score f + 10 phi of each optimiser and the new policy's
marks against each other one, both as the results page's Table 2 (rank-sum, alpha 0.05,
``planner_core.bench.stats.wilcoxon_mark``) and paired (Wilcoxon signed-rank over the runs, same
seed pairs); then the (better / tie / worse) counts and one signed-rank test over all
(task, run) pairs of the score ratio new / other. Resumable: rerun the same command and only
missing runs run (``<out>/results.jsonl``).

    python benchmarks/eval_policy_de.py --checkpoint CKPT --runs 5 --out RUNS/suite
    python benchmarks/eval_policy_de.py --checkpoint CKPT --generate 12 --runs 3 \\
        --out RUNS/heldout
    python benchmarks/eval_policy_de.py --name de-lamde-v3 \\
        --records docs/policy/issue34-suite-uniform.jsonl.gz     # the stored report

Cost: runs x tasks x 4 DE runs of ``--budget`` evaluations (about 0.4-1 s each at 10,000 on
this machine's maps), linear in sensors and obstacles as the model's evaluation is.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

BASELINES = ("de-adaptive", "de-random", "de-lamde")


def write_heldout(folder: Path, count: int, seed: int) -> Path:
    """Write ``count`` generated maps (``G{k:02d}.json``) into ``folder``; returns it.

    Args:
        folder: output folder (created).
        count: maps; map k has size (5000, 10000)[k % 2], density (k // 2 + 3 (k % 2)) % 8 and
            generator seed ``seed + k``.
        seed: first generator seed.

    Returns:
        The folder. Raises ValueError from the generator for bad arguments.
    """
    from planner_core.suite import generate_map

    folder.mkdir(parents=True, exist_ok=True)
    for k in range(count):
        size, density = (5000, 10000)[k % 2], (k // 2 + 3 * (k % 2)) % 8
        data = generate_map(size, density, seed + k, name=f"G{k:02d}")
        path = folder / f"G{k:02d}.json"
        text = json.dumps(data, indent=1) + "\n"
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
    return folder


def scores(out: Path) -> dict[str, dict[str, dict[int, float]]]:
    """optimiser -> task -> run -> penalised score, from ``<out>/results.jsonl`` (``out`` a
    folder) or from a records file (``.jsonl`` or ``.jsonl.gz``, e.g. the stored
    ``docs/policy/issue34-*.jsonl.gz``)."""
    from planner_core.textio import read_jsonl

    res: dict[str, dict[str, dict[int, float]]] = {}
    path = out / "results.jsonl" if out.is_dir() else out
    for r in read_jsonl(path):
        if r.get("error"):
            continue
        res.setdefault(r["optimiser"], {}).setdefault(r["task"], {})[int(r["run"])] = float(
            r["score"])
    return res


def report(res: dict[str, dict[str, dict[int, float]]], name: str,
           baselines: tuple[str, ...] = BASELINES) -> str:
    """The table and tests of the module doc as text (``name`` against each of ``baselines``
    present in ``res``)."""
    from scipy.stats import wilcoxon

    from planner_core.bench.stats import wilcoxon_mark

    others = [o for o in baselines if o in res and o != name]
    tasks = sorted(res[name])
    lines = ["| task | " + " | ".join([name, *others]) + " | " + " | ".join(
        f"vs {o} (rank-sum / paired)" for o in others) + " |",
        "|---|" + "---:|" * (1 + len(others)) + "---|" * len(others)]
    counts = {o: {"rank": [0, 0, 0], "paired": [0, 0, 0]} for o in others}
    ratios: dict[str, list[float]] = {o: [] for o in others}
    for t in tasks:
        mine = res[name][t]
        row = [f"{np.mean(list(mine.values())):.1f}"]
        marks = []
        for o in others:
            theirs = {r: v for r, v in res[o].get(t, {}).items() if r in mine}
            row.append(f"{np.mean(list(theirs.values())):.1f}" if theirs else "")
            runs = sorted(set(mine) & set(theirs))
            a = np.array([mine[r] for r in runs])
            b = np.array([theirs[r] for r in runs])
            rank = wilcoxon_mark(a, b) if runs else ""
            paired = "~"
            if len(runs) >= 2 and np.any(a != b):
                p = wilcoxon(a, b).pvalue
                if p < 0.05:
                    paired = "+" if np.median(a - b) < 0 else "-"
            for kind, m in (("rank", rank), ("paired", paired)):
                counts[o][kind]["+~-".index(m) if m in "+~-" and m else 1] += 1
            ratios[o].extend((a / np.where(b == 0, 1.0, b)).tolist())
            marks.append(f"{rank} / {paired}")
        lines.append(f"| {t} | " + " | ".join(row + marks) + " |")
    lines.append("")
    for o in others:
        r = np.array(ratios[o])
        p = wilcoxon(r - 1.0).pvalue if np.any(r != 1.0) else 1.0
        lines.append(
            f"{name} vs {o}: better / tie / worse per task, rank-sum {tuple(counts[o]['rank'])}, "
            f"paired {tuple(counts[o]['paired'])}; over {len(r)} (task, run) pairs the mean "
            f"score ratio {name} / {o} is {r.mean():.4f} (median {np.median(r):.4f}, paired "
            f"signed-rank p = {p:.3g})")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """Command line (module doc). Exit 2 with one line for a bad argument."""
    from planner_core.bench.baselines import policy_spec
    from planner_core.bench.runner import run_bench

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--checkpoint", help="policy checkpoint (name or folder)")
    ap.add_argument("--name", default="de-lamde-new", help="benchmark name of the checkpoint")
    ap.add_argument("--suite", default="examples/maps/suite", help="map folder")
    ap.add_argument("--generate", type=int, default=0, metavar="K",
                    help="write K held-out generated maps to OUT/maps and run on them")
    ap.add_argument("--map-seed", type=int, default=9000, help="first generator seed (9000)")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--budget", type=int, default=10000)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0, help="base run seed")
    ap.add_argument("--baselines", default=",".join(BASELINES),
                    help="comma-separated registry entries to compare with")
    ap.add_argument("--out", help="results folder (resumable)")
    ap.add_argument("--records", help="only print the report of a stored records file")
    args = ap.parse_args(argv)
    if args.records:
        print(report(scores(Path(args.records)), args.name, tuple(args.baselines.split(","))))
        return
    if not args.out:
        ap.error("--out is required (or --records)")
    if not args.checkpoint:
        ap.error("--checkpoint is required (or --records)")
    if args.runs < 1 or args.generate < 0:
        ap.error("--runs must be >= 1 and --generate >= 0")
    out = Path(args.out)
    suite = write_heldout(out / "maps", args.generate, args.map_seed) if args.generate \
        else Path(args.suite)
    spec = policy_spec(args.name, str(args.checkpoint), description=f"policy {args.checkpoint}")
    s = run_bench(suite, [*args.baselines.split(","), args.name], runs=args.runs,
                  budget=args.budget, out=out, jobs=args.jobs, base_seed=args.seed,
                  best_known=False, inits=("uniform",), extra=[spec],
                  command="python benchmarks/eval_policy_de.py " + " ".join(argv or []))
    if s.failed:
        raise SystemExit(f"{len(s.failed)} run(s) failed, first: {s.failed[0]['error']}")
    print(report(scores(out), args.name, tuple(args.baselines.split(","))))


if __name__ == "__main__":
    main()
