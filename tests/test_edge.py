"""Exactness at the edge (paper C5): what the planner calls collision-free has no positive
overlap under the sim's independent check, and the two share one tolerance."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Point, Polygon

from planner_core.defaults import L_VIO_TOL
from planner_core.model.formulas import L_VIO_TOL as MODEL_TOL
from planner_core.model.geometry import Obstacles, overlap_lengths, rectangle_vertices
from sim.checks import C5_TOL
from sim.obstacles import Obstacle
from sim.obstacles import overlap_lengths as sim_overlaps

CX, CY, R = 1234.5, 678.25, 100.0
RECT = (1500.0, 900.0, 180.0, 80.0, 33.0)  # centre x, y, length, width, angle (deg)
PLANNER = Obstacles.build([(CX, CY, R)], [rectangle_vertices(*RECT)])
SIM = [
    Obstacle("circle", 0, Point(CX, CY).buffer(R), circle=(CX, CY, R)),
    Obstacle("rectangle", 0, Polygon(rectangle_vertices(*RECT))),
]


def test_one_tolerance() -> None:
    assert MODEL_TOL == L_VIO_TOL == C5_TOL
    assert PLANNER.tol >= L_VIO_TOL
    assert L_VIO_TOL <= 1e-13 * 1e4  # float rounding scale of a 10 km map


def test_half_millimetre_cut_into_a_circle_counts_in_both() -> None:
    y = CY + R - 5e-4  # 0.5 mm deep
    a, b = np.array([CX - 300.0, y]), np.array([CX + 300.0, y])
    chord = 2 * math.sqrt(R * R - (R - 5e-4) ** 2)
    assert float(overlap_lengths(a, b, PLANNER)) > L_VIO_TOL
    sim = float(sim_overlaps(np.stack([a, b]), SIM[:1]).sum())
    assert sim > C5_TOL
    assert math.isclose(sim, chord, rel_tol=1e-6)


def _near_legs(seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Legs tangent to / along / through corners of the obstacles, nudged by -1e-6..1e-6 m."""
    rng = np.random.default_rng(seed)
    a, b = [], []
    rv = rectangle_vertices(*RECT)
    for _ in range(n):
        nudge = rng.choice([0.0, 1.0]) * rng.uniform(-1e-6, 1e-6) + rng.uniform(-1e-9, 1e-9)
        if rng.random() < 0.5:  # near a circle's tangent
            th = rng.uniform(0, 2 * math.pi)
            nv = np.array([math.cos(th), math.sin(th)])
            u = np.array([-nv[1], nv[0]])
            p = np.array([CX, CY]) + (R + nudge) * nv
            a.append(p - rng.uniform(1, 500) * u)
            b.append(p + rng.uniform(-50, 500) * u)
        else:  # near an edge line or a corner of the rectangle
            i = rng.integers(4)
            e = rv[(i + 1) % 4] - rv[i]
            out = np.array([e[1], -e[0]]) / np.linalg.norm(e)
            s0, s1 = rng.uniform(-0.5, 1.5, size=2)
            a.append(rv[i] + s0 * e + nudge * out)
            b.append(rv[i] + s1 * e + nudge * out + rng.choice([0.0, 1e-7]) * out)
    return np.array(a), np.array(b)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_called_free_means_no_positive_overlap_in_the_sim(seed: int) -> None:
    a, b = _near_legs(seed, 64)
    planner = overlap_lengths(a, b, PLANNER)
    for k in np.flatnonzero(planner <= L_VIO_TOL):
        sim = sim_overlaps(np.stack([a[k], b[k]]), SIM)
        assert float(sim.sum()) <= C5_TOL, (a[k], b[k], sim)  # the sim passes C5
