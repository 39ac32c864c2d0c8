"""The landscape-aware choice of training maps for LAMDE-S (issue 34): the paper's distributional
query (Sec. 4.3, Stage 1, Eq. select_obj) with UAV maps in place of BBOB instances.

The pool is a larger set of generated maps (`planner_core.suite.generated_maps`); the targets
are the maps the policy is meant for (the 16 suite maps by default). Each map's UAV problem
(`planner_core.model.problem.Problem`, its box of hover points in metres and seconds) is probed
as a task is (`query.task_features`: N_probe LHS points of its unit box, then an extractor's z_f
of the objective); ELA features are standardised over the pool (`query.standardiser`). Stage 1
then takes the k pool maps with the least mean distance to the targets ("global"), or each
target's nearest in turn ("local"), or k at random ("random", the ablation LAMDE-R's role).
Stage 2 (the constraint partner of a BBOB pair) has no counterpart: a map brings its own
constraints.

    python -m planner_core.learning.lam.maps --pool 192 --pool-seed 6000 --k 48 \\
        [--targets examples/maps/suite/*.json] [--selection global] -o picks.json

writes the chosen maps' generator arguments (name, size, density, seed) and their scores;
`python -m planner_core.learning.schedule_ppo --maps-file picks.json` trains on them.

Cost: one probe (N_probe evaluations, O(N_probe I_max J)) and one feature extraction per map.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["map_features", "select_maps"]


def map_features(maps: Sequence[Any], *, features: str = "ela", seed: int = 0) -> np.ndarray:
    """z_f of each map's UAV problem.

    Args:
        maps: map files or parsed map data; features: the extractor ("ela" or "learned");
        seed: the probes' seed (map m probed with `SeedSequence([seed, m])`).

    Returns:
        (n, q) features, one row per map.

    Raises:
        ValueError: an unknown extractor; a map that does not load (its field named).
    """
    from planner_core.learning.lam.database import make_extractors
    from planner_core.learning.lam.query import task_features
    from planner_core.model.mapio import load_map
    from planner_core.model.problem import Problem

    extractor = make_extractors([features])[features]
    problems = [Problem(load_map(m).planning_map()) for m in maps]
    return task_features(problems, [str(i) for i in range(len(problems))], extractor,
                         seed=seed).z_f


def select_maps(pool: np.ndarray, targets: np.ndarray, k: int, *, selection: str = "global",
                standardise: bool = True, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Stage 1 of the query over a pool of maps.

    Args:
        pool: z_f of the pool (S, q); targets: z_f of the targets (M, q); k: maps to take
            (1..S); selection: "global", "local" or "random"; standardise: scale each feature
            by the pool's mean and standard deviation first (ELA's scales differ by orders of
            magnitude; the learned features are unit vectors); seed: the random selection's.

    Returns:
        (indices into the pool (k,), every pool map's mean distance to the targets (S,)).

    Raises:
        ValueError: an unknown selection or k outside 1..S.
    """
    from planner_core.learning.lam.query import SELECTIONS, stage_one, standardiser

    if selection not in SELECTIONS:
        raise ValueError(f"selection: {selection!r} is not one of {SELECTIONS}")
    S = len(pool)
    if not 1 <= k <= S:
        raise ValueError(f"k: {k} must be in 1..{S} (the pool's size)")
    Z, z = np.asarray(pool, dtype=float), np.asarray(targets, dtype=float)
    if standardise:
        mu, sd = standardiser(Z)
        Z, z = (Z - mu) / sd, (z - mu) / sd
    Df = np.linalg.norm(z[:, None, :] - Z[None, :, :], axis=-1)  # (M, S)
    if selection == "random":
        idx = np.random.default_rng(seed).choice(S, size=k, replace=False)
    else:
        idx = stage_one(Df, k, selection)[0]
    return np.asarray(idx, dtype=int), Df.mean(axis=0)


def main(argv: list[str] | None = None) -> int:
    """The command line (module docstring): choose maps from a generated pool, write the JSON.

    Args:
        argv: the arguments (None: ``sys.argv[1:]``).

    Returns:
        The exit status: 0 written, 2 bad arguments (one line on stderr). An argument
        argparse refuses exits with status 2 (SystemExit) instead.
    """
    from planner_core.atomic import write_text_atomic
    from planner_core.suite import generated_maps, generated_spec

    ap = argparse.ArgumentParser(prog="python -m planner_core.learning.lam.maps",
                                 description="choose LAMDE-S's training maps from a generated "
                                 "pool by landscape similarity to target maps")
    ap.add_argument("--pool", type=int, default=192, help="generated maps in the pool")
    ap.add_argument("--pool-seed", type=int, default=6000, help="the pool's first map seed")
    ap.add_argument("--k", type=int, default=48, help="maps to choose")
    ap.add_argument("--targets", nargs="+", default=None,
                    help="target map files (default: the 16 suite maps)")
    ap.add_argument("--selection", default="global", help="global, local or random")
    ap.add_argument("--features", default="ela", help="ela or learned")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--output", required=True)
    args = ap.parse_args(argv)
    root = Path(__file__).resolve().parents[3]
    targets = args.targets or sorted(str(p) for p in (root / "examples/maps/suite").glob(
        "T*.json"))
    from planner_core.atomic import check_writable

    try:
        if args.pool < 1:
            raise ValueError(f"pool: must be >= 1, got {args.pool}")
        if not 1 <= args.k <= args.pool:
            raise ValueError(f"k: {args.k} must be in 1..{args.pool} (the pool's size)")
        for name in ("pool_seed", "seed"):
            if getattr(args, name) < 0:
                raise ValueError(f"{name.replace('_', '-')}: must be >= 0, got "
                                 f"{getattr(args, name)}")
        check_writable(args.output, mkdir=True, what="output")
        pool = generated_maps(args.pool, args.pool_seed)
        zp = map_features([d for _, d in pool], features=args.features, seed=args.seed)
        zt = map_features(targets, features=args.features, seed=args.seed + 1)
        idx, dist = select_maps(zp, zt, args.k, selection=args.selection,
                                standardise=args.features == "ela", seed=args.seed)
    except ValueError as exc:
        print(f"lam.maps: {exc}", file=sys.stderr)
        return 2
    picks = [dict(zip(("size", "density", "seed"), generated_spec(int(i), args.pool_seed),
                      strict=True), name=pool[i][0], distance=float(dist[i])) for i in idx]
    doc = {"pool": args.pool, "pool_seed": args.pool_seed, "k": args.k,
           "selection": args.selection, "features": args.features, "seed": args.seed,
           "targets": [Path(t).name for t in targets], "maps": picks,
           "mean_distance_chosen": float(dist[idx].mean()),
           "mean_distance_pool": float(dist.mean())}
    write_text_atomic(args.output, json.dumps(doc, indent=1) + "\n")
    print(f"wrote {args.output}: {len(picks)} of {args.pool} maps, mean distance "
          f"{doc['mean_distance_chosen']:.3f} (the pool's {doc['mean_distance_pool']:.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
