"""Keep a study's runs in the repository, small (issue 16): the I_max study and the ablations.

    python benchmarks/store_runs.py SRC DST

SRC is a benchmark folder (`lamde-mission bench --out SRC`, or `benchmarks/ablations.py --out
SRC`); DST gets its records cut to what the report's tables read (a few hundred bytes a run
instead of 3-6 kB) and its meta.json, with the ablation variants' policy checkpoints copied in
(`planner_core.bench.store`). Then `lamde-mission report RESULTS ... --imax DST` or
`--ablations DST` puts the study's tables and figures in the report, and
`python docs/make_figures.py` redraws its figures from DST.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from planner_core.bench.store import store_runs  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("src", type=Path, help="benchmark folder (with results.jsonl)")
    ap.add_argument("dst", type=Path, help="folder to write the slim copy to")
    args = ap.parse_args(argv)
    try:
        n = store_runs(args.src, args.dst)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"stored {n} run(s) of {args.src} in {args.dst}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
