"""Benchmark map generator (paper Sec. 3.2 and 5.1): maps with a known feasible plan stored inside.

Every map is feasible by construction. A witness plan is drawn first (stops spread over the area,
ordered into a tour, routed around the no-fly zones, with extra bends on some legs); sensors are
then placed around its hover points (C3 kept at every hover point), its hover times are the
smallest that deliver every sensor's data plus a margin (C4, T <= T_max), and circles and
rectangles are placed off its legs: on the straight line start -> end, on the shortcuts the bends
avoid, along the route and anywhere. The witness is stored in the map and checked with `Problem`
(phi == 0) before a map is returned.

The suite (16 tasks): T01..T08 on 5 km x 5 km (I_max 10) and T09..T16 on 10 km x 10 km (I_max 20),
obstacle density 0..7 within each size. Same seed, same bytes (coordinates rounded to 0.1 m,
hover times to 0.01 s).
"""


from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from planner_core.suite.draw import Draw, Retry
from planner_core.suite.tables import (
    N_DENSITIES,
    SIZES,
    SUITE_ORIGIN,
    SUITE_SEED,
    check_size_density,
    default_sensor_count,
    max_sensor_count,
    obstacle_counts,
    suite_tasks,
)

__all__ = [
    "SIZES",
    "N_DENSITIES",
    "SUITE_SEED",
    "SUITE_ORIGIN",
    "suite_tasks",
    "default_sensor_count",
    "max_sensor_count",
    "obstacle_counts",
    "generate_map",
    "suite_maps",
    "generated_maps",
    "generated_spec",
    "generate_suite",
    "write_maps",
    "dumps_map",
    "witness_score",
    "GenerationError",
]

_MAX_ATTEMPTS = 60


class GenerationError(RuntimeError):
    """No map met every check within the attempt budget (should not happen for valid input)."""


def witness_score(m: Any) -> tuple[float, float] | None:
    """The paper's f and phi of the map's stored witness plan, scored on the map as it is now.

    A generated map stores a witness checked to phi == 0 (`generate_map`); a map edited since
    may no longer be served by it. Scored as the planner scores a plan (`Problem`: the
    planning map, with the map's margins). Cost: one evaluation, O(I x sensors + legs x
    obstacles).

    Args:
        m: a `planner_core.model.mapio.Map`.

    Returns:
        (f, phi) of the witness (phi 0: feasible), or None when the map stores none or the
        witness has more hover points than I_max (no plan of this map can hold it).
    """
    w = m.spec.witness
    if w is None:
        return None
    hp = np.array(w.hover_points, dtype=float).reshape(-1, 2)
    ht = np.array(w.hover_times, dtype=float)
    if len(hp) > m.max_hover_points:
        return None
    problem = Problem(m)
    f, phi = problem.evaluate(problem.encode(hp, ht)[None, :])
    return float(f[0]), float(phi[0])


def _witness_ok(data: dict[str, Any]) -> bool:
    """Load the map and check its witness: phi == 0, times <= T_max, points in the area."""
    m = load_map(data)
    w = m.spec.witness
    if w is None:
        return False
    hp = np.array(w.hover_points, dtype=float).reshape(-1, 2)
    ht = np.array(w.hover_times, dtype=float)
    if np.any(ht < 0) or np.any(ht > m.spec.uav.max_hover_time):
        return False
    if np.any(hp < 0) or np.any(hp[:, 0] > m.width) or np.any(hp[:, 1] > m.height):
        return False
    score = witness_score(m)
    return score is not None and score[1] == 0.0


def generate_map(
    size: int,
    density: int,
    seed: int = SUITE_SEED,
    *,
    name: str | None = None,
    n_sensors: int | None = None,
    origin: dict[str, float] | None = None,
) -> dict[str, Any]:
    """One map with a stored witness (phi == 0), as JSON-ready data; same arguments, same map.

    Args:
        size: 5000 or 10000 (metres a side).
        density: obstacle density, 0..7.
        seed: the map's seed, an integer >= 0 (`SUITE_SEED`: the suite's).
        name: the map's name (None: "gen-<size>-d<density>-s<seed>").
        n_sensors: 1..`max_sensor_count(size)`; None: default grows with size and density
            (`default_sensor_count`).
        origin: the map's geographic origin (None: `SUITE_ORIGIN`).

    Returns:
        The map as JSON-ready data (witness included), as `dumps_map` writes it.

    Raises:
        ValueError: bad arguments (size, density, seed or sensor count).
        GenerationError: no attempt of `_MAX_ATTEMPTS` gave a map whose witness checks.
    """
    check_size_density(size, density)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer (got {seed!r})")
    if n_sensors is None:
        n_sensors = default_sensor_count(size, density)
    if not 1 <= n_sensors <= max_sensor_count(size):
        raise ValueError(
            f"sensors must be 1..{max_sensor_count(size)} on a {size} m map (got {n_sensors})"
        )
    if name is None:
        name = f"gen-{size}-d{density}-s{seed}"
    for attempt in range(_MAX_ATTEMPTS):
        rng = np.random.default_rng([int(seed), size, density, n_sensors, attempt])
        draw = Draw(rng, size, density, n_sensors)
        try:
            draw.run()
        except Retry:
            continue
        data = draw.to_dict(name, origin or SUITE_ORIGIN)
        if _witness_ok(data):
            return data
    raise GenerationError(
        f"no feasible map after {_MAX_ATTEMPTS} attempts (size {size}, density {density}, "
        f"seed {seed}, {n_sensors} sensors)"
    )


