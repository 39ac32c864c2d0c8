"""The visibility graph's tangency kernel (`_tangent_pairs`: both ends' tests for a row of
pairs into flags, branch-free, then compacted) finds exactly the pairs of its plain reference
(`_tangent_pairs_reference`: `_tangent` pair by pair), and its line of sight
(`overlap_first`, the nearest tiles first) answers as the plain sum over every obstacle
(`overlap_lengths`), so the graph built either way is the same to the byte: nodes, edges and
weights, on suite, large and generated campus maps."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planner_core.model.geometry import overlap_lengths
from planner_core.model.mapio import load_map
from planner_core.model.routing import graph
from planner_core.model.routing.graph import (
    _row_blocks,
    _tangent_pairs,
    _tangent_pairs_reference,
    build_visibility_graph,
)
from planner_core.model.seeding import MARGIN

ROOT = Path(__file__).resolve().parent.parent
MAPS = ROOT / "examples" / "maps"


def _nodes(kind: str, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random nodes with random neighbours, or nodes on an integer lattice with axis-aligned
    neighbours (many lines exactly along a side: the tolerance decides)."""
    rng = np.random.default_rng(7)
    if kind == "random":
        nodes = rng.uniform(0, 100, (n, 2))
        return nodes, nodes + rng.normal(0, 3, (n, 2)), nodes + rng.normal(0, 3, (n, 2))
    nodes = rng.integers(0, 12, (n, 2)).astype(float)
    steps = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    return (nodes, nodes + steps[rng.integers(0, 4, n)],
            nodes + steps[rng.integers(0, 4, n)])  # fmt: skip


@pytest.mark.parametrize("kind", ["random", "lattice"])
def test_tangent_pairs_equal_the_reference(kind: str) -> None:
    nodes, prev, nxt = _nodes(kind, 400)
    want = _tangent_pairs_reference(nodes, prev, nxt, 0, 400)
    got = _tangent_pairs(nodes, prev, nxt, 0, 400)
    # some kept, some not, more than the output's first 1,024 slots (it grows)
    assert 1024 < len(want[0]) < 400 * 399 // 2
    for w, g in zip(want, got, strict=True):
        assert w.dtype == g.dtype and w.tobytes() == g.tobytes()
    # row blocks (the build's calls) give the same pairs in the same order
    parts = [_tangent_pairs(nodes, prev, nxt, i0, i1) for i0, i1 in _row_blocks(400, 5000)]
    np.testing.assert_array_equal(np.concatenate([p[0] for p in parts]), want[0])
    np.testing.assert_array_equal(np.concatenate([p[1] for p in parts]), want[1])


def _campus() -> dict:
    from lamde_mission.gis.synthetic import campus_map

    return campus_map(60, seed=3, size=1500.0, n_sensors=5)


@pytest.mark.parametrize("name", ["T16", "L08", "campus-60"])
def test_the_graph_is_the_same_as_the_references(name: str, monkeypatch) -> None:
    """Built as a plan builds it and with the references (pair-by-pair tangency, the summed
    overlap): the same arrays to the byte (L08: 1,023 obstacles, 5,014 corners, ~77,000
    edges)."""
    if name == "T16":
        m = load_map(json.loads((MAPS / "suite" / "T16.json").read_text()))
    elif name == "L08":
        m = load_map(MAPS / "large" / "L08.json")
    else:
        m = load_map(_campus())
    fast = build_visibility_graph(m.obstacles, m.width, m.height, MARGIN)
    monkeypatch.setattr(graph, "_tangent_pairs", _tangent_pairs_reference)
    monkeypatch.setattr(graph, "overlap_first", overlap_lengths)  # every obstacle, in order
    ref = build_visibility_graph(m.obstacles, m.width, m.height, MARGIN)
    assert fast.n > 20 and len(fast.edges) > 50
    for field in ("nodes", "prev", "next", "indptr", "indices", "weights", "edges"):
        x, y = getattr(fast, field), getattr(ref, field)
        assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), field
