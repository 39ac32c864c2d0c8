"""Compare two policy checkpoints' validation runs map by map (Wilcoxon rank-sum on f + 10 phi).

Reads two JSONL files written by ``benchmarks/validate_policy.py`` (or the records committed
under ``docs/policy/``), takes the ``lamde`` records of one start mode and pipeline from each,
and prints per map both means, the mark of the candidate against the baseline ('+' candidate
significantly better, '-' worse, '~' no difference; alpha 0.05, two-sided,
`planner_core.bench.stats.wilcoxon_mark`) on the seeds both files have, and the totals.

    python benchmarks/compare_checkpoints.py candidate.jsonl docs/policy/suite-uniform.jsonl.gz
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from planner_core.bench._io import read_maybe_gz
from planner_core.bench.stats import wilcoxon_mark


def lamde_scores(path: Path, mode: str, pipeline: str) -> dict[str, dict[int, float]]:
    """map -> seed -> score of the ``lamde`` records of ``mode`` and ``pipeline`` in ``path``."""
    out: dict[str, dict[int, float]] = {}
    for line in read_maybe_gz(path).decode("utf-8").splitlines():  # .gz: compressed
        if not line.strip():
            continue
        r = json.loads(line)
        if (r["configurator"] == "lamde" and r["mode"] == mode
                and r.get("pipeline", "de") == pipeline):
            out.setdefault(r["map"], {})[int(r["seed"])] = float(r["score"])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("candidate", type=Path, help="JSONL with the candidate's lamde runs")
    ap.add_argument("baseline", type=Path, help="JSONL with the baseline's lamde runs")
    ap.add_argument("--mode", default="uniform", choices=("uniform", "seeded"))
    ap.add_argument("--pipeline", default="de", choices=("de", "planner"))
    args = ap.parse_args()
    cand = lamde_scores(args.candidate, args.mode, args.pipeline)
    base = lamde_scores(args.baseline, args.mode, args.pipeline)
    counts = {"+": 0, "-": 0, "~": 0}
    print(f"{'map':26}{'candidate':>12}{'baseline':>12}  mark  seeds")
    for name in sorted(set(cand) & set(base)):
        seeds = sorted(set(cand[name]) & set(base[name]))
        if not seeds:
            continue
        a = [cand[name][s] for s in seeds]
        b = [base[name][s] for s in seeds]
        mark = wilcoxon_mark(a, b)
        counts[mark] += 1
        print(f"{name:26}{np.mean(a):12.1f}{np.mean(b):12.1f}  {mark:>4}  {len(seeds)}")
    print(f"candidate vs baseline: significantly better on {counts['+']}, worse on "
          f"{counts['-']}, no difference on {counts['~']}")


if __name__ == "__main__":
    main()
