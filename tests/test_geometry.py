"""L_vio geometry: hand-computed cases, fast kernel vs reference (hypothesis), helpers."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, MultiPoint, Point
from shapely.geometry import Polygon as ShapelyPolygon

from planner_core.model.geometry import (
    Obstacles,
    overlap_lengths,
    overlap_lengths_reference,
    points_inside,
    rectangle_vertices,
)

ATOL = 1e-6  # metres


def _one(a, b, obs: Obstacles) -> float:
    """Fast path for a single leg, checked against the reference on the way."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    fast = float(overlap_lengths(a, b, obs))
    ref = float(overlap_lengths_reference(a, b, obs))
    assert fast == pytest.approx(ref, abs=ATOL)
    return fast


# --------------------------------------------------------------------------- hand-computed

CIRCLE = Obstacles.build([(0.0, 0.0, 50.0)], [])
SQUARE = Obstacles.build([], [np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])])


def test_leg_through_circle_centre() -> None:
    assert _one((-100, 0), (100, 0), CIRCLE) == pytest.approx(100.0, abs=1e-8)


def test_chord_at_offset() -> None:
    d = 30.0
    expect = 2 * math.sqrt(50.0**2 - d**2)  # 80
    assert _one((-100, d), (100, d), CIRCLE) == pytest.approx(expect, abs=1e-8)
    # same chord on a slanted leg: rotate everything by 37 degrees
    th = math.radians(37.0)
    rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    a, b = rot @ [-100.0, d], rot @ [100.0, d]
    assert _one(a, b, CIRCLE) == pytest.approx(expect, abs=1e-8)


def test_tangent_leg_counts_as_touching() -> None:
    # the rounding band is resolved towards the violation: a tangent touches the circle
    touch = 2 * math.sqrt(2 * 50.0 * CIRCLE.tol)  # chord of the circle inflated by tol
    assert _one((-100, 50), (100, 50), CIRCLE) == pytest.approx(touch, rel=1e-3)
    assert _one((50, -100), (50, 100), CIRCLE) > 0.0
    th = math.radians(23.0)
    n = np.array([math.cos(th), math.sin(th)])
    u = np.array([-n[1], n[0]])
    assert _one(50 * n - 300 * u, 50 * n + 300 * u, CIRCLE) > 0.0
    # clear of it by a micrometre: exactly 0
    assert _one((-100, 50 + 1e-6), (100, 50 + 1e-6), CIRCLE) == 0.0
    # a leg cutting 0.5 mm deep counts its chord (paper C5: a positive overlap is a violation)
    assert _one((-100, 50 - 5e-4), (100, 50 - 5e-4), CIRCLE) == pytest.approx(
        2 * math.sqrt(50.0**2 - (50 - 5e-4) ** 2), abs=1e-5
    )
    # just inside the tangent: a short chord, not 0
    assert _one((-100, 49.0), (100, 49.0), CIRCLE) == pytest.approx(2 * math.sqrt(99.0))


def test_leg_ending_inside_and_wholly_inside() -> None:
    assert _one((-100, 0), (0, 0), CIRCLE) == pytest.approx(50.0)
    assert _one((10, 20), (-100, 20), CIRCLE) == pytest.approx(10 + math.sqrt(50**2 - 20**2))
    assert _one((-10, 5), (10, 5), CIRCLE) == pytest.approx(20.0)
    big = Obstacles.build([], [SQUARE.polygon(0) * 10])  # [0, 20]^2
    assert _one((2, 1), (7, 7), big) == pytest.approx(math.hypot(5, 6))
    assert _one((10, 10), (30, 10), big) == pytest.approx(10.0)


def test_zero_length_leg() -> None:
    assert _one((0, 0), (0, 0), CIRCLE) == 0.0
    assert _one((1, 1), (1, 1), SQUARE) == 0.0
    assert _one((1e3, 1e3), (1e3, 1e3), CIRCLE) == 0.0


