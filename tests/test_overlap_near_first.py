"""`overlap_first` on a chunk of many legs (the visibility graph's rows: legs fanning out of one
corner) tests the obstacle tiles nearest the first leg's start first, so a leg cut near its
start leaves the tests there (2x faster line of sight on a 2,000-footprint campus); the
clear / cut answers stay `overlap_lengths`' (tests/test_scaling_paths.py), only which cut is
found first changes."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.model import geometry
from planner_core.model.geometry import Obstacles, overlap_first, overlap_lengths


def _field() -> Obstacles:
    """Two circles on the line y = 0 (r 10 at x 100, r 30 at x 2,900) among 400 small circles
    off it (a map with tiles)."""
    xs, ys = np.meshgrid(np.linspace(0, 3000, 20), np.linspace(200, 3000, 20))
    far = [(float(x), float(y), 5.0) for x, y in zip(xs.ravel(), ys.ravel(), strict=True)]
    return Obstacles.build([(100.0, 0.0, 10.0), (2900.0, 0.0, 30.0)] + far, [])


@pytest.mark.parametrize("start,near,other", [(0.0, 0, 1), (3000.0, 1, 0)])
def test_a_fan_of_legs_is_cut_first_by_the_obstacle_near_its_start(start, near, other) -> None:
    o = _field()
    assert len(o.tile_offsets) > 2  # tiled: the near-first order applies
    n = 2 * geometry._NEAR_FIRST_LEGS
    a = np.tile([start, 0.0], (n, 1))
    b = np.column_stack([np.full(n, 3000.0 - start), np.linspace(-0.5, 0.5, n)])
    first = overlap_first(a, b, o)
    alone = [overlap_lengths(a, b, Obstacles.build([tuple(o.circles[k])], [])) for k in (0, 1)]
    assert np.all(alone[near] > 0) and np.all(np.abs(alone[other] - alone[near]) > 1.0)
    np.testing.assert_array_equal(first, alone[near])  # the near circle's chord, every leg
    # whatever it finds first, the answer is the full sum's
    full = overlap_lengths(a, b, o)
    assert np.array_equal(first > 1e-9, full > 1e-9)
