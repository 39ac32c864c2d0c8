"""Time the L_vio kernel (fast numba path vs shapely/plain-Python reference) on a paper-sized map.

10 km x 10 km, 60 circles (r 40-100 m), 60 rotated rectangles (80-180 m sides), 4 no-fly zones
(3-7 vertices, 3-4 km across); 2,100 random long legs = one population of 100 solutions x 21 legs.

    python benchmarks/bench_geometry.py [--legs 2100] [--repeat 200] [--seed 0]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from planner_core.model.geometry import (
    Obstacles,
    overlap_lengths,
    overlap_lengths_reference,
    rectangle_vertices,
)

SIDE = 10_000.0


def paper_map(rng: np.random.Generator, n_circ: int = 60, n_rect: int = 60, n_nfz: int = 4):
    """Random obstacles with the paper's size ranges (Sec. 3.2)."""
    circles = [
        (rng.uniform(0, SIDE), rng.uniform(0, SIDE), rng.uniform(40, 100)) for _ in range(n_circ)
    ]
    polys = [
        rectangle_vertices(
            rng.uniform(0, SIDE),
            rng.uniform(0, SIDE),
            rng.uniform(80, 180),
            rng.uniform(80, 180),
            rng.uniform(0, 180),
        )
        for _ in range(n_rect)
    ]
    for _ in range(n_nfz):
        k = int(rng.integers(3, 8))
        radius = rng.uniform(1500, 2000)
        centre = rng.uniform(radius, SIDE - radius, size=2)
        ang = np.sort(rng.uniform(0, 2 * np.pi, size=k))
        polys.append(centre + radius * np.column_stack([np.cos(ang), np.sin(ang)]))
    return Obstacles.build(circles, polys)


def _time(fn, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--legs", type=int, default=2100)
    ap.add_argument("--repeat", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--reference-legs", type=int, default=210, help="legs timed on the reference")
    args = ap.parse_args()

    rng = np.random.default_rng(args.seed)
    obs = paper_map(rng)
    a = rng.uniform(0, SIDE, size=(args.legs, 2))
    b = rng.uniform(0, SIDE, size=(args.legs, 2))
    # population-shaped input as the evaluator passes it: (100, 21, 2) non-contiguous views
    path = rng.uniform(0, SIDE, size=(args.legs // 21, 22, 2))
    pa, pb = path[:, :-1], path[:, 1:]

    t0 = time.perf_counter()
    overlap_lengths(a[:2], b[:2], obs)
    print(f"first call (compile or cache load): {time.perf_counter() - t0:.2f} s")

    fast = overlap_lengths(a, b, obs)
    nr = min(args.reference_legs, args.legs)
    ref = overlap_lengths_reference(a[:nr], b[:nr], obs)
    print(f"max |fast - reference| on {nr} legs: {np.max(np.abs(fast[:nr] - ref)):.3g} m")
    print(f"legs with L_vio > 0: {np.mean(fast > 0):.1%}")

    n_obs = obs.n_circles + obs.n_polygons
    print(f"{args.legs} legs x {n_obs} obstacles ({obs.n_circles} circles, {obs.n_polygons} polys)")
    rows = [
        ("fast", lambda: overlap_lengths(a, b, obs), args.legs),
        ("fast, (100, 21) path views", lambda: overlap_lengths(pa, pb, obs),
         pa.shape[0] * pa.shape[1]),
        ("reference", lambda: overlap_lengths_reference(a[:nr], b[:nr], obs), nr),
    ]  # fmt: skip
    speeds = {}
    for name, fn, n in rows:
        t = _time(fn, args.repeat if name != "reference" else 3)
        speeds[name] = n / t
        print(f"  {name:28s} {t * 1e3:9.3f} ms  {n / t:14,.0f} legs/s  {n / t / 21:12,.0f} sol/s")
    print(f"speed-up fast / reference: {speeds['fast'] / speeds['reference']:,.0f}x")


if __name__ == "__main__":
    main()
