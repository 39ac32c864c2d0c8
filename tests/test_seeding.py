"""Obstacle-aware starts (planner_core.model.seeding): clear graph edges, collision-free
sensor-serving
starts on dense suite maps, determinism, small maps, no obstacles, fixed-length mode."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from planner_core import Problem
from planner_core.model.geometry import overlap_lengths_reference, points_inside
from planner_core.model.routing import build_visibility_graph
from planner_core.model.seeding import MARGIN, Seeder
from tests.conftest import MAPS, SUITE


def _suite(task: str) -> dict:
    return json.loads((SUITE / f"{task}.json").read_text())


def _seeded(problem: Problem, n: int = 40, seed: int = 0) -> list[dict]:
    """Breakdowns of the sensor-aware half of an initial population of 2 n."""
    X = problem.initial_population(np.random.default_rng(seed), 2 * n)
    return [problem.breakdown(x) for x in X[:n]]


def test_graph_edges_are_collision_free_and_nodes_outside() -> None:
    p = Problem(_suite("T16"))
    g = build_visibility_graph(p.obstacles, p.model.width, p.model.height, MARGIN)
    assert g.n > 100 and len(g.edges) > g.n
    assert not points_inside(g.nodes, p.obstacles).any()
    assert np.all((g.nodes >= 0.0) & (g.nodes <= p.upper[:2]))
    rng = np.random.default_rng(1)
    sample = g.edges[rng.choice(len(g.edges), size=150, replace=False)]
    lengths = overlap_lengths_reference(g.nodes[sample[:, 0]], g.nodes[sample[:, 1]], p.obstacles)
    assert np.all(lengths == 0.0)


def test_graph_route_goes_around_a_wall() -> None:
    # one long thin building between start and end: the direct leg is blocked
    m = {
        "area": {"width": 2000, "height": 2000},
        "start": [100, 1000],
        "end": [1900, 1000],
        "sensors": [{"id": "a", "x": 1000, "y": 1900}],
        "obstacles": {"rectangles": [{"x": 1000, "y": 1000, "length": 60, "width": 1500}]},
    }
    p = Problem(m)
    s = Seeder.for_problem(p)
    ends = s.connect(np.array([p.start, p.end]))
    length, path = s.graph.route(ends[0], ends[1])
    assert path and np.isfinite(length)
    pts = np.vstack([p.start, s.graph.nodes[path], p.end])
    assert np.all(overlap_lengths_reference(pts[:-1], pts[1:], p.obstacles) == 0.0)
    assert length > np.hypot(*(p.end - p.start))


@pytest.mark.parametrize("task", ["T16", "T08"])
def test_seeded_starts_are_collision_free_and_serve_all_sensors(task: str) -> None:
    p = Problem(_suite(task))
    bd = _seeded(p)
    assert np.mean([b["l_vio"] == 0.0 for b in bd]) >= 0.8
    assert np.mean([b["v4"] <= 1e-9 for b in bd]) >= 0.8
    assert np.mean([b["phi"] == 0.0 for b in bd]) >= 0.8
    assert all(b["n_hover"] <= p.n_points for b in bd)
    # hover times stay within the box
    assert all(0.0 <= t <= p.t_max for b in bd for t in b["hover_times"])


def test_same_seed_same_population() -> None:
    d = _suite("T13")
    a = Problem(d).initial_population(np.random.default_rng(7), 30)
    p = Problem(d)
    p.initial_population(np.random.default_rng(3), 10)  # a used seeder keeps no state
    b = p.initial_population(np.random.default_rng(7), 30)
    np.testing.assert_array_equal(a, b)
    c = p.initial_population(np.random.default_rng(8), 30)
    assert not np.array_equal(a, c)
    assert np.all((a >= p.lower) & (a <= p.upper))


@pytest.mark.parametrize("name", ["tiny.json", "small-demo.json"])
@pytest.mark.parametrize("variable", [True, False])
def test_small_maps(name: str, variable: bool) -> None:
    p = Problem(MAPS / name, variable_length=variable)
    bd = _seeded(p, n=10)
    assert np.mean([b["phi"] == 0.0 for b in bd]) >= 0.8
    if not variable:
        assert all(b["n_hover"] == p.n_points for b in bd)


def test_map_without_obstacles() -> None:
    d = _suite("T09")
    d["obstacles"] = {}
    d.pop("witness")
    p = Problem(d)
    assert build_visibility_graph(p.obstacles, p.model.width, p.model.height, MARGIN).n == 0
    bd = _seeded(p, n=10)
    assert all(b["phi"] == 0.0 for b in bd)


def test_bandwidth_is_respected(hand_map: dict) -> None:
    # bandwidth 15 Mbit/s: hovering on top of sensor a would exceed it (9 + 6.8)
    p = Problem(copy.deepcopy(hand_map))
    bd = _seeded(p, n=10)
    assert np.mean([b["phi"] == 0.0 for b in bd]) >= 0.8


@pytest.mark.parametrize("task", ["T16", "T05"])
def test_fixed_length_fills_every_slot_collision_free(task: str) -> None:
    p = Problem(_suite(task), variable_length=False)
    bd = _seeded(p, n=20)
    assert all(b["n_hover"] == p.n_points for b in bd)
    assert np.mean([b["phi"] == 0.0 for b in bd]) >= 0.8


def test_route_keeps_each_blocked_legs_corners_and_gives_a_fresh_searchs_path(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`Seeder.route` routes a blocked leg once: a path that meets it again (the improving
    rounds' moves keep the incumbent's legs) reuses its corners, and every answer equals a
    fresh seeder's, whose table is empty."""
    p = Problem(_suite("T16"))
    rng = np.random.default_rng(4)
    paths = [rng.uniform(0.0, p.model.width, (12, 2)) for _ in range(3)]
    paths.append(np.vstack([paths[0][:6], rng.uniform(0.0, p.model.width, (3, 2)),
                            paths[0][9:]]))  # a window of paths[0] changed
    seeder = Seeder.for_problem(p)
    searched: list[int] = []
    graph = type(seeder.graph)
    real = graph.route

    def counted(self, *a, **kw):  # noqa: ANN001, ANN002, ANN003, ANN202
        searched.append(self is seeder.graph)
        return real(self, *a, **kw)

    monkeypatch.setattr(graph, "route", counted)
    for C in paths:
        fresh = Seeder.for_problem(p).route(C)
        again = seeder.route(C)
        np.testing.assert_array_equal(again[0], fresh[0])
        np.testing.assert_array_equal(again[1], fresh[1])
    first = sum(searched)
    assert first > 0
    for C in paths:  # every leg met before: no search at all
        seeder.route(C)
    assert sum(searched) == first
