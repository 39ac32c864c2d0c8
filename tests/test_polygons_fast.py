"""The fast ring cleaning, convex pieces and outer offset equal their references to the bit.

`clean_ring` screens all vertices at once and leaves only those near the tolerance to the
scalar test, `convex_pieces_many` triangulates and orients many polygons together, and
`outer_offset` builds its corners' outer polygons together: each must give exactly what the
plain reference (`_clean_ring_reference`, `_convex_pieces_reference`,
`_outer_offset_reference`) gives, on random rings made to sit at the tolerance and on every
polygon of the campus and example maps (so a map's planning map, and its plans, stay the same).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from planner_core.model import polygons as P
from planner_core.model.geometry import Obstacles
from planner_core.model.mapio import (
    CLEARANCE_PAD,
    OFFSET_OVERSHOOT,
    MapError,
    _obstacle_polygons,
    _outer_offset_reference,
    load_map,
    outer_offset,
)

TOL = P.VERTEX_TOL
MAPS = Path(__file__).resolve().parent.parent / "examples" / "maps"


def _same_ring(points) -> None:
    got, counts = P.clean_ring(points)
    want, want_counts = P._clean_ring_reference(points)
    assert counts == want_counts
    assert got.dtype == want.dtype and got.shape == want.shape
    assert got.tobytes() == want.tobytes()


def _same_pieces(got, want) -> None:
    if isinstance(want, Exception):
        assert type(got) is type(want) and str(got) == str(want)
        return
    assert not isinstance(got, Exception), got
    assert len(got) == len(want)
    for (v, f), (rv, rf) in zip(got, want, strict=True):
        assert v.shape == rv.shape and v.tobytes() == rv.tobytes()
        assert f.dtype == rf.dtype and f.tobytes() == rf.tobytes()


def _reference_pieces(shell, holes):
    try:
        return P._convex_pieces_reference(shell, holes)
    except Exception as exc:  # noqa: BLE001 - the answer compared is the exception itself
        return exc


def _star(rng: np.random.Generator, n: int, radius: float, centre: np.ndarray) -> np.ndarray:
    ang = np.sort(rng.random(n)) * 2 * math.pi
    r = radius * (0.4 + 0.6 * rng.random(n))
    return centre + np.column_stack([r * np.cos(ang), r * np.sin(ang)])


def _at_tolerance(rng: np.random.Generator, ring: np.ndarray) -> np.ndarray:
    """`ring` with vertices added in the middle of edges and beside vertices, at distances
    from within a few roundings of the tolerance to well inside and outside it."""
    out = []
    for k, p in enumerate(ring):
        out.append(p)
        q = ring[(k + 1) % len(ring)]
        kind = rng.integers(0, 6)
        scale = TOL * rng.choice([1.0 - 1e-15, 1.0, 1.0 + 1e-15, 1.0 - 1e-12, 1.0 + 1e-12,
                                  1.0 - 1e-9, 1.0 + 1e-9, 0.5, 0.0, 2.0, 1.0 - 1e-6])
        if kind == 0:  # a vertex beside the edge's middle (or several along it)
            d = q - p
            nrm = np.array([-d[1], d[0]]) / math.hypot(*d)
            for t in np.sort(rng.random(rng.integers(1, 4))):
                out.append(p + t * d + rng.choice([-1.0, 1.0]) * scale * nrm)
        elif kind == 1:  # a near-duplicate (or a run of them)
            for _ in range(rng.integers(1, 4)):
                a = rng.random() * 2 * math.pi
                out.append(out[-1] + scale * np.array([math.cos(a), math.sin(a)]))
        elif kind == 2:  # exactly on the edge
            out.append(p + rng.random() * (q - p))
    ring = np.array(out)
    if rng.random() < 0.3:  # a closing vertex, exactly or within the tolerance
        ring = np.vstack([ring, ring[0] + rng.choice([0.0, 0.5 * TOL, TOL]) * np.array([0.6, 0.8])])
    return ring[::-1].copy() if rng.random() < 0.5 else ring


def _random_rings(seed: int, count: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    rings = []
    for _ in range(count):
        centre = rng.choice([0.0, 500.0, 1e5, -3e5]) + rng.random(2) * 100
        ring = _star(rng, int(rng.integers(3, 40)), float(rng.choice([0.02, 1.0, 50.0])), centre)
        rings.append(_at_tolerance(rng, ring))
    return rings


def test_clean_ring_equals_the_reference_on_rings_at_the_tolerance() -> None:
    for ring in _random_rings(0, 1500):
        _same_ring(ring)


def test_clean_ring_equals_the_reference_on_degenerate_rings() -> None:
    rng = np.random.default_rng(1)
    cases: list = [[], [(1.0, 2.0)], [(0, 0), (0, 0)], [(0, 0), (1, 0), (0, 0)],
                   [(0, 0), (TOL, 0), (2 * TOL, 0), (3 * TOL, 0)],
                   [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]]  # fmt: skip
    cases += [np.column_stack([np.linspace(0, 10, n), np.zeros(n)]) for n in (3, 4, 9)]
    cases += [rng.random((n, 2)) * TOL * 3 for n in range(1, 12)]  # all within a few tol
    cases += [np.repeat(rng.random((5, 2)) * 10, 3, axis=0) + rng.random((15, 2)) * TOL * 0.3]
    cases += [np.array([(0, 0), (1, 0), (1, 1), (0, 1)]) * 1e9,  # no screen: the reference
              np.array([(0, 0), (1e-3, 0), (1e-3, 1e-3), (0, 1e-3)])]  # fmt: skip
    for ring in cases:
        _same_ring(ring)


def test_clean_ring_leaves_only_vertices_near_the_tolerance_to_the_scalar_test(monkeypatch) -> None:
    calls = []
    real = P._seg_distance
    monkeypatch.setattr(P, "_seg_distance", lambda *a: calls.append(1) or real(*a))
    square = np.array([(0, 0), (10, 0), (10, 10), (0, 10)], dtype=float)
    P.clean_ring(square)
    assert calls == []  # every vertex certainly far from its neighbours' segment
    at_tol = np.array([(0, 0), (5, TOL), (10, 0), (10, 10), (0, 10)], dtype=float)
    _, counts = P.clean_ring(at_tol)
    assert len(calls) == 1  # the vertex at the tolerance: the scalar test decides
    assert counts["collinear"] == P._clean_ring_reference(at_tol)[1]["collinear"]


def _random_polygons(seed: int, count: int) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        centre = rng.choice([0.0, 1e5]) + rng.random(2) * 100
        shell, _ = P.clean_ring(_at_tolerance(rng, _star(rng, int(rng.integers(3, 30)), 60.0,
                                                           centre)))  # fmt: skip
        holes = []
        for _ in range(rng.integers(0, 3)):
            c = centre + (rng.random(2) - 0.5) * 30
            hole = np.round(_star(rng, int(rng.integers(3, 8)), 6.0, c), 3)
            holes.append(hole if rng.random() < 0.5 else hole[::-1].copy())
        if len(shell) >= 3 and P.polygon_problem(shell, holes) is None:
            out.append((shell if rng.random() < 0.5 else shell[::-1].copy(), holes))
    return out


def _grid_polygons(seed: int, count: int) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    """Unions of grid cells (L-, U-shapes, courtyards): many cocircular vertices."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        cells = rng.integers(0, 6, (int(rng.integers(1, 20)), 2))
        geom = shapely.union_all([shapely.box(10 * x, 10 * y, 10 * x + 10, 10 * y + 10)
                                  for x, y in cells])  # fmt: skip
        for part in shapely.get_parts(geom):
            shell = P.clean_ring(np.asarray(part.exterior.coords))[0]
            holes = [P.clean_ring(np.asarray(h.coords))[0] for h in part.interiors]
            if P.polygon_problem(shell, holes) is None:
                out.append((shell, holes))
    return out


