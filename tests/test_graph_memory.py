"""The visibility graph's build holds one block of candidate pairs at a time (issue 32, item
4): a map at the documented vertex limit (LAMDE_MAX_VERTICES, 50,000) plans within 4 GB of
address space, where n(n-1)/2 int64 pairs alone asked for ~20 GB."""

from __future__ import annotations

import json
import math
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from planner_core.model.mapio import load_map
from planner_core.model.routing import graph
from planner_core.model.routing.graph import _row_blocks, _tangent_pairs, build_visibility_graph
from planner_core.textio import limit

ROOT = Path(__file__).resolve().parent.parent
TINY = ROOT / "tests" / "data" / "hostile" / "tiny-map.json"


@pytest.mark.parametrize("n", [0, 1, 2, 3, 7, 100, 2001, 3000])
@pytest.mark.parametrize("block", [1, 5, 1000, 4_000_000])
def test_row_blocks_cover_every_pair_once(n: int, block: int) -> None:
    rows = [i for i0, i1 in _row_blocks(n, block) for i in range(i0, i1)]
    assert rows == list(range(n))
    for i0, i1 in _row_blocks(n, block):
        pairs = sum(n - i - 1 for i in range(i0, i1))
        assert pairs <= block or i1 == i0 + 1  # a row longer than a block is a block alone


def test_blocks_find_the_pairs_one_pass_finds() -> None:
    rng = np.random.default_rng(3)
    nodes = rng.uniform(0, 100, (300, 2))
    prev = nodes + rng.normal(0, 3, (300, 2))
    nxt = nodes + rng.normal(0, 3, (300, 2))
    whole = _tangent_pairs(nodes, prev, nxt, 0, 300)
    parts = [_tangent_pairs(nodes, prev, nxt, i0, i1) for i0, i1 in _row_blocks(300, 997)]
    # some pairs kept, some not; more than the output's first 1,024 slots (it grows)
    assert 1024 < len(whole[0]) < 300 * 299 // 2
    np.testing.assert_array_equal(np.concatenate([p[0] for p in parts]), whole[0])
    np.testing.assert_array_equal(np.concatenate([p[1] for p in parts]), whole[1])


def test_the_graph_is_the_same_whatever_the_block(monkeypatch) -> None:
    m = load_map(TINY)
    g1 = build_visibility_graph(m.obstacles, m.width, m.height, 1.0)
    monkeypatch.setattr(graph, "PAIR_BLOCK", 3)
    # the build reads PAIR_BLOCK when it runs (a default bound at import ignored the patch)
    assert len(_row_blocks(g1.n)) == len(_row_blocks(g1.n, 3)) > 5
    g2 = build_visibility_graph(m.obstacles, m.width, m.height, 1.0)
    assert len(g1.edges) > 10
    np.testing.assert_array_equal(g1.edges, g2.edges)
    np.testing.assert_array_equal(g1.weights, g2.weights)


def same_graph(a: graph.VisibilityGraph, b: graph.VisibilityGraph) -> None:
    for field in ("nodes", "prev", "next", "indptr", "indices", "weights", "edges"):
        x, y = getattr(a, field), getattr(b, field)
        assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), field


def test_the_build_reports_its_progress_and_builds_the_same_graph(monkeypatch) -> None:
    """Issue 31 (progress for every stage longer than a second): at 2,000 campus footprints the
    build ran for a minute with no word; `progress` now hears the fraction of node pairs done
    after each block, increasing to 1.0, and the graph is the same to the byte."""
    from planner_core.model.problem import Problem
    from planner_core.model.seeding import Seeder

    m = load_map(TINY)
    plain = build_visibility_graph(m.obstacles, m.width, m.height, 1.0)
    monkeypatch.setattr(graph, "PAIR_BLOCK", 3)
    heard: list[float] = []
    told = build_visibility_graph(m.obstacles, m.width, m.height, 1.0, progress=heard.append)
    same_graph(plain, told)
    n = plain.n
    done = np.cumsum([sum(n - i - 1 for i in range(i0, i1)) for i0, i1 in _row_blocks(n, 3)])
    assert len(heard) == len(done) > 5 and heard[-1] == 1.0
    assert heard == pytest.approx((done / (n * (n - 1) // 2)).tolist(), rel=1e-12)
    assert all(a < b for a, b in zip(heard[:-1], heard[1:], strict=True))
    # the seeder hands its callback on; a map without corners tells 1.0 once
    problem = Problem(TINY)
    heard.clear()
    seeder = Seeder.for_problem(problem, progress=heard.append)
    same_graph(Seeder.for_problem(problem).graph, seeder.graph)
    assert heard[-1] == 1.0 and len(heard) > 5
    heard.clear()
    d = json.loads(TINY.read_text())
    d["obstacles"] = {}
    bare = load_map(d)
    empty = build_visibility_graph(bare.obstacles, bare.width, bare.height, 1.0,
                                   progress=heard.append)  # fmt: skip
    assert empty.n == 0 and heard == [1.0]


def vertex_limit_map(path: Path) -> Path:
    """25 convex no-fly zones of 2,000 vertices each (50,000 in all: the default limit) on a
    22 km map; every corner is a node of the visibility graph."""
    per, side = 2000, 5
    d = json.loads(TINY.read_text())
    w = 4000 * side + 2000
    d["area"] = {"width": w, "height": w}
    d["start"], d["end"] = [100, 100], [w - 100, w - 100]
    d["sensors"] = [{"id": f"s{k}", "x": 1000 + 4000 * (k % side), "y": 3000 + 4000 * (k // side)}
                    for k in range(8)]  # fmt: skip
    zones = []
    for z in range(side * side):
        cx, cy = 3000 + (z % side) * 4000, 3000 + (z // side) * 4000
        zones.append({"vertices": [[cx + 1500 * math.cos(2 * math.pi * k / per),
                                    cy + 1500 * math.sin(2 * math.pi * k / per)]
                                   for k in range(per)]})  # fmt: skip
    d["obstacles"] = {"no_fly_zones": zones}
    path.write_text(json.dumps(d))
    return path


GIB = 1024**3


@pytest.mark.slow
def test_a_map_at_the_vertex_limit_plans_under_4_gb(tmp_path: Path) -> None:
    """`plan` on a 50,000-vertex map under `ulimit -v` 4 GB (RLIMIT_AS): exit 0, a mission
    written, peak RSS reported by the child. (Before: MemoryError from _tangent_pairs.)"""
    src = vertex_limit_map(tmp_path / "v50k.json")
    assert sum(len(z["vertices"]) for z in json.loads(src.read_text())["obstacles"][
        "no_fly_zones"]) == limit("vertices") == 50_000  # fmt: skip

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (4 * GIB, 4 * GIB))

    out = tmp_path / "v50k.plan"
    code = ("import resource, sys; from lamde_mission.cli import main; rc = main(sys.argv[1:]); "
            "print('maxrss_kib', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); "
            "sys.exit(rc)")  # fmt: skip
    r = subprocess.run([sys.executable, "-c", code, "plan", str(src), "-o", str(out),
                        "--budget", "1000", "--quiet"], capture_output=True, text=True,
                       timeout=1200, preexec_fn=cap, cwd=ROOT)  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    assert out.stat().st_size > 0
    rss = int(r.stdout.split("maxrss_kib")[1].split()[0])
    assert rss * 1024 < 2 * GIB, rss
