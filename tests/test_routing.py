"""planner_core.model.routing: polygon offsets, all-pairs shortest paths, the visibility graph."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.model.problem import Problem
from planner_core.model.routing import (
    build_visibility_graph,
    offset_convex,
    path_hops,
    shortest_paths,
)
from tests.conftest import SUITE


def test_offset_square_stands_off_every_edge_by_c() -> None:
    sq = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    out = offset_convex(sq, 2.0)
    assert out == pytest.approx(np.array([[-2, -2], [12, -2], [12, 12], [-2, 12]]))
    # a capped mitre at a needle corner stays outside but closer than c
    needle = np.array([[0.0, 0.0], [100.0, 1.0], [0.0, 2.0]])
    capped = offset_convex(needle, 1.0, min_denominator=0.08)[1] - needle[1]
    full = offset_convex(needle, 1.0)[1] - needle[1]
    assert capped[0] > 0.0 and np.hypot(*capped) < np.hypot(*full)


def test_shortest_paths_and_hops() -> None:
    inf = np.inf
    w = np.array([[0, 1, inf, 10], [1, 0, 1, inf], [inf, 1, 0, 1], [10, inf, 1, 0]], dtype=float)
    dist, nxt = shortest_paths(w)
    assert dist[0, 3] == 3.0 and path_hops(nxt, 0, 3) == [1, 2] and path_hops(nxt, 0, 1) == []
    dist, nxt = shortest_paths(np.array([[0.0, inf], [inf, 0.0]]))
    assert dist[0, 1] == inf and nxt[0, 1] == -1
    with pytest.raises(ValueError, match="no path from node 0 to node 1"):
        path_hops(nxt, 0, 1)  # it returned [-1] (nxt's last row read as the hop)
    loop = np.array([[0, 1, 1], [1, 0, 0], [0, 0, 0]])  # 0 -> 1 -> 0 -> ... never reaches 2
    with pytest.raises(ValueError, match="no path"):
        path_hops(loop, 0, 2)


def test_route_follows_graph_edges() -> None:
    p = Problem(SUITE / "T16.json")
    g = build_visibility_graph(p.obstacles, p.model.width, p.model.height, 20.0)
    edges = {tuple(e) for e in g.edges.tolist()}
    src = np.full(g.n, np.inf)
    dst = np.full(g.n, np.inf)
    src[0] = 0.0
    dst[g.n - 1] = 0.0
    length, path = g.route(src, dst)
    assert path[0] == 0 and path[-1] == g.n - 1
    hops = list(zip(path[:-1], path[1:], strict=True))
    assert all((min(a, b), max(a, b)) in edges for a, b in hops)
    steps = [np.hypot(*(g.nodes[b] - g.nodes[a])) for a, b in hops]
    assert length == pytest.approx(sum(steps))