def test_rotated_rectangle_crossed_along_its_axes() -> None:
    c = np.array([1000.0, 2000.0])
    rect = Obstacles.build([], [rectangle_vertices(*c, 180.0, 80.0, 30.0)])
    th = math.radians(30.0)
    u = np.array([math.cos(th), math.sin(th)])
    v = np.array([-u[1], u[0]])
    assert _one(c - 200 * u, c + 200 * u, rect) == pytest.approx(180.0, abs=1e-8)
    assert _one(c - 200 * v, c + 200 * v, rect) == pytest.approx(80.0, abs=1e-8)
    # parallel to the long axis, 30 m off centre: still the full length
    assert _one(c - 200 * u + 30 * v, c + 200 * u + 30 * v, rect) == pytest.approx(180.0)


def test_leg_through_a_corner() -> None:
    # touches the corner (0, 0) only, from outside: counts as touching (a tiny overlap)
    assert 0.0 < _one((-1, 1), (1, -1), SQUARE) < 1e-8
    assert _one((-1, 1 - 1e-6), (1 - 1e-6, -1), SQUARE) == 0.0
    # the diagonal through two corners lies inside
    assert _one((-1, -1), (3, 3), SQUARE) == pytest.approx(2 * math.sqrt(2))
    # corner-to-corner on a rotated rectangle: the diagonal
    v = rectangle_vertices(500.0, -300.0, 120.0, 90.0, 63.0)
    rect = Obstacles.build([], [v])
    assert _one(v[0], v[2], rect) == pytest.approx(150.0)
    # a corner grazed from outside, perpendicular to the corner's bisector
    corner = v[1]
    bisector = (v[1] - v[3]) / np.linalg.norm(v[1] - v[3])
    perp = np.array([-bisector[1], bisector[0]])
    assert 0.0 < _one(corner - 200 * perp, corner + 200 * perp, rect) < 1e-7
    assert _one(corner - 200 * perp + 1e-6 * bisector, corner + 200 * perp + 1e-6 * bisector,
                rect) == 0.0  # fmt: skip


def test_leg_along_an_edge_counts_its_length() -> None:
    # the closed obstacle: flying along an edge touches it all the way (rounding band -> C5)
    assert _one((-1, 0), (3, 0), SQUARE) == pytest.approx(2.0)
    assert _one((2, -5), (2, 5), SQUARE) == pytest.approx(2.0)
    assert _one((0.5, 2), (1.5, 2), SQUARE) == pytest.approx(1.0)
    assert _one((-1, -1e-6), (3, -1e-6), SQUARE) == 0.0  # a micrometre off: clear
    v = rectangle_vertices(1000.0, 2000.0, 180.0, 80.0, 30.0)
    rect = Obstacles.build([], [v])
    for i in range(4):
        e = v[(i + 1) % 4] - v[i]
        assert _one(v[i], v[(i + 1) % 4], rect) == pytest.approx(np.linalg.norm(e))
        # extended beyond both corners: endpoints rounded off the edge line by ~1e-13
        got = float(overlap_lengths(v[i] - 0.5 * e, v[i] + 1.5 * e, rect))
        assert got == pytest.approx(np.linalg.norm(e), abs=1e-6)


def test_triangle_no_fly_zone() -> None:
    tri = Obstacles.build([], [np.array([[0.0, 0.0], [4000.0, 0.0], [0.0, 3000.0]])])
    assert _one((-1000, 1500), (5000, 1500), tri) == pytest.approx(2000.0)
    # along the hypotenuse direction, 300 m inside: parallel chord
    assert _one((-1000, 1000), (1000, 1000), tri) == pytest.approx(1000.0)
    assert _one((0, 3000), (4000, 0), tri) == pytest.approx(5000.0)  # the hypotenuse itself
    # in through the corner (0, 0), out through the hypotenuse at (2000, 1500)
    assert _one((-1000, -750), (4000, 3000), tri) == pytest.approx(2500.0)


