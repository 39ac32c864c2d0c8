"""The planner's fast paths for many sensors equal their slow references to the bit (issue 31):
the seeder's prune (`Seeder.prune` vs `Seeder.prune_reference`) and the repair's merge of two
hover points (`refine._merge_pair` vs `refine.merge_pair_reference`), on suite maps and on
random small maps with random point sets."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planner_core.model.problem import Problem
from planner_core.search import refine

SUITE = Path(__file__).resolve().parent.parent / "examples" / "maps" / "suite"


def _random_map(rng: np.random.Generator, n_sensors: int, size: float = 3000.0) -> dict:
    sensors = rng.uniform(100, size - 100, (n_sensors, 2))
    circles = [{"x": float(x), "y": float(y), "radius": float(r)}
               for x, y, r in zip(*rng.uniform(200, size - 200, (2, 6)),
                                  rng.uniform(30, 90, 6), strict=True)]
    return {"name": "random", "area": {"width": size, "height": size},
            "start": [50.0, 50.0], "end": [size - 50.0, size - 50.0],
            "sensors": [{"id": f"S{i}", "x": float(x), "y": float(y)}
                        for i, (x, y) in enumerate(sensors)],
            "obstacles": {"circles": circles},
            "uav": {"max_hover_points": max(2, n_sensors // 3)}}


def _cases() -> list[tuple[str, Problem, np.ndarray]]:
    rng = np.random.default_rng(31)
    out = []
    for task in ("T03", "T09", "T16"):
        p = Problem(json.loads((SUITE / f"{task}.json").read_text()))
        for n in (3, 12, 30):
            pts = rng.uniform(0, p.model.width, (n, 2))
            out.append((f"{task}-{n}", p, pts))
            # points near the sensors: most of them serve someone
            near = p.model.sensors[rng.integers(0, len(p.model.sensors), n)]
            out.append((f"{task}-near-{n}", p, near + rng.normal(0, 150, (n, 2))))
    for case in range(6):
        p = Problem(_random_map(rng, int(rng.integers(4, 25))))
        near = p.model.sensors[rng.integers(0, len(p.model.sensors), 2 * len(p.model.sensors))]
        out.append((f"random-{case}", p, near + rng.normal(0, 200, near.shape)))
    return out


CASES = _cases()


@pytest.mark.parametrize("name,problem,pts", CASES, ids=[c[0] for c in CASES])
def test_prune_equals_its_reference(name: str, problem: Problem, pts: np.ndarray) -> None:
    seeder = problem.seeder
    for limit in (1, max(1, len(pts) // 2), len(pts)):
        fast = seeder.prune(pts.copy(), limit)
        slow = seeder.prune_reference(pts.copy(), limit)
        assert fast.shape == slow.shape and np.array_equal(fast, slow), (name, limit)


@pytest.mark.parametrize("name,problem,pts", CASES, ids=[c[0] for c in CASES])
def test_merge_pair_equals_its_reference(name: str, problem: Problem, pts: np.ndarray) -> None:
    cur = pts.copy()
    for _ in range(3):  # a few merges in a row, as the repair does
        fast = refine._merge_pair(problem, cur)
        slow = refine.merge_pair_reference(problem, cur)
        assert (fast is None) == (slow is None), name
        if fast is None:
            break
        assert np.array_equal(fast, slow), name
        cur = fast


def test_merge_pair_blocks_give_the_same_answer(monkeypatch: pytest.MonkeyPatch) -> None:
    """Tiny blocks (a few pairs each) choose the same pair and place as one block."""
    name, problem, pts = CASES[-1]
    whole = refine._merge_pair(problem, pts)
    monkeypatch.setattr(refine, "_MERGE_BLOCK", 50)
    assert np.array_equal(refine._merge_pair(problem, pts), whole)


@pytest.mark.parametrize("name,problem,pts", CASES, ids=[c[0] for c in CASES])
def test_greedy_cover_equals_its_reference(name: str, problem: Problem, pts: np.ndarray) -> None:
    from planner_core.search import construct

    sites = construct.candidate_sites(problem, pts)
    table = construct.CoverTable(problem, sites)
    for frac in construct.FRACTIONS:
        for chosen in (None, pts[: len(pts) // 3]):
            fast = construct.greedy_cover(problem, sites, frac, chosen=chosen, table=table)
            slow = construct.greedy_cover_reference(problem, sites, frac, chosen=chosen)
            assert np.array_equal(fast, slow), (name, frac)


def test_via_corners_equals_the_dense_minimum() -> None:
    """The blocked legs' detour times: the compiled minimum over each point's seen corners
    equals the dense (K, N) minimum, infinities included."""
    from planner_core.search.construct import via_corners

    rng = np.random.default_rng(3)
    P, N = 30, 200
    first = np.where(rng.random((P, N)) < 0.05, rng.uniform(1, 100, (P, N)), np.inf)
    first[4] = np.inf  # a point that sees no corner
    far = np.where(rng.random((P, N)) < 0.9, rng.uniform(1, 500, (P, N)), np.inf)
    ia, ib = np.triu_indices(P, 1)
    dense = (far[ia] + first[ib]).min(axis=1)
    assert np.array_equal(via_corners(far, first, ia, ib), dense)
    assert np.isinf(dense).any()


def test_the_leg_time_matrix_is_unchanged_on_a_walled_map(monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    from planner_core.search import construct

    p = Problem(json.loads((SUITE / "T16.json").read_text()))
    pts = np.random.default_rng(4).uniform(0, 10000, (25, 2))
    fast = construct.LegTimes(p).matrix(pts)
    monkeypatch.setattr(construct, "via_corners",
                        lambda far, first, ia, ib: (far[ia] + first[ib]).min(axis=1))
    assert np.array_equal(construct.LegTimes(p).matrix(pts), fast)


@pytest.mark.parametrize("size", [3000.0, 12000.0])
def test_slide_costs_equal_their_reference(size: float) -> None:
    """The slide's local costs: visiting only each centre's members and the sensors its
    candidates can hear gives the every-sensor reference's costs to the bit (inf included),
    on random small maps where most sensors are out of radio range (size 12 km) or not."""
    from planner_core.model import seeding

    rng = np.random.default_rng(int(size))
    for _ in range(4):
        p = Problem(_random_map(rng, int(rng.integers(5, 40)), size))
        m, S = p.model, p.model.sensors
        n, Q = int(rng.integers(1, 8)), 37
        cur = S[rng.integers(0, len(S), n)] + rng.normal(0, 300, (n, 2))
        cand = cur[:, None, :] + rng.normal(0, 400, (n, Q, 2))
        prv, nxt = rng.uniform(0, size, (n, 2)), rng.uniform(0, size, (n, 2))
        member = rng.integers(0, n + 2, len(S))[None, :] == np.arange(n)[:, None]
        lim = rng.uniform(100, 900, len(S))
        model = (m.required, m.altitude, m.peak_rate, m.decay, 0.98 * m.bandwidth, m.v_max)
        args = (cand, prv, nxt, member, S, lim, *model, m.accel, m.alpha)
        fast = seeding._slide_costs(*args)
        slow = seeding._slide_costs_reference(*args)
        assert np.array_equal(fast, slow)
        assert fast.shape == (n, Q)


@pytest.mark.parametrize("name,problem,pts", CASES, ids=[c[0] for c in CASES])
def test_push_one_equals_its_reference(name: str, problem: Problem, pts: np.ndarray) -> None:
    """Moving a point out of the first obstacle holding it: testing only the circles whose box
    holds the point gives the every-circle reference's point (circle centres included)."""
    seeder = problem.seeder
    circles = problem.obstacles.circles
    rng = np.random.default_rng(len(pts))
    at_circles = circles[:, :2] + rng.normal(0, 1, (len(circles), 1)) * circles[:, 2:]
    moved = 0
    for q in np.vstack([pts, circles[:, :2], at_circles]):
        fast = seeder.push_one(q.copy(), np.random.default_rng(7))
        slow = seeder.push_one_reference(q.copy(), np.random.default_rng(7))
        assert np.array_equal(fast, slow), (name, q)
        moved += not np.array_equal(fast, q)
    assert moved or not len(circles), name


