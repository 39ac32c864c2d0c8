"""The descent's two step rules side by side: one step for every point, or one per point.

Two kinds of start (`--from`):
* `starts`: the `--starts` best constructive plans (`planner_core.search.construct.
  candidate_plans`, seed `--seed`, 64 candidates), far from any optimum;
* `kicks` (default): what the improving rounds descend. The plan of a short pipeline run
  (`--budget`, seed `--seed`) with one hover point kicked by a normal step of `structure.KICK`
  m per axis (`--starts` kicks from a seeded generator; a kick into an obstacle, past the
  bandwidth or leaving a sensor unserved is drawn again), timed by its LP as `structure._move`
  times a move.
Each start is descended twice for at most `--trials` evaluations, once with `GLOBAL` and once
with `PER_POINT` steps (`planner_core.search.descent.descend`, module docstring). Prints one
line per start (its f, each rule's f and evaluations; "stopped early" where the global rule
spent fewer than `--trials`: its step fell below `MIN_STEP` first), then per map on how many
starts the per-point rule ended lower and higher than the global one, the mean difference
(per-point over global: negative where per-point did better) and each rule's mean
evaluations. Deterministic: the same command
prints the same lines.

    python benchmarks/bench_descent.py [--maps L06 L08] [--from kicks|starts] [--starts 25]
        [--trials 40] [--budget 2000] [--seed 0]

A map is a suite name (T01-T16), a large-suite name (L01-L08) or a path to a map file.
Cost: per start and rule, `--trials` evaluations with their LPs (I points x J sensors) and
C3/C5 checks, plus the short run for `kicks`: a few seconds a map on the 300-400-sensor maps.
Exit status 2 for a bad argument (argparse's usage and error for a malformed option, one
line for a bad value or map).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = (ROOT / "examples" / "maps" / "suite", ROOT / "examples" / "maps" / "large")


def _source(name: str) -> Path:
    """The map file of a suite or large-suite name, or `name` as a path."""
    for folder in FOLDERS:
        if (folder / f"{name}.json").is_file():
            return folder / f"{name}.json"
    if Path(name).is_file():
        return Path(name)
    raise ValueError(f"--maps: no suite map or file named {name!r}")


def _starts(problem: object, kind: str, n: int, budget: int, seed: int) -> list:
    """The decision vectors (d,) to descend (module docstring) and their f."""
    import numpy as np

    from planner_core.model.formulas import deb_order
    from planner_core.search.construct import candidate_plans

    if kind == "starts":
        X, _ = candidate_plans(problem, seed, 64)
        f, phi = problem.evaluate(X)
        return [X[k] for k in deb_order(f, phi) if phi[k] == 0][:n]
    from planner_core.pipeline import PlanConfig, run_pipeline
    from planner_core.search.descent import hover_of
    from planner_core.search.polish import hover_lp
    from planner_core.search.structure import KICK
    from planner_core.search.trial import held_points

    x = np.asarray(run_pipeline(problem, PlanConfig(seed=seed, budget=budget)).x, dtype=float)
    P = hover_of(problem.breakdown(x))[0]
    m = problem.model
    box = np.array([m.width, m.height])
    rng = np.random.default_rng(np.random.SeedSequence([seed, 71]))
    out = []
    for _ in range(100 * n):  # refused kicks are drawn again, boundedly
        if len(out) == n:
            break
        Q = P.copy()
        i = int(rng.integers(len(Q)))
        Q[i] = np.clip(Q[i] + rng.normal(0.0, KICK, 2), 0.0, box)
        lp = None if len(held_points(problem, Q)) else hover_lp(m.rates(Q), m.required, m.t_max)
        if lp is not None:
            out.append(problem.encode(Q, lp[0]))
    return out


def compare(problem: object, kind: str, n: int, trials: int, budget: int,
            seed: int) -> list[dict[str, float]]:
    """One row per start: its f, and each rule's f and evaluations."""
    from planner_core.pipeline.evaluator import Evaluator
    from planner_core.search.descent import GLOBAL, PER_POINT, descend

    rows = []
    for x in _starts(problem, kind, n, budget, seed):
        f0 = float(problem.evaluate(x[None, :])[0][0])
        row = {"f0": f0}
        for rule in (GLOBAL, PER_POINT):
            r = descend(problem, x, Evaluator(problem, trials).evaluate, trials=trials,
                        steps=rule)
            row[rule] = r.f if r is not None else f0
            row[rule + " evaluations"] = r.evaluations if r is not None else 0
        row["stalled"] = row[GLOBAL + " evaluations"] < trials  # its step below MIN_STEP
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", nargs="+", default=["L06", "L08"],
                    help="suite names (T01-T16, L01-L08) or map files (default: L06 L08)")
    ap.add_argument("--from", dest="kind", choices=("kicks", "starts"), default="kicks",
                    help="kicked plans of a short run (default) or constructive starts")
    ap.add_argument("--starts", type=int, default=25, help="starts per map (default 25)")
    ap.add_argument("--trials", type=int, default=40,
                    help="evaluations each descent may spend (default 40)")
    ap.add_argument("--budget", type=int, default=2000,
                    help="the short run's evaluations, for --from kicks (default 2000)")
    ap.add_argument("--seed", type=int, default=0, help="the run's and the kicks' seed")
    a = ap.parse_args(argv)
    try:
        if a.starts < 1 or a.trials < 1 or a.seed < 0 or a.budget < 200:
            raise ValueError("--starts and --trials must be >= 1, --budget >= 200, --seed >= 0")
        sources = [(name, _source(name)) for name in a.maps]
    except ValueError as e:
        print(f"bench_descent: {e}", file=sys.stderr)
        return 2

    from planner_core.model.mapio import MapError
    from planner_core.model.problem import Problem
    from planner_core.pipeline.warmup import warm_up
    from planner_core.search.descent import GLOBAL, PER_POINT

    warm_up()
    what = (f"the {a.starts} best constructive starts (seed {a.seed})" if a.kind == "starts"
            else f"{a.starts} kicks of the plan at {a.budget} evaluations (seed {a.seed})")
    print(f"descents from {what}, at most {a.trials} evaluations each")
    for name, path in sources:
        try:
            problem = Problem(path)
        except (MapError, OSError, ValueError) as e:
            print(f"bench_descent: {e}" if str(name) in str(e) else f"bench_descent: {name}: {e}",
                  file=sys.stderr)
            return 2
        rows = compare(problem, a.kind, a.starts, a.trials, a.budget, a.seed)
        for i, r in enumerate(rows):
            print(f"{name} start {i}: f {r['f0']:.1f}; global {r[GLOBAL]:.1f} "
                  f"({r[GLOBAL + ' evaluations']} ev{', stopped early' if r['stalled'] else ''}); "
                  f"per-point {r[PER_POINT]:.1f} ({r[PER_POINT + ' evaluations']} ev)")
        diff = [100.0 * (r[PER_POINT] / r[GLOBAL] - 1.0) for r in rows]
        n = max(len(rows), 1)
        print(f"{name}: per-point vs global: lower on {sum(d < 0 for d in diff)}, higher on "
              f"{sum(d > 0 for d in diff)} of {len(rows)} starts (mean {sum(diff) / n:+.2f} %, "
              f"range {min(diff, default=0):+.2f} to {max(diff, default=0):+.2f} %); "
              f"evaluations global {sum(r[GLOBAL + ' evaluations'] for r in rows) / n:.1f}, "
              f"per-point {sum(r[PER_POINT + ' evaluations'] for r in rows) / n:.1f} a start; "
              f"the global rule stopped early on {sum(r['stalled'] for r in rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