@pytest.mark.parametrize("make", [_random_polygons, _grid_polygons])
def test_convex_pieces_equal_the_reference_one_by_one_and_together(make) -> None:
    regions = make(2, 300)
    assert len(regions) > 100
    want = [_reference_pieces(s, h) for s, h in regions]
    for (s, h), w in zip(regions, want, strict=True):
        try:
            got = P.convex_pieces(s, h)
        except Exception as exc:  # noqa: BLE001 - compared with the reference's
            got = exc
        _same_pieces(got, w)
    for got, w in zip(P.convex_pieces_many(regions), want, strict=True):
        _same_pieces(got, w)


def test_convex_pieces_many_answers_each_polygon_as_the_reference_would() -> None:
    good = (np.array([(0, 0), (10, 0), (10, 1), (1, 1), (1, 10), (0, 10)], dtype=float), [])
    square = (np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=float), [])
    two = (np.array([(0, 0), (1, 0)], dtype=float), [])  # not a polygon: shapely refuses it
    regions = [good, two, square, two]
    got = P.convex_pieces_many(regions)
    for g, (s, h) in zip(got, regions, strict=True):
        _same_pieces(g, _reference_pieces(s, h))
    assert isinstance(got[1], ValueError)
    with pytest.raises(ValueError) as err:
        Obstacles.build([], [], regions)
    assert str(err.value) == f"region 1: {_reference_pieces(*two)}"  # the first failing one