@pytest.mark.parametrize("name,problem,pts", CASES, ids=[c[0] for c in CASES])
def test_points_inside_equals_its_reference(name: str, problem: Problem, pts: np.ndarray) -> None:
    """Which points lie inside an obstacle: skipping circles whose box misses the point gives
    the every-circle reference's answer, also for points on and near the circles' rims."""
    from planner_core.model import geometry

    o = problem.obstacles
    rng = np.random.default_rng(len(pts) + 1)
    ang = rng.uniform(0, 2 * np.pi, (len(o.circles), 3))
    rad = o.circles[:, 2:] * np.array([1.0 - 1e-12, 1.0, 1.0 + 1e-12]) - o.tol
    rims = o.circles[:, None, :2] + rad[..., None] * np.stack([np.cos(ang), np.sin(ang)], -1)
    q = np.ascontiguousarray(np.vstack([pts, rims.reshape(-1, 2)]))
    args = (q, o.circles, o.poly_vertices, o.poly_offsets, o.edge_normals, o.edge_flags,
            o.poly_boxes, o.tol)
    fast, slow = np.zeros(len(q), dtype=bool), np.zeros(len(q), dtype=bool)
    geometry._points_inside_kernel(*args, fast)
    geometry._points_inside_reference(*args, slow)
    assert np.array_equal(fast, slow), name
    assert np.array_equal(geometry.points_inside(q, o), slow), name
    assert slow.any() or not len(o.circles), name


