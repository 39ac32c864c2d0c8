"""Refresh the suite's best-known plans from benchmark records, each checked by the simulator.

Issue 14: the best-known f per map (examples/maps/suite_best_known.json) is to be refreshed with
the peers' best plans and with long (1,000,000-evaluation) runs of the planner. `bench` itself
stores a run that beats the best-known after checking it with the optimiser's own model
(`planner_core.bench.limits.BestKnown.offer`); this script adds the independent check: a plan is
offered only when the simulator (`sim.replay` of its MAVLink mission + `sim.verify`: shapely
geometry, the sim's own kinematics and data model) passes all of C1-C5 and ENDS and its f agrees
with the model's within `--f-tol` (relative). Records come from `bench --out DIR` results files
(DIR/results.jsonl, or the trimmed JSONL under docs/search/; any run budget, start mode; runs with
an I_max override are skipped).

    python benchmarks/refresh_best_known.py RESULTS.jsonl [...] [--suite examples/maps/suite]
        [--best-known examples/maps/suite_best_known.json] [--dry-run] [--check-stored]

Per task it tries the feasible records below the stored f, lowest first, and offers the first
that passes the sim; a stored plan that itself fails the sim (issue 14: 1,000,000-evaluation
plans that cut an obstacle by ~1e-9 m) is replaced by the best record that passes, whatever its
f. `--dry-run` only prints. `--check-stored` also replays every stored entry in
the sim and reports those that fail (it does not change them).

The best-known refresh with long planner runs (resumable: bench skips runs already in its folder;
rerun the same two commands after an interruption):

    lamde-mission bench --optimizers planner --budget 1000000 --runs 1 --jobs 1 \\
        --out results-bk1m --no-best-known-update
    python benchmarks/refresh_best_known.py results-bk1m/results.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from planner_core.bench._io import read_maybe_gz

ROOT = Path(__file__).resolve().parents[1]


def sim_check(map_path: Path, hover_points: Any, hover_times: Any) -> tuple[bool, float, str]:
    """(passed, the sim's f, failed verdicts) of a plan flown as its mission in the simulator."""
    from lamde_mission.items import plan_to_items
    from planner_core.model.mapio import load_map
    from sim import replay, verify

    m = load_map(map_path)
    plan = SimpleNamespace(hover_points=hover_points, hover_times=hover_times)
    v = verify(replay(plan_to_items(plan, m), m), m)
    return v.passed, float(v.f), ",".join(v.failed)


def candidates(paths: list[Path]) -> dict[str, list[dict[str, Any]]]:
    """Feasible records (no I_max override) per task, lowest f first."""
    out: dict[str, list[dict[str, Any]]] = {}
    for path in paths:
        for line in read_maybe_gz(path).decode("utf-8").splitlines():  # .gz: compressed
            if not line.strip():
                continue
            r = json.loads(line)
            if (not r.get("feasible") or r.get("i_max") is not None or r.get("f") is None
                    or not r.get("hover_points")):
                continue
            out.setdefault(r["task"], []).append(r)
    for recs in out.values():
        recs.sort(key=lambda r: float(r["f"]))
    return out


def refresh(paths: list[Path], suite: Path, best_known: Path, *, dry_run: bool = False,
            f_tol: float = 1e-6, command: str = "",
            log: Any = print) -> dict[str, dict[str, Any]]:
    """Offer each task's best sim-verified record to the best-known file; returns per task what
    happened: {"old": stored f or None, "new": f of the record offered or None, "optimiser",
    "stored": bool, "replaced_failing": bool, "rejected": [(optimiser, run, reason), ...] for
    records the sim refused}. A stored entry that itself fails the sim is replaced by the best
    record that passes, even if its f is higher (`replaced_failing`)."""
    from planner_core.bench.limits import BestKnown, suite_task_files

    files = suite_task_files(suite)
    bk = BestKnown(best_known)
    stored = bk.f_values(files)
    entries = bk.load()
    report: dict[str, dict[str, Any]] = {}
    for task, recs in sorted(candidates(paths).items()):
        if task not in files:
            log(f"{task}: not in {suite}, skipped")
            continue
        old = stored.get(task, math.inf)
        failing = False
        if task in stored:
            e = entries[task]
            ok, f_sim, failed = sim_check(files[task], e["hover_points"], e["hover_times"])
            failing = not ok or abs(f_sim - old) > f_tol * max(1.0, abs(old))
            if failing:
                log(f"{task}: the stored plan (f {old:.6g}, {e.get('optimiser')}) fails the sim "
                    f"({failed or f'sim f {f_sim:.9g}'}): replaced by the best record that passes")
        bar = math.inf if failing else old
        entry: dict[str, Any] = {"old": None if math.isinf(old) else old, "new": None,
                                 "optimiser": None, "stored": False,
                                 "replaced_failing": False, "rejected": []}
        report[task] = entry
        for r in recs:
            f = float(r["f"])
            if f >= bar:
                break
            ok, f_sim, failed = sim_check(files[task], r["hover_points"], r["hover_times"])
            if not ok or abs(f_sim - f) > f_tol * max(1.0, abs(f)):
                why = f"sim failed {failed}" if not ok else f"sim f {f_sim:.9g} != {f:.9g}"
                entry["rejected"].append((r["optimiser"], r.get("run"), why))
                log(f"{task}: {r['optimiser']} run {r.get('run')} f {f:.6g}: {why}; next")
                continue
            entry.update(new=f, optimiser=r["optimiser"])
            if not dry_run:
                entry["stored"] = bk.offer(
                    task, files[task], r["hover_points"], r["hover_times"],
                    optimiser=r["optimiser"], seed=r.get("seed"), budget=r.get("budget"),
                    run=r.get("run"), command=command or shlex.join(sys.argv),
                    replace=failing)
                entry["replaced_failing"] = failing and entry["stored"]
            log(f"{task}: {entry['old'] if entry['old'] is not None else '-'} -> {f:.6g} "
                f"({r['optimiser']}, budget {r.get('budget')}, run {r.get('run')}, sim f "
                f"{f_sim:.6g}){'' if entry['stored'] else ' [not stored]'}")
            break
    return report


def check_stored(suite: Path, best_known: Path, log: Any = print) -> list[str]:
    """Tasks whose stored best-known plan fails the sim (or whose sim f differs by > 1e-6)."""
    from planner_core.bench.limits import BestKnown, suite_task_files

    files = suite_task_files(suite)
    bad = []
    for task, e in sorted(BestKnown(best_known).load().items()):
        if task not in files:
            continue
        ok, f_sim, failed = sim_check(files[task], e["hover_points"], e["hover_times"])
        same = abs(f_sim - float(e["f"])) <= 1e-6 * max(1.0, abs(float(e["f"])))
        log(f"{task}: stored f {float(e['f']):.6g} ({e.get('optimiser')}), sim "
            f"{'PASS' if ok else 'FAIL ' + failed}, sim f {f_sim:.6g}")
        if not (ok and same):
            bad.append(task)
    return bad


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="*", type=Path)
    ap.add_argument("--suite", type=Path, default=ROOT / "examples/maps/suite")
    ap.add_argument("--best-known", type=Path,
                    default=ROOT / "examples/maps/suite_best_known.json")
    ap.add_argument("--dry-run", action="store_true", help="print, store nothing")
    ap.add_argument("--f-tol", type=float, default=1e-6,
                    help="largest relative difference of the sim's f from the record's")
    ap.add_argument("--check-stored", action="store_true",
                    help="replay every stored entry in the sim and report failures")
    a = ap.parse_args()
    for p in a.results:
        if not p.is_file():
            print(f"results: {p} is not a file", file=sys.stderr)
            return 2
    bad: list[str] = []
    if a.check_stored:
        bad = check_stored(a.suite, a.best_known)
        print(f"stored entries failing the sim: {', '.join(bad) or 'none'}")
    if a.results:
        rep = refresh(a.results, a.suite, a.best_known, dry_run=a.dry_run, f_tol=a.f_tol)
        n = sum(e["stored"] for e in rep.values())
        print(f"refresh: {n} task(s) improved"
              + (f": {', '.join(t for t, e in rep.items() if e['stored'])}" if n else ""))
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