def test_overlapping_obstacles_count_once_each() -> None:
    two = Obstacles.build([(0.0, 0.0, 50.0), (30.0, 0.0, 50.0)], [])
    assert _one((-100, 0), (200, 0), two) == pytest.approx(200.0)
    mixed = Obstacles.build(
        [(0.0, 0.0, 50.0)], [rectangle_vertices(0.0, 0.0, 60.0, 20.0, 0.0), SQUARE.polygon(0)]
    )
    assert _one((-100, 1), (100, 1), mixed) == pytest.approx(2 * math.sqrt(50**2 - 1) + 60 + 2)


def test_shapes_broadcasting_and_special_values() -> None:
    rng = np.random.default_rng(1)
    obs = Obstacles.build([(0.0, 0.0, 50.0)], [rectangle_vertices(100, 0, 50, 50, 10)])
    a = rng.uniform(-200, 200, size=(7, 5, 2))
    b = rng.uniform(-200, 200, size=(7, 5, 2))
    out = overlap_lengths(a, b, obs)
    assert out.shape == (7, 5)
    np.testing.assert_allclose(out, overlap_lengths_reference(a, b, obs), atol=ATOL)
    # a shared start point broadcasts; non-contiguous views and int input are accepted
    np.testing.assert_allclose(overlap_lengths(np.zeros(2), b, obs), overlap_lengths(0 * a, b, obs))
    np.testing.assert_allclose(overlap_lengths(a[:, ::2], b[:, ::2], obs), out[:, ::2])
    got = float(overlap_lengths(np.array([-100, 0]), np.array([50, 0]), obs))
    assert got == pytest.approx(100.0, abs=1e-8)
    assert overlap_lengths(np.zeros((0, 2)), np.zeros((0, 2)), obs).shape == (0,)
    res = overlap_lengths(np.array([[np.nan, 0.0], [-100, 0]]), np.array([[1, 1], [50, 0]]), obs)
    assert math.isnan(res[0]) and res[1] == pytest.approx(100.0)
    empty = Obstacles.build([], [])
    assert empty.n_polygons == 0 and np.all(overlap_lengths(a, b, empty) == 0.0)
    with pytest.raises(ValueError):
        overlap_lengths(np.zeros((3, 3)), np.zeros((3, 3)), obs)


def test_batch_independence_and_threads() -> None:
    # each leg's answer does not depend on the rest of the batch; the kernel releases the GIL
    from concurrent.futures import ThreadPoolExecutor

    rng = np.random.default_rng(2)
    circles = [(*rng.uniform(0, 1e4, 2), rng.uniform(40, 100)) for _ in range(30)]
    rects = [
        rectangle_vertices(*rng.uniform(0, 1e4, 2), 150, 90, rng.uniform(0, 180)) for _ in "abc"
    ]
    obs = Obstacles.build(circles, rects)
    a = rng.uniform(0, 1e4, size=(500, 2))
    b = rng.uniform(0, 1e4, size=(500, 2))
    whole = overlap_lengths(a, b, obs)
    assert np.any(whole > 0)
    with ThreadPoolExecutor(2) as pool:
        parts = list(
            pool.map(lambda s: overlap_lengths(a[s], b[s], obs), np.array_split(range(500), 7))
        )
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    np.testing.assert_array_equal([overlap_lengths(a[i], b[i], obs) for i in range(9)], whole[:9])


def test_far_coordinates_take_the_exact_fallback() -> None:
    # beyond the float32 culling range: every obstacle is tested exactly
    obs = Obstacles.build([(0.0, 0.0, 50.0)], [rectangle_vertices(0, 0, 10, 10, 0)])
    a = np.array([[-1e16, 0.0], [-1e16, 1e16]])
    b = np.array([[1e16, 0.0], [-1e16, 2e16]])
    out = overlap_lengths(a, b, obs)
    assert out[0] == pytest.approx(110.0, abs=8.0)  # ulp(1e16) = 2
    assert out[1] == 0.0


# --------------------------------------------------------------------------- helpers