@pytest.mark.parametrize("name,problem,pts", CASES, ids=[c[0] for c in CASES])
def test_held_check_equals_held_points(name: str, problem: Problem, pts: np.ndarray) -> None:
    """The descent's incremental C3/C5 flags: after each move of a few points, `HeldCheck`
    holds the points `held_points` holds on the moved set (computed afresh)."""
    from planner_core.search.descent import HeldCheck, held_points

    rng = np.random.default_rng(len(pts) + 2)
    P = pts.copy()
    check = HeldCheck(problem, P)
    held_any = False
    for _ in range(6):
        assert np.array_equal(check.held(), held_points(problem, P)), name
        held_any |= bool(len(check.held()))
        idx = np.unique(rng.integers(0, len(P), max(1, len(P) // 4)))
        P[idx] = problem.model.sensors[rng.integers(0, len(problem.model.sensors), len(idx))]
        check.moved(P, idx)
    assert np.array_equal(check.held(), held_points(problem, P)), name
    assert held_any or len(pts) < 12 or name.startswith("random"), name


def _leg_cases() -> list[tuple[str, object]]:
    """Obstacle sets for `overlap_first`: suite maps (one "tile" of all obstacles) and L02
    (460 obstacles: the tiled kernel, whose cut legs are dropped between tiles)."""
    large = SUITE.parent / "large" / "L02.json"
    out = [(t, Problem(json.loads((SUITE / f"{t}.json").read_text())).obstacles)
           for t in ("T03", "T16")]
    from planner_core.model.mapio import load_map
    from planner_core.model.problem import Problem as _P

    out.append(("L02", _P(load_map(large).planning_map()).obstacles))
    return out


@pytest.mark.parametrize("name,obstacles", _leg_cases(), ids=lambda c: c if isinstance(c, str)
                         else "")
def test_overlap_first_gives_overlap_lengths_answers(name: str, obstacles: object) -> None:
    """`overlap_first` (a leg leaves the tests at its first cut) answers every clear / cut
    question as `overlap_lengths` does: 0 exactly where the sum is 0, positive and at most
    the sum elsewhere, NaN where it is NaN; on long and short random legs, legs from and to
    obstacle corners and circle rims (the boundary band), zero-length and NaN legs, and more
    legs than one kernel chunk."""
    from planner_core.model import geometry
    from planner_core.model.formulas import L_VIO_TOL
    from planner_core.model.routing.graph import CLEAR

    o = obstacles
    rng = np.random.default_rng(5)
    size = float(np.max(np.abs(o.poly_vertices))) if len(o.poly_vertices) else 3000.0
    size = max(size, float(np.max(o.circles[:, :2])) if len(o.circles) else 0.0)
    a = rng.uniform(0, size, (5000, 2))
    b = np.where(rng.random((5000, 1)) < 0.5, rng.uniform(0, size, (5000, 2)),
                 a + rng.normal(0, 300, (5000, 2)))
    ends = [o.poly_vertices] if len(o.poly_vertices) else []
    if len(o.circles):
        ang = rng.uniform(0, 2 * np.pi, len(o.circles))
        ends.append(o.circles[:, :2] + (o.circles[:, 2] + o.tol)[:, None]
                    * np.column_stack([np.cos(ang), np.sin(ang)]))
    corners = np.vstack(ends)
    i, j = rng.integers(0, len(corners), (2, 3000))
    a = np.vstack([a, corners[i], corners[:50], [[np.nan, 1.0]]])
    b = np.vstack([b, corners[j], corners[:50], [[5.0, 5.0]]])
    full = geometry.overlap_lengths(a, b, o)
    first = geometry.overlap_first(a, b, o)
    assert np.array_equal(np.isnan(first), np.isnan(full)), name
    ok = ~np.isnan(full)
    assert np.array_equal(first[ok] == 0.0, full[ok] == 0.0), name
    assert np.all(first[ok] <= full[ok]) and np.all(first[ok] >= 0.0), name
    for t in (CLEAR, L_VIO_TOL):
        assert np.array_equal(first <= t, full <= t) and np.array_equal(first > t, full > t)
    assert 0.2 < np.mean(full[ok] > 0) < 0.98, name  # both answers well represented