def _same_offset(poly, r: float, overshoot: float = OFFSET_OVERSHOOT) -> None:
    got = outer_offset(poly, r, overshoot)
    want = _outer_offset_reference(poly, r, overshoot)
    assert shapely.to_wkb(got) == shapely.to_wkb(want)


def test_outer_offset_equals_the_reference_on_random_polygons() -> None:
    regions = _random_polygons(3, 60) + _grid_polygons(3, 20)
    for k, (shell, holes) in enumerate(regions):
        poly = Polygon(shell, holes)
        for r, f in ((0.55, OFFSET_OVERSHOOT), (12.05, OFFSET_OVERSHOOT), (3.0, 1.0005)):
            _same_offset(poly if k % 2 else poly.reverse(), r, f)


def _check_map(m) -> None:
    """Every ring, polygon and inflated obstacle of map `m` and of its planning map."""
    for mm in (m, m.planning_map()):
        obs = mm.spec.obstacles
        for z in [*obs.no_fly_zones, *obs.polygons]:
            for ring in (z.vertices, *z.holes):
                _same_ring(ring)
        regions = [(sh.shell, sh.holes) for sh in mm.shapes]
        for got, (s, h) in zip(P.convex_pieces_many(regions), regions, strict=True):
            _same_pieces(got, _reference_pieces(s, h))
    nc = len(m.spec.obstacles.circles)
    cl = m.obstacle_clearances
    for k, poly in enumerate(_obstacle_polygons(m)):
        if k < nc:  # circles are inflated exactly, not by outer_offset
            continue
        if cl[k] > 0.0:
            _same_offset(poly, cl[k] + CLEARANCE_PAD, m._inflation[k][1])
        else:  # a map without clearance: as if it had 10 m
            _same_offset(poly, 10.0 + CLEARANCE_PAD)


def test_campus_map_rings_pieces_and_offsets_equal_the_references() -> None:
    from lamde_mission.gis.synthetic import campus_map

    _check_map(load_map(campus_map(500, seed=0)))


@pytest.mark.slow  # about 10 s on a loaded machine
def test_large_campus_map_rings_pieces_and_offsets_equal_the_references() -> None:
    from lamde_mission.gis.synthetic import campus_map

    _check_map(load_map(campus_map(2000, seed=0)))


@pytest.mark.parametrize("path", sorted(p.relative_to(MAPS).as_posix()
                                        for p in MAPS.rglob("*.json")))  # fmt: skip
def test_example_maps_rings_pieces_and_offsets_equal_the_references(path: str) -> None:
    try:
        m = load_map(MAPS / path)
    except MapError:
        pytest.skip("not a map (best-known or bound tables)")
    _check_map(m)