@pytest.mark.parametrize("angle", [0.0, 30.0, 90.0, 145.0, 180.0, 271.0, -60.0])
def test_rectangle_vertices_orientation(angle: float) -> None:
    v = rectangle_vertices(10.0, -20.0, 180.0, 80.0, angle)
    assert v.shape == (4, 2)
    poly = ShapelyPolygon(v)
    assert poly.exterior.is_ccw and poly.is_valid
    assert poly.area == pytest.approx(180.0 * 80.0)
    np.testing.assert_allclose(v.mean(axis=0), [10.0, -20.0], atol=1e-9)
    first = v[1] - v[0]  # the first edge runs along the length axis
    assert np.linalg.norm(first) == pytest.approx(180.0)
    assert math.degrees(math.atan2(first[1], first[0])) % 360 == pytest.approx(angle % 360)
    assert np.linalg.norm(v[2] - v[1]) == pytest.approx(80.0)


def test_rectangle_vertices_rejects_bad_sides() -> None:
    for length, width in [(0.0, 1.0), (1.0, -1.0), (math.nan, 1.0), (math.inf, 1.0)]:
        with pytest.raises(ValueError):
            rectangle_vertices(0.0, 0.0, length, width, 0.0)


def test_build_validates_and_normalises_polygons() -> None:
    sq = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    closed = Obstacles.build([], [np.vstack([sq, sq[:1]])])  # shapely-style closed ring
    assert closed.n_polygons == 1 and len(closed.polygon(0)) == 4
    for bad in (sq[::-1], sq[[0, 2, 1, 3]], sq[:2], np.array([[0, 0], [1, 0], [2, 0.0]])):
        with pytest.raises(ValueError):
            Obstacles.build([], [bad])
    pentagram = np.array([[math.cos(t), math.sin(t)] for t in np.arange(5) * 4 * math.pi / 5])
    with pytest.raises(ValueError):
        Obstacles.build([], [pentagram])
    with pytest.raises(ValueError):
        Obstacles.build([(0.0, 0.0, 0.0)], [])
    # direct construction from the packed arrays gives the same object
    direct = Obstacles(np.zeros((0, 3)), sq, np.array([0, 4]))
    assert direct.n_polygons == 1 and direct.n_circles == 0
    got = float(overlap_lengths(np.array([-1.0, 1]), np.array([3.0, 1]), direct))
    assert got == pytest.approx(2.0, abs=1e-8)
    assert not direct.poly_vertices.flags.writeable  # frozen means frozen ...
    assert sq.flags.writeable  # ... without freezing the caller's array


def test_points_inside() -> None:
    obs = Obstacles.build(
        [(0.0, 0.0, 50.0)], [rectangle_vertices(200.0, 0.0, 100.0, 40.0, 30.0), SQUARE.polygon(0)]
    )
    corner = rectangle_vertices(200.0, 0.0, 100.0, 40.0, 30.0)[2]
    pts = np.array(
        [
            [0, 0],
            [49.9, 0],
            [50, 0],
            [0, -50],
            [60, 0],
            [200, 0],
            [250, 0],
            [1, 1],
            [2, 1],
            [200, 18],
        ]
    )
    expect = [True, True, False, False, False, True, False, True, True, True]
    # the square [0, 2]^2 sits inside the circle: its edges are inside the circle, but a square
    # alone has only its open interior
    sq = Obstacles.build([], [SQUARE.polygon(0)])
    np.testing.assert_array_equal(
        points_inside(np.array([[1, 1], [2, 1], [0, 0], [1, 2], [1, 2.5], [1e-12, 1]]), sq),
        [True, False, False, False, False, False],
    )
    np.testing.assert_array_equal(points_inside(pts, obs), expect)
    assert not points_inside(corner, obs)
    assert points_inside(pts.reshape(2, 5, 2), obs).shape == (2, 5)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-1000, 1000), st.floats(-1000, 1000)), min_size=1, max_size=20),
    st.integers(0, 2**32 - 1),
)
def test_points_inside_matches_shapely(points: list[tuple[float, float]], seed: int) -> None:
    rng = np.random.default_rng(seed)
    circles = [(*rng.uniform(-800, 800, 2), rng.uniform(10, 300)) for _ in range(3)]
    polys = [rectangle_vertices(*rng.uniform(-800, 800, 2), 300, 150, rng.uniform(0, 180))]
    polys.append(_hull(rng.uniform(-900, 900, size=(8, 2))))
    obs = Obstacles.build(circles, polys)
    got = points_inside(np.array(points), obs)
    shapes = [Point(cx, cy).buffer(r, quad_segs=512) for cx, cy, r in circles]
    shapes += [ShapelyPolygon(p) for p in polys]
    for (x, y), inside in zip(points, got, strict=True):
        p = Point(x, y)
        near = min(s.exterior.distance(p) for s in shapes)
        exact_circles = any(math.hypot(x - cx, y - cy) < r for cx, cy, r in circles)
        if near > 1e-3 or exact_circles:  # skip points on (or within 1 mm of) a boundary
            expect = exact_circles or any(ShapelyPolygon(q).contains(p) for q in polys)
            assert inside == expect


