"""Optional: our evaluator behind a JSON-lines pipe, for optimisers that run in another venv.

Not imported by the package. Run it with OUR interpreter; the foreign optimiser (MetaBox-v2's
RLDE-AFL, GLEET, LDE in a venv with numpy < 2) starts it as a subprocess and talks to it on
stdin/stdout, one JSON object per line (README.md beside this file):

    -> {"op": "info"}
    <- {"dim": d, "lower": [...], "upper": [...], "budget": B, "used": 0, "seed": S}
    -> {"op": "evaluate", "X": [[...], ...]}        (rows in problem space, i.e. within bounds)
    <- {"f": [...], "phi": [...], "score": [...], "used": n}   score = f + 10 phi
    -> {"op": "finish"}
    <- {"record": {...}}   the run's record, also appended to OUT/results.jsonl

Every evaluation counts against the budget (`planner_core.bench.baselines.Evaluator`); a batch
past it is answered {"error": ...} and evaluates nothing. The reported result is the best
penalised score seen (as for CMA-ES), so the record is scored exactly as our own optimisers.

The seed is recorded, and told to the client in "info" so it can seed its optimiser: either
given (--seed) or our benchmark's seed of that (task, run) (--base-seed B:
`planner_core.bench.runner.run_seed(B, task, run)`, so the foreign runs pair with ours).

Usage: python benchmarks/metabox/evaluator_server.py --map examples/maps/suite/T01.json \
           --optimiser rlde-afl --run 0 --base-seed 0 --budget 10000 --init uniform --out results/
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from planner_core.bench.baselines import Evaluator
from planner_core.bench.records import RESULTS_FILE, ResultsWriter
from planner_core.bench.runner import SCHEMA, downsample, read_map_file, run_seed
from planner_core.model.formulas import penalised_score
from planner_core.model.problem import Problem


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", required=True)
    ap.add_argument("--optimiser", required=True, help="name recorded, e.g. rlde-afl")
    ap.add_argument("--task", help="task name (default: the map file's stem)")
    ap.add_argument("--run", type=int, default=0)
    seed = ap.add_mutually_exclusive_group()
    seed.add_argument("--seed", type=int, help="the run's seed, recorded (default 0)")
    seed.add_argument("--base-seed", type=int,
                      help="the seed is run_seed(BASE_SEED, task, run), as `lamde-mission bench`")
    ap.add_argument("--budget", type=int, default=10_000)
    ap.add_argument("--init", choices=("uniform", "seeded"), default="uniform",
                    help="recorded only: the foreign optimiser draws its own start")
    ap.add_argument("--out", help="results folder to append the record to (optional)")
    a = ap.parse_args(argv)
    task = a.task or Path(a.map).stem
    if a.base_seed is not None:
        a.seed = run_seed(a.base_seed, task, a.run)
    elif a.seed is None:
        a.seed = 0
    content, sha = read_map_file(a.map)
    problem = Problem(content)
    bp = Evaluator(problem, a.budget)
    t0 = time.perf_counter()

    def reply(obj: dict) -> None:
        sys.stdout.write(json.dumps(obj) + "\n")
        sys.stdout.flush()

    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            req = json.loads(line)
            op = req.get("op")
        except (ValueError, AttributeError):
            reply({"error": "request: not a JSON object"})
            continue
        if op == "info":
            reply({"dim": int(problem.dim), "lower": bp.lower.tolist(),
                   "upper": bp.upper.tolist(), "budget": bp.budget, "used": bp.count,
                   "seed": a.seed})
        elif op == "evaluate":
            try:
                X = np.atleast_2d(np.asarray(req["X"], dtype=float))
                if X.shape[1] != problem.dim:
                    raise ValueError(f"X: rows of length {X.shape[1]}, expected {problem.dim}")
                f, phi = bp.evaluate(np.clip(X, bp.lower, bp.upper))
            except Exception as exc:  # one bad batch is answered, the server goes on
                reply({"error": f"{type(exc).__name__}: {exc}"})
                continue
            reply({"f": f.tolist(), "phi": phi.tolist(),
                   "score": np.asarray(penalised_score(f, phi)).tolist(), "used": bp.count})
        elif op == "finish":
            x, f, phi = bp.best("penalised")
            h = bp.trace("penalised")
            ev, (bf, bph) = downsample(h.evaluations, [h.best_f, h.best_phi], bp.budget)
            bd = problem.breakdown(x)
            rec = {"optimiser": a.optimiser, "task": task, "run": a.run,
                   "seed": a.seed, "budget": a.budget, "map_sha256": sha, "init": a.init,
                   "schema": SCHEMA, "score": float(penalised_score(f, phi)), "f": float(f),
                   "phi": float(phi), "feasible": bool(phi == 0.0),
                   "evaluations": int(bp.count), "wall_s": round(time.perf_counter() - t0, 4),
                   "n_hover": int(bd["n_hover"]), "n_points": int(problem.n_points),
                   "last_feasible_rate": None, "hover_points": bd["hover_points"],
                   "hover_times": bd["hover_times"], "x": x.tolist(),
                   "history": {"evaluations": ev.astype(int).tolist(),
                               "best_f": bf.tolist(), "best_phi": bph.tolist()}}
            if a.out:
                with ResultsWriter(Path(a.out) / RESULTS_FILE) as w:
                    w.write(rec)
            reply({"record": rec})
            return 0
        else:
            reply({"error": f"op: unknown {op!r} (info, evaluate, finish)"})
    return 1  # stdin closed before "finish"


if __name__ == "__main__":
    raise SystemExit(main())