def suite_maps(seed: int = SUITE_SEED) -> dict[str, dict[str, Any]]:
    """The 16 suite maps by name (T01..T16); each task uses `seed` with its own size/density.

    Args:
        seed: the suite's seed (`SUITE_SEED`: the committed maps).

    Returns:
        {name: map data} in task order, T01 first (`generate_map`'s data).
    """
    return {name: generate_map(size, d, seed, name=name) for name, size, d in suite_tasks()}


def generated_maps(n: int, map_seed: int) -> list[tuple[str, dict[str, Any]]]:
    """`n` generated paper-size maps for training and held-out sets (the schedule benchmark,
    LAMDE-S's training): 5,000 m and 10,000 m a side alternating, densities 0-7 in turn, map
    seeds `map_seed`, `map_seed` + 1, ...

    Args:
        n: how many maps.
        map_seed: the first map's seed (the k-th map's is `map_seed` + k).

    Returns:
        [(name "gen-<size>-d<density>-s<seed>", map data)], in that order.
    """
    out = []
    for k in range(n):
        size, density, seed = generated_spec(k, map_seed)
        out.append((f"gen-{size}-d{density}-s{seed}", generate_map(size, density, seed)))
    return out


def generated_spec(k: int, map_seed: int) -> tuple[int, int, int]:
    """The k-th map of `generated_maps(n, map_seed)`: (size in m, density, map seed).

    Args:
        k: the map's index, 0-based.
        map_seed: the seed of map 0.

    Returns:
        (size in m: 5000 for even k, 10000 for odd; density (k // 2) % 8; seed map_seed + k).
    """
    return (5000, 10000)[k % 2], (k // 2) % 8, map_seed + k


def generate_suite(folder: str | Path, seed: int = SUITE_SEED) -> list[Path]:
    """Write T01.json..T16.json into `folder` (created), each atomically (`write_maps`).

    Args:
        folder: the target folder.
        seed: the suite's seed (`SUITE_SEED`: the committed maps).

    Returns:
        The 16 paths, T01 first.

    Raises:
        OSError: the folder cannot be written.
    """
    return write_maps(folder, suite_maps(seed))


def write_maps(folder: str | Path, maps: dict[str, dict[str, Any]],
               written: Callable[[Path, dict[str, Any]], None] | None = None) -> list[Path]:
    """Write each map as `folder/NAME.json` (the folder created), in order, each atomically
    (a temporary file renamed onto it: a killed run leaves each map old or whole, never
    half-written); `written(path, map)` is told after each.

    Args:
        folder: the target folder.
        maps: the map files by name (`suite_maps`, `large.large_suite_maps`).
        written: called after each map is written, or None.

    Returns:
        The paths written, in the order of `maps`.

    Raises:
        OSError: the folder cannot be made or a map cannot be written (the maps before it
            are written).
    """
    from planner_core.atomic import write_text_atomic

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, data in maps.items():
        path = folder / f"{name}.json"
        write_text_atomic(path, dumps_map(data))
        paths.append(path)
        if written is not None:
            written(path, data)
    return paths


# ----------------------------------------------------------------------------- JSON text

_WIDTH = 100


def dumps_map(data: dict[str, Any]) -> str:
    """Readable, stable JSON: short containers on one line, long number lists wrapped.

    Args:
        data: JSON-ready map data (`generate_map`'s).

    Returns:
        The JSON text (lines up to 100 characters where the values allow), ending with a
        newline.
    """
    return _fmt(data, 0, 0) + "\n"


def _fmt(v: Any, indent: int, used: int) -> str:
    compact = json.dumps(v, separators=(", ", ": "))
    if not isinstance(v, dict | list) or not v or used + len(compact) <= _WIDTH:
        return compact
    pad = " " * (indent + 2)
    if isinstance(v, dict):
        items = []
        for k, x in v.items():
            key = json.dumps(k) + ": "
            items.append(pad + key + _fmt(x, indent + 2, indent + 2 + len(key) + 1))
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    if all(not isinstance(x, dict) for x in v) and all(
        len(json.dumps(x, separators=(", ", ": "))) + indent + 4 <= _WIDTH for x in v
    ):  # pack numbers / short lists several to a line
        lines, cur = [], ""
        for x in v:
            t = json.dumps(x, separators=(", ", ": "))
            if cur and len(pad) + len(cur) + 2 + len(t) + 1 > _WIDTH:
                lines.append(cur)
                cur = t
            else:
                cur = f"{cur}, {t}" if cur else t
        lines.append(cur)
        return "[\n" + ",\n".join(pad + ln for ln in lines) + "\n" + " " * indent + "]"
    items = [pad + _fmt(x, indent + 2, indent + 3) for x in v]
    return "[\n" + ",\n".join(items) + "\n" + " " * indent + "]"
