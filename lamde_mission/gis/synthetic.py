"""A generated campus: hundreds of non-convex building footprints, for speed at real scale.

`campus_map(n_footprints=500, seed=0)` lays a square grid of lots over a `size` x `size` m area
(5 km, the paper's smaller maps) with enough lots for the footprints plus a third left empty;
a seeded generator (numpy's default_rng([seed, n_footprints, size])) picks the built lots and,
in each, one footprint centred in the lot with streets of at least `STREET` m between lots:
an L, a U, a T, or a block with a courtyard (a hole), with random arm widths and lengths, turned
by a multiple of 90 degrees plus a small random angle (within +-10 degrees). All are non-convex
(the block is convex outside but has a hole). Sensors stand in the empty lots' centres, the
start and end in the south-west and north-east corners (their lots are kept empty). The radio,
UAV and objective are the paper's defaults. Same seed, same map.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["campus_map", "STREET"]

#: metres: the least gap between two footprints in neighbouring lots
STREET = 40.0


def _l_shape(w: float, h: float, a: float, b: float) -> list[tuple[float, float]]:
    return [(0, 0), (w, 0), (w, b), (a, b), (a, h), (0, h)]


def _u_shape(w: float, h: float, a: float, b: float) -> list[tuple[float, float]]:
    return [(0, 0), (w, 0), (w, h), (w - a, h), (w - a, b), (a, b), (a, h), (0, h)]


def _t_shape(w: float, h: float, a: float, b: float) -> list[tuple[float, float]]:
    x0, x1 = 0.5 * (w - a), 0.5 * (w + a)
    return [(x0, 0), (x1, 0), (x1, h - b), (w, h - b), (w, h), (0, h), (0, h - b), (x0, h - b)]


def _footprint(rng: np.random.Generator, lot: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """One footprint centred on (0, 0), fitting a lot of side `lot` less the street."""
    span = (lot - STREET) / math.sqrt(2.0) * rng.uniform(0.7, 1.0)  # fits at any angle
    w, h = span, span * rng.uniform(0.6, 1.0)
    a, b = w * rng.uniform(0.25, 0.45), h * rng.uniform(0.25, 0.45)
    kind = int(rng.integers(4))
    holes: list[np.ndarray] = []
    if kind == 0:
        shell = np.array(_l_shape(w, h, a, b), dtype=float)
    elif kind == 1:
        shell = np.array(_u_shape(w, h, a, b), dtype=float)
    elif kind == 2:
        shell = np.array(_t_shape(w, h, a, b), dtype=float)
    else:
        shell = np.array([(0, 0), (w, 0), (w, h), (0, h)], dtype=float)
        cx, cy = 0.5 * w, 0.5 * h
        hw, hh = 0.5 * (w - 2 * a * 0.8), 0.5 * (h - 2 * b * 0.8)
        holes.append(np.array([(cx - hw, cy - hh), (cx - hw, cy + hh), (cx + hw, cy + hh),
                               (cx + hw, cy - hh)], dtype=float))  # fmt: skip
    centre = np.array([0.5 * w, 0.5 * h])
    th = 0.5 * math.pi * int(rng.integers(4)) + math.radians(rng.uniform(-10.0, 10.0))
    rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    shell = (shell - centre) @ rot.T
    holes = [(hh_ - centre) @ rot.T for hh_ in holes]
    return shell, holes


def campus_map(
    n_footprints: int = 500, seed: int = 0, size: float = 5000.0, n_sensors: int = 15
) -> dict[str, Any]:
    """A map file (dict for `planner_core.load_map`) with `n_footprints` non-convex footprints.

    Args:
        n_footprints: how many footprints (polygon obstacles), >= 1.
        seed: the random seed (with `n_footprints` and `size`: same arguments, same map).
        size: the square area's side, metres.
        n_sensors: how many sensors, >= 1, one per empty lot.

    Returns:
        The map file as a dict: name, area, start and end (the corner lots), sensors and
        `obstacles.polygons` (vertices and holes in metres, 3 decimals).

    Raises:
        ValueError: `n_footprints` or `n_sensors` < 1, or the grid cannot hold that many
            footprints and sensors.
    """
    if n_footprints < 1:
        raise ValueError(f"n_footprints must be >= 1, got {n_footprints}")
    if n_sensors < 1:
        raise ValueError(f"n_sensors must be >= 1, got {n_sensors}")
    rng = np.random.default_rng([int(seed), int(n_footprints), int(size)])
    n_lots = int(math.ceil(math.sqrt((n_footprints + n_sensors + 2) * 1.5)))
    lot = size / n_lots
    if lot <= 2.0 * STREET:
        raise ValueError(f"{n_footprints} footprints and {n_sensors} sensors do not fit on a "
                         f"{size:g} m map (one lot each, lots wider than two {STREET:g} m "
                         "streets)")
    cells = [(i, j) for j in range(n_lots) for i in range(n_lots)]
    reserved = {(0, 0), (n_lots - 1, n_lots - 1)}
    free = [c for c in cells if c not in reserved]
    order = rng.permutation(len(free))
    built = [free[k] for k in order[:n_footprints]]
    empty = [free[k] for k in order[n_footprints:]]
    if len(empty) < n_sensors:
        raise ValueError("not enough empty lots for the sensors")
    sensor_lots = [empty[k] for k in rng.choice(len(empty), n_sensors, replace=False)]
    polygons = []
    for k, (i, j) in enumerate(built):
        shell, holes = _footprint(rng, lot)
        c = np.array([(i + 0.5) * lot, (j + 0.5) * lot])
        entry: dict[str, Any] = {"vertices": np.round(shell + c, 3).tolist(), "name": f"b{k}"}
        if holes:
            entry["holes"] = [np.round(h + c, 3).tolist() for h in holes]
        polygons.append(entry)
    sensors = [{"id": f"s{k + 1}", "x": round((i + 0.5) * lot, 3), "y": round((j + 0.5) * lot, 3)}
               for k, (i, j) in enumerate(sensor_lots)]  # fmt: skip
    return {
        "name": f"campus-{n_footprints}-seed{seed}",
        "area": {"width": size, "height": size},
        "start": [0.5 * lot, 0.5 * lot],
        "end": [size - 0.5 * lot, size - 0.5 * lot],
        "sensors": sensors,
        "obstacles": {"polygons": polygons},
    }
