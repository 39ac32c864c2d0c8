"""Any simple polygon as an obstacle: cleaning, convex pieces, exact L_vio (issue 15).

Three implementations must agree on non-convex polygons with holes: the compiled kernel on the
convex pieces (`overlap_lengths`), the reference measuring each region whole with shapely
(`overlap_lengths_reference`) and the simulator's own shapely check (`sim.obstacles`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString
from shapely.geometry import Polygon as ShapelyPolygon

from planner_core.model.geometry import (
    Obstacles,
    overlap_lengths,
    overlap_lengths_reference,
    points_inside,
)
from planner_core.model.polygons import (
    EDGE_BOUNDARY,
    EDGE_OWNED,
    EDGE_SHARED,
    VERTEX_TOL,
    clean_ring,
    convex_pieces,
    polygon_problem,
)
from sim.obstacles import Obstacle
from sim.obstacles import overlap_lengths as sim_overlap_lengths

ATOL = 1e-6

L_SHAPE = np.array([(0, 0), (100, 0), (100, 10), (10, 10), (10, 100), (0, 100)], dtype=float)
BLOCK = np.array([(0, 0), (100, 0), (100, 100), (0, 100)], dtype=float)
COURT = np.array([(20, 20), (20, 80), (80, 80), (80, 20)], dtype=float)  # clockwise hole


def _shapely_inside(a, b, poly: ShapelyPolygon) -> float:
    leg = LineString([tuple(a), tuple(b)])
    return leg.intersection(poly).length - leg.intersection(poly.boundary).length


def _check_pieces(shell: np.ndarray, holes: list[np.ndarray]) -> list[tuple]:
    pieces = convex_pieces(shell, holes)
    whole = ShapelyPolygon(shell, holes)
    shp = [ShapelyPolygon(v) for v, _ in pieces]
    for v, flags in pieces:
        assert ShapelyPolygon(v).exterior.is_ccw
        e = np.roll(v, -1, axis=0) - v
        cross = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
        assert np.all(cross >= 0.0)  # convex
        assert len(flags) == len(v)
    assert sum(p.area for p in shp) == pytest.approx(whole.area, rel=1e-9)
    assert shapely.union_all(shp).symmetric_difference(whole).area < 1e-9 * whole.area
    owned = sum(int(np.sum(f == EDGE_OWNED)) for _, f in pieces)
    shared = sum(int(np.sum(f == EDGE_SHARED)) for _, f in pieces)
    assert owned == shared  # each diagonal: one owner, one neighbour
    return pieces


# --------------------------------------------------------------------------- cleaning


def test_clean_ring_closure_duplicate_collinear() -> None:
    ring = [(0, 0), (50, 0.001), (100, 0), (100, 50), (100.002, 50.001), (0, 50), (0, 0)]
    v, counts = clean_ring(ring)
    assert counts == {"closing": 1, "duplicate": 1, "collinear": 1}
    np.testing.assert_array_equal(v, [[0, 0], [100, 0], [100, 50], [0, 50]])
    # a vertex 1 cm off the edge is a real feature and stays
    v, counts = clean_ring([(0, 0), (50, 0.01), (100, 0), (100, 50), (0, 50)])
    assert len(v) == 5 and counts["collinear"] == 0
    assert VERTEX_TOL == 0.005


def test_clean_ring_keeps_orientation_and_refuses_nan() -> None:
    v, _ = clean_ring(BLOCK[::-1])
    np.testing.assert_array_equal(v, BLOCK[::-1])
    with pytest.raises(ValueError, match="non-finite"):
        clean_ring([(0, 0), (1, math.nan), (0, 1)])


def test_polygon_problem_names_self_intersection() -> None:
    bow = np.array([(0, 0), (400, 400), (400, 0), (0, 400)], dtype=float)
    assert polygon_problem(bow) == "self-intersection at (200, 200)"
    assert polygon_problem(L_SHAPE) is None
    assert polygon_problem(BLOCK, [COURT]) is None
    outside_hole = np.array([(200, 200), (300, 200), (300, 300)], dtype=float)
    assert polygon_problem(BLOCK, [outside_hole]) is not None


# --------------------------------------------------------------------------- decomposition


def test_pieces_of_l_shape_and_courtyard() -> None:
    assert len(_check_pieces(L_SHAPE, [])) == 2
    assert len(_check_pieces(BLOCK, [COURT])) == 4
    (v, flags), = convex_pieces(BLOCK[::-1], [])
    np.testing.assert_array_equal(v, BLOCK)  # convex: one piece, made counter-clockwise
    assert np.all(flags == EDGE_BOUNDARY)


def test_leg_along_internal_diagonal_counted_once() -> None:
    pieces = convex_pieces(L_SHAPE, [])
    diag = {tuple(map(tuple, sorted([tuple(v[i]), tuple(v[(i + 1) % len(v)])])))
            for v, f in pieces for i in range(len(v)) if f[i] != EDGE_BOUNDARY}
    assert len(diag) == 1
    (p, q), = diag
    obs = Obstacles.build([], [], [(L_SHAPE, [])])
    poly = ShapelyPolygon(L_SHAPE)
    p, q = np.array(p), np.array(q)
    d = q - p
    for a, b in [(p, q), (q, p), (p - 0.5 * d, q + 0.5 * d), (p + 0.25 * d, p + 0.75 * d)]:
        want = _shapely_inside(a, b, poly)
        assert want > 1.0
        assert float(overlap_lengths(a, b, obs)) == pytest.approx(want, abs=ATOL)
        assert float(overlap_lengths_reference(a, b, obs)) == pytest.approx(want, abs=ATOL)
    mid = 0.5 * (p + q)
    assert points_inside(mid, obs)  # a point on the diagonal is inside the polygon


def test_boundary_contacts_touch_and_holes_are_free() -> None:
    # C5 is exact and the rounding band counts as inside (planner_core.model.geometry): a leg along
    # a
    # wall touches it for its whole length; a courtyard's inside is free
    obs = Obstacles.build([], [], [(L_SHAPE, []), (BLOCK + 200.0, [COURT + 200.0])])
    legs = [
        ((-10, 0), (120, 0)),  # along the L's bottom edge
        ((10, 10), (10, 150)),  # along the inner edge of the vertical arm
        ((100, 10), (10, 10)),  # along the inner edge of the horizontal arm
        ((220, 230), (220, 270)),  # along the courtyard's wall
        ((230, 230), (270, 270)),  # inside the courtyard
        ((150, 250), (350, 250)),  # across the block and its courtyard: 2 x 20 m
    ]
    want = [100, 90, 90, 40, 0, 40]  # wall lengths touched; none inside the courtyard
    for (a, b), w in zip(legs, want, strict=True):
        assert float(overlap_lengths(np.array(a, float), np.array(b, float), obs)) == \
            pytest.approx(w, abs=ATOL)
    assert not points_inside(np.array([250.0, 250.0]), obs)  # the courtyard is flyable
    assert points_inside(np.array([210.0, 250.0]), obs)


def test_obstacles_build_refuses_bad_edge_flags() -> None:
    o = Obstacles.build([], [BLOCK])
    with pytest.raises(ValueError, match="edge_flags"):
        Obstacles(o.circles, o.poly_vertices, o.poly_offsets, edge_flags=np.zeros(3))


# --------------------------------------------------------------------------- property tests


@st.composite
def star_polygon(draw) -> tuple[np.ndarray, list[np.ndarray]]:
    """A random star-shaped polygon (simple by construction), often with a hole."""
    n = draw(st.integers(3, 12))
    cx = draw(st.floats(-300, 300)).__round__(3)
    cy = draw(st.floats(-300, 300)).__round__(3)
    gaps = np.array(draw(st.lists(st.floats(0.2, 1.0), min_size=n, max_size=n)))
    ang = np.cumsum(gaps) / gaps.sum() * 2 * math.pi
    rad = np.array(draw(st.lists(st.floats(30.0, 200.0), min_size=n, max_size=n)))
    shell = np.round(np.column_stack([cx + rad * np.cos(ang), cy + rad * np.sin(ang)]), 3)
    holes = []
    if draw(st.booleans()) and np.max(np.diff(np.r_[0.0, ang])) < 2 * math.pi / 3:
        m = draw(st.integers(3, 6))
        hr = np.array(draw(st.lists(st.floats(3.0, 12.0), min_size=m, max_size=m)))
        ha = np.linspace(0, 2 * math.pi, m, endpoint=False) + draw(st.floats(0, 1))
        holes.append(np.round(np.column_stack([cx + hr * np.cos(ha), cy + hr * np.sin(ha)]), 3))
    return shell, holes


def _usable(shell: np.ndarray, holes: list[np.ndarray]) -> bool:
    v, _ = clean_ring(shell)
    return len(v) == len(shell) and polygon_problem(shell, holes) is None


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(star_polygon(), st.integers(0, 2**32 - 1))
@pytest.mark.slow  # measured 1.7 s on a loaded machine (default suite <= 5 min)
def test_random_polygons_kernel_reference_and_sim_agree(shape, seed) -> None:
    shell, holes = shape
    assume(_usable(shell, holes))
    _check_pieces(shell, holes)
    obs = Obstacles.build([], [], [(shell, holes)])
    rng = np.random.default_rng(seed)
    lo, hi = shell.min(axis=0) - 30, shell.max(axis=0) + 30
    a = lo + rng.random((40, 2)) * (hi - lo)
    b = lo + rng.random((40, 2)) * (hi - lo)
    # legs through vertices and along diagonals / edges as well
    verts = np.concatenate([shell, *holes])
    i, j = rng.integers(0, len(verts), (2, 20))
    a = np.vstack([a, verts[i]])
    b = np.vstack([b, verts[j]])
    fast = overlap_lengths(a, b, obs)
    ref = overlap_lengths_reference(a, b, obs)
    np.testing.assert_allclose(fast, ref, rtol=0, atol=ATOL)
    poly = ShapelyPolygon(shell, holes)
    sim = sim_overlap_lengths(np.stack([a[:40], b[:40]], axis=1).reshape(-1, 2),
                              [Obstacle("polygon", 0, poly)])[::2, 0]  # fmt: skip
    np.testing.assert_allclose(fast[:40], sim, rtol=0, atol=ATOL)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.integers(0, 5), st.integers(0, 5)), min_size=1, max_size=20),
       st.integers(0, 2**32 - 1))
@pytest.mark.slow  # measured 1.6 s on a loaded machine (default suite <= 5 min)
def test_rectilinear_footprints_with_grid_legs(cells, seed) -> None:
    """Unions of grid cells (L-, U-shapes, courtyards); legs between grid points run along
    edges and diagonals, through reflex corners: the kernel must still equal shapely."""
    geom = shapely.union_all([shapely.box(10 * x, 10 * y, 10 * x + 10, 10 * y + 10)
                              for x, y in cells])  # fmt: skip
    regions = []
    for part in shapely.get_parts(geom):
        shell, _ = clean_ring(np.asarray(part.exterior.coords))
        holes = [clean_ring(np.asarray(h.coords))[0] for h in part.interiors]
        assume(polygon_problem(shell, holes) is None)  # cells touching at a corner only
        _check_pieces(shell, holes)
        regions.append((shell, holes))
    obs = Obstacles.build([], [], regions)
    rng = np.random.default_rng(seed)
    a = rng.integers(-1, 8, (60, 2)) * 10.0
    b = rng.integers(-1, 8, (60, 2)) * 10.0
    fast = overlap_lengths(a, b, obs)
    # the closed shapes: legs along walls touch them (the kernel's conservative boundary band)
    want = np.array([sum(shapely.LineString([p, q]).intersection(ShapelyPolygon(s, h)).length
                         if tuple(p) != tuple(q) else 0.0 for s, h in regions)
                     for p, q in zip(a, b, strict=True)])  # fmt: skip
    np.testing.assert_allclose(fast, want, rtol=0, atol=ATOL)
    mid = 0.5 * (a + b)
    inside = points_inside(mid, obs)
    expect = [any(ShapelyPolygon(s, h).contains(shapely.Point(*m)) for s, h in regions)
              for m in mid]  # fmt: skip
    np.testing.assert_array_equal(inside, expect)


def test_many_obstacles_tiled_kernel_matches_reference() -> None:
    """From 256 obstacles on, the kernel culls by tiles first: same answers as the reference."""
    from planner_core.model.geometry import _TILE_MIN

    rng = np.random.default_rng(3)
    circles = [(x, y, r) for x, y, r in zip(rng.uniform(0, 3000, 150), rng.uniform(0, 3000, 150),
                                            rng.uniform(5, 40, 150), strict=True)]  # fmt: skip
    squares = [np.array([(x, y), (x + 30, y), (x + 30, y + 30), (x, y + 30)])
               for x, y in rng.uniform(0, 3000, (100, 2))]  # fmt: skip
    regions = [(L_SHAPE * 0.5 + rng.uniform(0, 3000, 2), []) for _ in range(60)]
    obs = Obstacles.build(circles, squares, regions)
    assert len(obs.cull_radii) >= _TILE_MIN and len(obs.tile_offsets) > 2
    a = rng.uniform(-100, 3100, (300, 2))
    b = rng.uniform(-100, 3100, (300, 2))
    fast = overlap_lengths(a, b, obs)
    assert np.count_nonzero(fast) > 100
    np.testing.assert_allclose(fast, overlap_lengths_reference(a, b, obs), rtol=0, atol=ATOL)
    short_b = a + rng.uniform(-60, 60, (300, 2))  # short legs: most tiles culled
    np.testing.assert_allclose(overlap_lengths(a, short_b, obs),
                               overlap_lengths_reference(a, short_b, obs), rtol=0, atol=ATOL)


def test_seeder_routes_around_non_convex_footprints() -> None:
    """A U-shaped hall and an L between start and the sensors: the graph's edges and the
    seeded routes stay clear of the real shapes (never through a building along a cut)."""
    from planner_core import Problem, load_map
    from planner_core.model.seeding import Seeder

    u = [[1000, 1000], [3000, 1000], [3000, 3000], [2600, 3000], [2600, 1400], [1400, 1400],
         [1400, 3000], [1000, 3000]]  # fmt: skip
    ell = [[3400, 600], [4400, 600], [4400, 900], [3700, 900], [3700, 2400], [3400, 2400]]
    m = load_map({
        "area": {"width": 5000, "height": 5000}, "start": [2000, 300], "end": [2000, 4700],
        "sensors": [{"id": "a", "x": 2000, "y": 2200}, {"id": "b", "x": 4000, "y": 1500},
                    {"id": "c", "x": 500, "y": 4500}],
        "obstacles": {"polygons": [{"vertices": u, "name": "U"}, {"vertices": ell}]},
    })  # fmt: skip
    assert m.obstacles.n_regions == 2
    p = Problem(m)
    s = Seeder.for_problem(p)
    g = s.graph
    assert g.n > 0 and len(g.edges)
    i, j = g.edges[:, 0], g.edges[:, 1]
    assert not overlap_lengths(g.nodes[i], g.nodes[j], m.obstacles).any()
    assert not points_inside(g.nodes, m.obstacles).any()
    rng = np.random.default_rng(0)
    clear = 0
    for _ in range(10):
        hp, _ = s.hover_plan(rng)
        nodes = np.vstack([m.start, hp, m.end])
        legs = overlap_lengths(nodes[:-1], nodes[1:], m.obstacles)
        clear += int(not legs.any())
        assert not points_inside(hp, m.obstacles).any()
    assert clear >= 8, clear  # the starts are collision-free (the DE then keeps them so)
