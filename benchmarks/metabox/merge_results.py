"""Merge MetaBox runs (run_metabox.py's results.jsonl) with a benchmark folder, for the report.

Run with the PROJECT's interpreter. Writes a new folder OUT: OUT/results.jsonl = the benchmark's
records + the MetaBox records whose key (optimiser, task, run, init, i_max) the benchmark does
not already hold, and OUT/meta.json = the benchmark's meta.json + a description of each MetaBox
agent (the report's "What it is" column) + this command. Neither input is modified; OUT must not
exist yet. Then:

    python benchmarks/metabox/merge_results.py --results results \\
        --metabox docs/metabox/results.jsonl.gz --out results-with-metabox
    lamde-mission report results-with-metabox -o docs/results.md --reference de-lamde

Bad input: one line naming the problem, exit status 2, nothing written.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from planner_core.atomic import write_text_atomic
from planner_core.bench._io import dumps_json, read_json
from planner_core.bench.records import RESULTS_FILE, key_of, read_records
from planner_core.bench.runner import META_FILE

#: the report's description of each MetaBox-v2 agent (run_metabox.py's names)
DESCRIPTIONS = {
    "rlde-afl": "MetaBox-v2 RLDE-AFL, its pretrained bbob-10D checkpoint (PPO-controlled DE "
                "operators and parameters, population 100), out of process, uniform start",
    "gleet": "MetaBox-v2 GLEET, its pretrained bbob-10D checkpoint (PPO-controlled PSO "
             "exploration-exploitation, population 100), out of process, uniform start",
    "lde": "MetaBox-v2 LDE, its pretrained bbob-10D checkpoint (LSTM-controlled DE F and CR, "
           "population 50), out of process, uniform start",
}


def merge(results: Path, metabox: Path, out: Path, command: str = "") -> tuple[int, int]:
    """Write OUT (see the module doc); return (records taken from MetaBox, skipped as already
    present). Raises ValueError on bad input (no records, budgets that differ, OUT exists)."""
    if out.exists():
        raise ValueError(f"--out: {out} exists; give a new folder")
    ours = read_records(results / RESULTS_FILE)
    theirs = read_records(metabox)
    if not ours.records:
        raise ValueError(f"--results: no records in {results / RESULTS_FILE}")
    if not theirs.records:
        raise ValueError(f"--metabox: no records in {metabox}")
    meta = read_json(results / META_FILE)
    budgets = {int(r["budget"]) for r in ours.records + theirs.records}
    if len(budgets) > 1:
        raise ValueError(f"--metabox: budgets {sorted(budgets)} differ from the benchmark's")
    have = {key_of(r) for r in ours.records}
    new = [r for r in theirs.records if key_of(r) not in have]
    lines = [json.dumps(r) for r in ours.records + new]
    entries = meta.setdefault("optimisers", {})
    for name in sorted({r["optimiser"] for r in new}):
        entries.setdefault(name, {"description": DESCRIPTIONS.get(
            name, "run out of process through benchmarks/metabox/evaluator_server.py")})
    if command:
        meta.setdefault("commands", []).append({"command": command})
    out.mkdir(parents=True)
    write_text_atomic(out / RESULTS_FILE, "\n".join(lines) + "\n")
    write_text_atomic(out / META_FILE, dumps_json(meta) + "\n")
    return len(new), len(theirs.records) - len(new)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", required=True, help="benchmark folder (results.jsonl, meta.json)")
    ap.add_argument("--metabox", required=True,
                    help="run_metabox.py's results.jsonl (a .gz name: compressed)")
    ap.add_argument("--out", required=True, help="new folder for the merged benchmark")
    a = ap.parse_args(argv)
    argv_used = sys.argv[1:] if argv is None else argv
    try:
        n, skipped = merge(Path(a.results), Path(a.metabox), Path(a.out),
                           shlex.join(["python", "benchmarks/metabox/merge_results.py",
                                       *argv_used]))
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{a.out}: {n} MetaBox record(s) added, {skipped} already present")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
