"""The benchmark suite's table: sizes, densities and obstacle counts (paper Sec. 5.1)."""

from __future__ import annotations

from planner_core.defaults import SUITE_SEED as _SUITE_SEED

__all__ = [
    "SIZES",
    "N_DENSITIES",
    "SUITE_SEED",
    "SUITE_ORIGIN",
    "BENDS",
    "suite_tasks",
    "default_sensor_count",
    "max_sensor_count",
    "obstacle_counts",
    "check_size_density",
]

#: map side (m) -> I_max, the two sizes of the paper's suite
SIZES: dict[int, int] = {5000: 10, 10000: 20}
#: obstacle densities per size (0 = sparsest, 7 = densest)
N_DENSITIES = 8
#: the seed the committed suite was generated with
SUITE_SEED = _SUITE_SEED
#: one fixed, realistic origin for all generated maps (Guangzhou Higher Education Mega Center)
SUITE_ORIGIN: dict[str, float] = {"lat": 23.0493, "lon": 113.3975, "alt": 10.0}

# obstacle counts per density, per size
_CIRCLES = {5000: (3, 5, 8, 11, 14, 18, 22, 26), 10000: (6, 12, 18, 25, 32, 40, 48, 56)}
_RECTANGLES = {5000: (2, 4, 7, 10, 13, 17, 21, 25), 10000: (5, 11, 17, 24, 31, 39, 47, 55)}
_NFZS = {5000: (0, 0, 0, 1, 1, 1, 2, 2), 10000: (0, 0, 1, 1, 2, 2, 3, 4)}
# legs of the witness bent sideways, with an obstacle on the shortcut they avoid
BENDS = {5000: (0, 0, 1, 1, 2, 2, 3, 3), 10000: (0, 1, 1, 2, 3, 4, 5, 6)}


def suite_tasks() -> list[tuple[str, int, int]]:
    """The suite's 16 tasks (paper Sec. 5.1): T01..T08 on 5 km, T09..T16 on 10 km.

    Returns:
        (name, size in m, density 0..7) per task, in name order.
    """
    return [
        (f"T{k * N_DENSITIES + d + 1:02d}", size, d)
        for k, size in enumerate(sorted(SIZES))
        for d in range(N_DENSITIES)
    ]


def default_sensor_count(size: int, density: int) -> int:
    """The number of sensors of a suite map: it grows with size and density, 8..15 on 5 km,
    15..29 on 10 km.

    Args:
        size: the map's side (m), a key of `SIZES`.
        density: 0 (sparsest) .. `N_DENSITIES` - 1 (densest).

    Returns:
        J.

    Raises:
        ValueError: as `check_size_density`.
    """
    check_size_density(size, density)
    return 8 + density if size == 5000 else 15 + 2 * density


def max_sensor_count(size: int) -> int:
    """The most sensors a map of this size may ask for (two per hover point, 2 I_max).

    Args:
        size: the map's side (m), a key of `SIZES`.

    Returns:
        The largest J.

    Raises:
        ValueError: an unknown size (`check_size_density`).
    """
    check_size_density(size, 0)
    return 2 * SIZES[size]


def obstacle_counts(size: int, density: int) -> tuple[int, int, int]:
    """The obstacles of a suite map at this size and density (paper Sec. 3.2's three kinds).

    Args:
        size: the map's side (m), a key of `SIZES`.
        density: 0 (sparsest) .. `N_DENSITIES` - 1 (densest).

    Returns:
        (circles, rectangles, no-fly zones).

    Raises:
        ValueError: as `check_size_density`.
    """
    check_size_density(size, density)
    return _CIRCLES[size][density], _RECTANGLES[size][density], _NFZS[size][density]


def check_size_density(size: int, density: int) -> None:
    """Check a suite map's size and density, the two axes of the suite's table.

    Args:
        size: the map's side (m): one of `SIZES` (5000, 10000).
        density: the obstacle density, 0 (sparsest) .. `N_DENSITIES` - 1 (densest).

    Raises:
        ValueError: `size` is not a key of `SIZES`, or `density` is outside 0 ..
            `N_DENSITIES` - 1; the message names the field and the allowed values.
    """
    if size not in SIZES:
        raise ValueError(f"size must be one of {sorted(SIZES)} (got {size})")
    if not 0 <= density < N_DENSITIES:
        raise ValueError(f"density must be 0..{N_DENSITIES - 1} (got {density})")