# --------------------------------------------------------------------------- property tests


def _hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of points as a CCW (V, 2) array (may be degenerate: callers filter)."""
    hull = MultiPoint([tuple(p) for p in points]).convex_hull
    if hull.geom_type != "Polygon":
        return np.zeros((0, 2))
    ring = np.asarray(hull.exterior.coords)[:-1]
    return ring if ShapelyPolygon(ring).exterior.is_ccw else ring[::-1]


def _well_formed(v: np.ndarray, min_feature: float = 1e-3) -> bool:
    """At least a triangle with no near-duplicate or near-collinear vertices (1 mm)."""
    if len(v) < 3:
        return False
    for i in range(len(v)):
        p, q, r = v[i - 1], v[i], v[(i + 1) % len(v)]
        base = np.linalg.norm(r - p)
        if np.linalg.norm(q - p) < min_feature or base < min_feature:
            return False
        height = abs((r - p)[0] * (q - p)[1] - (r - p)[1] * (q - p)[0]) / base
        if height < min_feature:
            return False
    return True


# coordinates on a 1 um grid: GEOS (the reference) mis-clips legs with coordinates like 1e-236
# (underflow), which hypothesis otherwise finds; real maps are nowhere near that
coord = st.floats(-1000.0, 1000.0, allow_nan=False, allow_infinity=False).map(lambda x: round(x, 6))
point = st.tuples(coord, coord)


@st.composite
def circles_st(draw) -> tuple[float, float, float]:
    x, y = draw(point)
    return (x, y, draw(st.floats(1.0, 400.0)))


@st.composite
def rect_st(draw) -> np.ndarray:
    x, y = draw(point)
    return rectangle_vertices(
        x,
        y,
        draw(st.floats(1.0, 500.0)),
        draw(st.floats(1.0, 500.0)),
        draw(st.floats(-360.0, 360.0)),
    )


@st.composite
def hull_st(draw) -> np.ndarray:
    pts = np.array(draw(st.lists(point, min_size=3, max_size=9)))
    v = _hull(pts)
    assume(_well_formed(v))
    return v


@st.composite
def obstacles_st(draw) -> Obstacles:
    circles = draw(st.lists(circles_st(), max_size=4))
    polys = draw(st.lists(st.one_of(rect_st(), hull_st()), max_size=4))
    assume(circles or polys)
    if draw(st.booleans()) and circles:
        # deliberately overlapping: a copy of a circle shifted by less than its radius, and a
        # rectangle around a circle's centre
        cx, cy, r = circles[0]
        circles.append((cx + 0.5 * r, cy - 0.3 * r, 0.8 * r))
        polys.append(rectangle_vertices(cx, cy, 1.5 * r, 0.7 * r, 17.0))
    return Obstacles.build(circles, polys)


@st.composite
def legs_st(draw, obs: Obstacles) -> tuple[np.ndarray, np.ndarray]:
    """Random legs plus the special families: tangents, corner grazes, vertex-to-vertex legs
    (edges and diagonals), legs wholly inside, zero-length legs, legs along axis-aligned edges."""
    a_list, b_list = [], []

    def add(a, b) -> None:
        a_list.append(np.asarray(a, dtype=float))
        b_list.append(np.asarray(b, dtype=float))

    for _ in range(draw(st.integers(1, 6))):
        add(draw(point), draw(point))
    frac = st.floats(0.0, 1.0)
    length = st.floats(1.0, 2000.0)
    angle = st.floats(0.0, 2 * math.pi)
    for cx, cy, r in obs.circles.tolist():
        c = np.array([cx, cy])
        th = draw(angle)
        n = np.array([math.cos(th), math.sin(th)])
        u = np.array([-n[1], n[0]])
        add(c + r * n - draw(length) * u, c + r * n + draw(length) * u)  # tangent
        add(c + r * n - draw(length) * u, c + r * n)  # tangent, ends at the touch point
        p = c + draw(frac) * 0.99 * r * n
        q = c + draw(frac) * 0.99 * r * u
        add(p, q)  # wholly inside
        add(p, p)  # zero length
        add(c + r * n, c - r * n)  # a diameter ending on the boundary
        add(c + r * n, c + r * u)  # a chord between boundary points
    for k in range(obs.n_polygons):
        v = np.asarray(obs.polygon(k))
        nv = len(v)
        i = draw(st.integers(0, nv - 1))
        j = draw(st.integers(0, nv - 1))
        add(v[i], v[(i + 1) % nv])  # an edge
        add(v[i], v[j])  # an edge, a diagonal or a point
        # grazing corner i from outside: perpendicular to the corner's outward bisector
        e_in = v[i] - v[i - 1]
        e_out = v[(i + 1) % nv] - v[i]
        bis = e_in / np.linalg.norm(e_in) - e_out / np.linalg.norm(e_out)
        bis = np.array([bis[1], -bis[0]])
        if np.linalg.norm(bis) > 1e-9:
            t = bis / np.linalg.norm(bis)
            add(v[i] - draw(length) * t, v[i] + draw(length) * t)
        # wholly inside: convex combinations of vertices
        w1, w2 = (np.array(draw(st.lists(frac, min_size=nv, max_size=nv))) + 1e-3 for _ in "ab")
        p1, p2 = (w / w.sum() @ v for w in (w1, w2))
        add(p1, p2)
        add(p1, p1)
        add(p1, p1 + draw(length) * (p2 - p1) / max(np.linalg.norm(p2 - p1), 1e-9))  # exits
    # legs along the edges of an axis-aligned box with dyadic coordinates
    return np.array(a_list), np.array(b_list)


@settings(
    max_examples=int(os.environ.get("GEOMETRY_EXAMPLES", 150)),
    deadline=None,
    suppress_health_check=[HealthCheck.filter_too_much],
)
@given(st.data())
@pytest.mark.slow  # measured 9 s (issue 35: default suite <= 5 min)
def test_fast_matches_reference(data) -> None:
    obs = data.draw(obstacles_st())
    a, b = data.draw(legs_st(obs))
    fast = overlap_lengths(a, b, obs)
    ref = overlap_lengths_reference(a, b, obs)
    np.testing.assert_allclose(fast, ref, rtol=0, atol=ATOL)
    # direction does not matter
    np.testing.assert_allclose(overlap_lengths(b, a, obs), fast, rtol=0, atol=ATOL)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(-50, 50),
    st.integers(-50, 50),
    st.integers(1, 40),
    st.integers(1, 40),
    st.lists(st.tuples(st.integers(-100, 100), st.integers(-100, 100)), min_size=2, max_size=8),
)
def test_axis_aligned_edges_exact(x: int, y: int, w: int, h: int, pts: list) -> None:
    # integer geometry: legs exactly along edges, through corners, along diagonals
    box = np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]], dtype=float)
    obs = Obstacles.build([(x, y, w)], [box])
    corners = [tuple(c) for c in box]
    ends = np.array(pts + corners + [(x + w, y - 5), (x - 3, y + h)], dtype=float)
    a = np.repeat(ends, len(ends), axis=0)
    b = np.tile(ends, (len(ends), 1))
    np.testing.assert_allclose(
        overlap_lengths(a, b, obs), overlap_lengths_reference(a, b, obs), rtol=0, atol=ATOL
    )


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from([0.0, 3e3, 1e5, 1e6]),
    st.floats(10.0, 400.0),
    st.floats(0.0, 2 * math.pi),
    st.floats(1e-6, 2.0),
    st.floats(-3000.0, 3000.0),
)
def test_grazing_legs_far_from_origin(offset, r, th, depth, shift) -> None:
    # the float32 culling pass must never drop a leg that dips just inside, wherever the map is
    c = np.array([offset + 123.0, -offset + 45.0])
    n = np.array([math.cos(th), math.sin(th)])
    u = np.array([-n[1], n[0]])
    rect = rectangle_vertices(*(c + 3 * r * u), r, r, math.degrees(th))
    obs = Obstacles.build([(*c, r), (*(c + 2.5 * r * n), 0.3 * r)], [rect])
    base = c + (r - depth) * n + shift * u
    # along an edge inside the rounding band (counts as touching) and clearly outside it (0)
    corner = np.asarray(obs.polygon(0))[0] - 0.5 * obs.tol * n
    clear = np.asarray(obs.polygon(0))[0] - (depth * 0.1 + 3 * obs.tol) * n
    a = np.array([base - 5000 * u, base + 0.5 * u, corner - 400 * u, c - 5000 * n, clear])
    b = np.array([base + 5000 * u, base + 1.0 * u, corner + 400 * u, c + 5000 * n, clear + u])
    fast = overlap_lengths(a, b, obs)
    assert fast[0] > 0.0
    assert fast[2] >= r and fast[4] == 0.0
    np.testing.assert_allclose(fast, overlap_lengths_reference(a, b, obs), rtol=0, atol=ATOL)


@settings(max_examples=40, deadline=None)
@given(st.lists(circles_st(), min_size=1, max_size=3), st.integers(0, 2**32 - 1))
def test_circles_against_buffered_shapely(circles, seed) -> None:
    # shapely's circle is an inscribed polygon with n = 4 * quad_segs sides: every chord of it is
    # within [chord(r cos(pi / n)), chord(r)], which bounds the difference to the exact chord
    quad_segs = 256
    cos_n = math.cos(math.pi / (4 * quad_segs))
    obs = Obstacles.build(circles, [])
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1500, 1500, size=(30, 2))
    b = rng.uniform(-1500, 1500, size=(30, 2))
    for cx, cy, r in circles[:1]:  # legs through the first circle, too
        a[:10] = rng.uniform(-r, r, size=(10, 2)) * 0.7 + (cx, cy)
    fast = overlap_lengths(a, b, obs)
    disks = [Point(cx, cy).buffer(r, quad_segs=quad_segs) for cx, cy, r in circles]
    for m in range(len(a)):
        leg = LineString([a[m], b[m]])
        approx = sum(leg.intersection(d).length for d in disks)
        bound = 1e-9
        for cx, cy, r in circles:
            d = b[m] - a[m]
            h = abs(d[0] * (cy - a[m, 1]) - d[1] * (cx - a[m, 0])) / max(np.linalg.norm(d), 1e-300)
            chord = 2 * math.sqrt(max(r * r - h * h, 0.0))
            chord_in = 2 * math.sqrt(max((r * cos_n) ** 2 - h * h, 0.0))
            bound += chord - chord_in
        assert abs(fast[m] - approx) <= bound
