"""Statistics of a map's sensor layout, read before any stage runs.

`clark_evans` is the Clark-Evans ratio (Clark & Evans, "Distance to nearest neighbor as a
measure of spatial relationships in populations", Ecology 35(4), 1954): the sensors' mean
nearest-neighbour distance over 0.5 sqrt(area / J), the mean for J points drawn uniformly
over the area. About 1 for a uniform layout, below for clustered fields and corridors (the
large suite: 0.97-1.13 for L01-L03, 0.12-0.20 for L04-L08), above for a regular one. The
stage scheduler's split table (`planner_core.learning.schedule_select`), the default
scheduler's window rule (`planner_core.pipeline.schedule`) and the structural moves' descent
(`planner_core.search.structure`) read it, through `UNIFORM_LAYOUT` and
`planner_core.model.problem.Problem.uniform_layout`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["UNIFORM_LAYOUT", "clark_evans"]

#: a layout whose Clark-Evans ratio is at least this is uniform (the large suite's L01-L03,
#: 0.97-1.13); below it, clustered fields and corridors (L04-L08, 0.12-0.20)
UNIFORM_LAYOUT = 0.5


def clark_evans(sensors: np.ndarray, area: float) -> float:
    """The Clark-Evans ratio of the points sensors (J, 2) m over an area of `area` m^2 (module
    docstring); 1 for fewer than 2 points or no area. Cost: one k-d tree query, O(J log J).

    Args:
        sensors: (J, 2) sensor positions, m.
        area: the area they lie in, m^2.

    Returns:
        The mean nearest-neighbour distance over 0.5 sqrt(area / J) (1.0 for J < 2 or
        area <= 0).
    """
    from scipy.spatial import cKDTree

    xy = np.asarray(sensors, dtype=float).reshape(-1, 2)
    if len(xy) < 2 or not area > 0:
        return 1.0
    d, _ = cKDTree(xy).query(xy, k=2)
    return float(d[:, 1].mean() / (0.5 * np.sqrt(area / len(xy))))
