"""The planner's fast paths for many sensors equal their slow references to the bit (issue 31):
the seeder's prune (`Seeder.prune` vs `Seeder.prune_reference`) and the repair's merge of two
hover points (`refine._merge_pair` vs `refine.merge_pair_reference`), on suite maps and on
random small maps with random point sets."""

from __future__ import annotations

import copy
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
    """The compiled prune (`prune`) and the O(n^2 J) reference keep the same points."""
    seeder = problem.seeder
    for limit in (1, max(1, len(pts) // 2), len(pts)):
        fast = seeder.prune(pts.copy(), limit)
        slow = seeder.prune_reference(pts.copy(), limit)
        assert fast.shape == slow.shape and np.array_equal(fast, slow), (name, limit)


def test_prune_equals_its_reference_on_a_large_map() -> None:
    """L02 (460 obstacles: the tiled overlap kernel inside the compiled loop): routes of 20-120
    points near the sensors and anywhere, every limit kind."""
    from planner_core.model.mapio import load_map

    p = Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())
    rng = np.random.default_rng(16)
    S = p.model.sensors
    for n in (20, 60, 120):
        for pts in (S[rng.integers(0, len(S), n)] + rng.normal(0, 200, (n, 2)),
                    rng.uniform(0, p.model.width, (n, 2))):
            for limit in (1, n // 3, n):
                fast = p.seeder.prune(pts.copy(), limit)
                slow = p.seeder.prune_reference(pts.copy(), limit)
                assert np.array_equal(fast, slow), (n, limit)


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
    holds the points `held_points` holds on the moved set (computed afresh), and the compiled
    `held_points` holds what its numpy reference holds."""
    from planner_core.search.trial import HeldCheck, held_points, held_points_reference

    rng = np.random.default_rng(len(pts) + 2)
    P = pts.copy()
    check = HeldCheck(problem, P)
    held_any = False
    for _ in range(6):
        assert np.array_equal(check.held(), held_points(problem, P)), name
        assert np.array_equal(held_points_reference(problem, P), held_points(problem, P)), name
        held_any |= bool(len(check.held()))
        idx = np.unique(rng.integers(0, len(P), max(1, len(P) // 4)))
        P[idx] = problem.model.sensors[rng.integers(0, len(problem.model.sensors), len(idx))]
        check.moved(P, idx)
    assert np.array_equal(check.held(), held_points(problem, P)), name
    assert held_any or len(pts) < 12 or name.startswith("random"), name


def _trial_steps(problem: Problem, pts: np.ndarray, rng: np.random.Generator, tries: int
                 ) -> dict[int, int]:
    """`trial_points` against `trial_points_reference` from points pts (I, 2) for random
    gradients and steps of 0.5-3000 m (some points held, some sliding, some put back): the
    same points to the bit, verdict and rates; returns how often each verdict came."""
    m = problem.model
    box = np.array([m.width, m.height])
    seen = {0: 0, 1: 0, 2: 0}
    for _ in range(tries):
        P = np.clip(pts + rng.normal(0, 30, pts.shape), 0.0, box)
        g = rng.normal(size=P.shape) * (rng.random((len(P), 1)) < 0.8)
        scale = float(np.abs(g).max()) or 1.0
        step = float(rng.choice([0.5, 20.0, 200.0, 3000.0]))
        seen[_same_trial(problem, P, g, scale, step, box)] += 1
    return seen


def _same_trial(problem: Problem, P: np.ndarray, g: np.ndarray, scale: float, step: float,
                box: np.ndarray) -> int:
    """`trial_points` against `trial_points_reference` for one step: the same verdict and
    points to the bit, and for a plan (TRIAL_OK) the same link rates; returns the verdict."""
    from planner_core.search.trial import TRIAL_OK, trial_points, trial_points_reference

    fast = trial_points(problem, P, g, scale, step, box)
    slow = trial_points_reference(problem, P, g, scale, step, box)
    assert fast[2] == slow[2]
    assert np.array_equal(fast[0].view(np.int64), slow[0].view(np.int64))
    if fast[2] == TRIAL_OK:
        want = slow[1] if slow[1] is not None else problem.model.rates(slow[0])
        assert np.array_equal(fast[1], want)
    return int(fast[2])


@pytest.mark.parametrize("name,problem,pts", CASES, ids=[c[0] for c in CASES])
def test_trial_points_equal_their_reference(name: str, problem: Problem, pts: np.ndarray
                                            ) -> None:
    """The descent's compiled trial step (`trial_points`: step, C3/C5 flags, slides, points
    put back) against the numpy sequence it replaces (`trial_points_reference`), to the bit,
    with the map's bandwidth and with one that most points break (C3 binds)."""
    import dataclasses

    rng = np.random.default_rng(len(pts) + 7)
    seen = _trial_steps(problem, pts, rng, 12)
    tight = dataclasses.replace(problem.model, bandwidth=float(
        np.median(problem.model.rates(pts).sum(axis=1))))
    narrow = copy.copy(problem)
    narrow.model = tight
    for k, v in _trial_steps(narrow, pts, rng, 8).items():
        seen[k] += v
    assert seen[0] + seen[1] > 0, (name, seen)


def test_trial_points_equal_their_reference_on_a_large_map() -> None:
    """As above on L02 (460 obstacles: the tiled kernel, cut legs dropped between tiles)."""
    from planner_core.model.mapio import load_map

    p = Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())
    rng = np.random.default_rng(17)
    near = p.model.sensors[rng.integers(0, len(p.model.sensors), 40)]
    pts = near + rng.normal(0, 100, near.shape)
    seen = _trial_steps(p, pts, rng, 10)
    assert seen[0] + seen[1] > 0, seen
    from planner_core.search.trial import held_points, held_points_reference

    for P in (pts, pts[:7], near):
        assert np.array_equal(held_points(p, P), held_points_reference(p, P))


def test_trial_points_slide_and_put_back_to_a_plan_as_the_reference_does() -> None:
    """From a feasible plan of L02 (its stored best-known, whose detour corners touch the
    obstacles), steps that some points cannot take: the trial slides or puts those back and
    the rest is a plan (TRIAL_OK); its points and link rates equal the reference's (to the
    bit). The random steps above, from jittered points, end held on this map."""
    import json

    from planner_core.model.mapio import load_map
    from planner_core.search.trial import TRIAL_OK, held_points_reference

    p = Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())
    bk = json.loads((SUITE.parent / "large_best_known.json").read_text())["tasks"]["L02"]
    P = np.asarray(bk["hover_points"], dtype=float)
    assert not len(held_points_reference(p, P))
    m = p.model
    box = np.array([m.width, m.height])
    rng = np.random.default_rng(5)
    slid = 0
    for _ in range(30):
        g = rng.normal(size=P.shape)
        scale = float(np.abs(g).max())
        step = float(rng.choice([20.0, 80.0, 300.0]))
        if _same_trial(p, P, g, scale, step, box) == TRIAL_OK:
            slid += len(held_points_reference(p, np.clip(P + (-g / scale * step), 0.0, box))) > 0
    assert slid > 0


def test_clip1_is_numpys_clip() -> None:
    """The compiled trial step's scalar clip against np.clip of (n, 2) and (k, 2, 2) arrays to
    [0, box (2,)] (the reference's calls; numpy's loop for a broadcast box), signed zeros and
    NaN included."""
    from planner_core.search.trial import _clip1

    rng = np.random.default_rng(3)
    box = np.array([50.0, 80.0])
    for shape in [(n, 2) for n in (1, 2, 5, 17, 40)] + [(k, 2, 2) for k in (1, 3, 9)]:
        x = rng.normal(0, 100, shape)
        x[rng.random(shape) < 0.2] = -0.0
        x[rng.random(shape) < 0.05] = np.nan
        want = np.clip(x, 0.0, box)
        got = np.array([[_clip1(a, 0.0, box[0]), _clip1(b, 0.0, box[1])]
                        for a, b in x.reshape(-1, 2)]).reshape(shape)
        assert np.array_equal(got.view(np.int64), want.view(np.int64)), shape


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


def _graph_cases() -> list[tuple[str, object, np.ndarray]]:
    """Visibility graphs with their Eq. 1 hop times: T03, T16 and L02 (2,230 corners)."""
    from planner_core.model.mapio import load_map

    out = []
    for t in ("T03", "T16"):
        p = Problem(json.loads((SUITE / f"{t}.json").read_text()))
        out.append((t, p))
    out.append(("L02", Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())))
    return [(name, p.seeder.graph, p.model.flight_time(p.seeder.graph.weights))
            for name, p in out]


@pytest.mark.parametrize("name,graph,hops", _graph_cases(),
                         ids=lambda c: c if isinstance(c, str) else "")
def test_spread_equals_its_reference(name: str, graph: object, hops: np.ndarray) -> None:
    """The corners' Dijkstra (`graph._spread`, a bucket queue, and `_spread_heap`, an indexed
    heap with decrease-key) gives the lazy deletion reference's costs to the bit, inf
    included, from one source, many sources, tied sources, no source, with the edge lengths
    and with Eq. 1 hop times (as `LegTimes`)."""
    from planner_core.model.routing import graph as g

    rng = np.random.default_rng(9)
    n = graph.n
    srcs = [np.full(n, np.inf)]
    for k in (1, 3, 40, n):
        s = np.full(n, np.inf)
        s[rng.choice(n, min(k, n), replace=False)] = rng.uniform(0, 300, min(k, n))
        srcs.append(s)
    tied = np.full(n, np.inf)
    tied[rng.choice(n, min(10, n), replace=False)] = 17.0
    srcs.append(tied)
    for w in (graph.weights, np.ascontiguousarray(hops, dtype=float)):
        for s in srcs:
            fast = g._spread(graph.indptr, graph.indices, w, s, *g.weight_bounds(w))
            heap = g._spread_heap(graph.indptr, graph.indices, w, s)
            slow = g._spread_reference(graph.indptr, graph.indices, w, s)
            assert np.array_equal(fast, slow) and np.array_equal(heap, slow), name
            assert np.array_equal(graph.spread(s, w), slow), name
    assert n > 2


def test_spread_equals_its_reference_with_ties() -> None:
    """Random sparse graphs with small integer weights (many equal costs, so the heaps and the
    buckets settle tied nodes in different orders): the same costs; with a zero or a huge
    weight (`_spread` then takes the heap) too."""
    from planner_core.model.routing import graph as g

    rng = np.random.default_rng(10)
    for _ in range(20):
        n = int(rng.integers(2, 300))
        i, j = rng.integers(0, n, (2, 4 * n))
        keep = i != j
        i, j = i[keep], j[keep]
        w = rng.integers(1, 4, len(i)).astype(float)
        src, dst, wts = np.concatenate([i, j]), np.concatenate([j, i]), np.concatenate([w, w])
        order = np.lexsort((dst, src))
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(src, minlength=n), out=indptr[1:])
        indices, wts = np.ascontiguousarray(dst[order]), np.ascontiguousarray(wts[order])
        s = np.where(rng.random(n) < 0.1, rng.integers(0, 3, n).astype(float), np.inf)
        slow = g._spread_reference(indptr, indices, wts, s)
        assert np.array_equal(g._spread(indptr, indices, wts, s, *g.weight_bounds(wts)), slow)
        assert np.array_equal(g._spread_heap(indptr, indices, wts, s), slow)
        # a zero weight, a huge one: the heap, with the same costs
        for odd in (0.0, 1e15):
            w2 = wts.copy()
            w2[: len(w2) // 7] = odd
            w2 = np.ascontiguousarray(w2)
            assert np.array_equal(g._spread(indptr, indices, w2, s, *g.weight_bounds(w2)),
                                  g._spread_reference(indptr, indices, w2, s))


def test_kmeans_equals_its_reference() -> None:
    """The sweep's k-means (k-means++ init keeping each sensor's least distance across picks)
    gives scipy's centres to the bit and leaves the generator where scipy leaves it: random
    fields of 1-400 sensors (numpy's pairwise sum above 128 and 256), clustered and duplicated
    sensors, every k up to J on small fields, and L02's 160 sensors for k = 1 .. 80."""
    from planner_core.model.mapio import load_map
    from planner_core.search import construct

    rng = np.random.default_rng(11)
    fields = [rng.uniform(0, 5000, (n, 2)) for n in (1, 2, 7, 8, 9, 40, 129, 257, 400)]
    fields.append(np.repeat(rng.uniform(0, 900, (6, 2)), 3, axis=0))  # duplicates
    fields.append(rng.normal(0, 1, (50, 2)) + rng.integers(0, 3, (50, 1)) * 4000.0)
    large = Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())
    fields.append(np.asarray(large.model.sensors, dtype=float))
    for f, S in enumerate(fields):
        ks = range(1, len(S) + 1) if len(S) <= 20 else sorted({1, 2, 3, len(S) // 4,
                                                               len(S) // 2, len(S)})
        if f == len(fields) - 1:
            ks = range(1, 81)
        for k in ks:
            for seed in (0, 1):
                r1, r2 = np.random.default_rng([f, k, seed]), np.random.default_rng([f, k, seed])
                fast = construct._kmeans(S, k, r1)
                slow = construct._kmeans_reference(S, k, r2)
                assert np.array_equal(fast, slow), (f, k, seed)
                assert r1.random() == r2.random(), (f, k, seed)


def test_numpy_sum_is_numpys() -> None:
    """`formulas.numpy_sum` (for compiled twins of numpy code) gives numpy's sums to the bit:
    1-D slices of every length to 700 and a few long ones, and the rows of a square matrix's
    ``sum(axis=1)``."""
    from planner_core.model.formulas import numpy_sum

    rng = np.random.default_rng(12)
    for n in [*range(0, 700), 1000, 4099, 100_003]:
        x = rng.random(n) ** 3 * 10.0 ** rng.integers(-3, 8)
        assert numpy_sum(x, 0, n) == x.sum(), n
        if n > 5:
            assert numpy_sum(x, 3, n - 5) == x[3:n - 2].sum(), n
    for n in (1, 7, 9, 100, 129, 300):
        T = rng.random((n, n)) ** 3 * 1e3
        rows = T.sum(axis=1)
        assert all(numpy_sum(T[i], 0, n) == rows[i] for i in range(n)), n


def _radio_cases() -> list[tuple[str, Problem]]:
    """Problems for the link rate's range cut: suite maps, L02 (160 sensors on 20 km), a dense
    field in scheduled access, and random maps with odd radios (no decay: no cut; a peak rate
    the overhead link never reaches: every rate 0; a long range)."""
    from planner_core.model.mapio import load_map
    from tests.test_cannot import dense_field

    out = [(t, Problem(json.loads((SUITE / f"{t}.json").read_text()))) for t in ("T03", "T16")]
    out.append(("L02", Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())))
    out.append(("scheduled", Problem(dense_field(radio={"access": "scheduled"}))))
    rng = np.random.default_rng(13)
    for name, radio in (("no-decay", {"decay": 0.0}), ("none-heard", {"peak_rate": 0.5}),
                        ("long-range", {"decay": 0.0005})):
        m = _random_map(rng, 30)
        m["radio"] = radio
        out.append((name, Problem(m)))
    return out


RADIO_CASES = _radio_cases()


def _probe_points(p: Problem, rng: np.random.Generator, n: int) -> np.ndarray:
    """Points near the sensors, on and a hair either side of the radio range in x, in y and
    diagonally, far away, outside the area and non-finite."""
    m = p.model
    S = m.sensors
    ratio = m.peak_rate / max(m.decay, 1e-6)
    reach = min(float(np.sqrt(max(ratio * ratio - m.altitude ** 2, 0.0))), 1e6)
    near = S[rng.integers(0, len(S), n)] + rng.normal(0, max(reach, 1.0), (n, 2))
    j = rng.integers(0, len(S), n)
    ang = rng.choice([0.0, np.pi / 2, np.pi / 4, np.pi, rng.uniform(0, 2 * np.pi)], n)
    eps = rng.choice([-1e-9, -1e-12, 0.0, 1e-12, 1e-9, 1e-6], n)
    rim = S[j] + (reach * (1 + eps))[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
    odd = np.array([[np.nan, 5.0], [5.0, np.nan], [np.inf, 0.0], [-np.inf, 3.0], [0.0, np.inf],
                    [-5e6, 1e6], [m.width * 3, -m.height]])
    return np.ascontiguousarray(np.vstack([near, rim, odd]))


@pytest.mark.parametrize("name,problem", RADIO_CASES, ids=[c[0] for c in RADIO_CASES])
def test_link_rates_window_equals_every_sensor(name: str, problem: Problem) -> None:
    """The link rates with the range cut (`formulas._link_rates_window`, what
    `ModelParams.rates` takes) equal the every-sensor loop to the bit (NaN included), on
    points at and a hair either side of the range, far away and non-finite."""
    from planner_core.model import formulas

    m = problem.model
    rng = np.random.default_rng(len(name))
    pts = _probe_points(problem, rng, 400)
    slow = formulas._link_rates_2d(pts, m.sensors, m.altitude ** 2, m.peak_rate, m.decay)
    fast = m.rates(pts)
    assert np.array_equal(fast, slow, equal_nan=True), name
    assert np.array_equal(np.signbit(fast), np.signbit(slow)), name
    if name in ("T03", "T16", "L02"):
        assert np.isfinite(m.window.half) and (slow[:400] > 0).any()
    if name == "no-decay":
        assert m.window.half == np.inf


@pytest.mark.parametrize("name,problem", RADIO_CASES, ids=[c[0] for c in RADIO_CASES])
def test_model_terms_window_equals_every_sensor(name: str, problem: Problem) -> None:
    """`Problem.evaluate`'s kernel with the range cut gives f, v3, v4 and the legs of the
    every-sensor loop (half = inf) to the bit: random populations, points on the range's rim
    and plans over the sensors (C3 and the scheduled flow active)."""
    from planner_core.model.kernels import model_terms

    p = problem
    rng = np.random.default_rng(len(name) + 1)
    n = 48
    X = p.lower + rng.random((n, p.dim)) * (p.upper - p.lower)
    probe = _probe_points(p, rng, n * p.n_points)[: n * p.n_points].reshape(n, p.n_points, 2)
    X[: n // 2, 0::4] = probe[: n // 2, :, 0]
    X[: n // 2, 1::4] = probe[: n // 2, :, 1]
    X[0, :2] = np.nan
    X = np.ascontiguousarray(X)

    def run(order: np.ndarray, xs: np.ndarray, half: float) -> list[np.ndarray]:
        legs = p.n_points + 1
        out = [np.empty((n, legs, 2)), np.empty((n, legs, 2)), np.empty(n), np.empty(n),
               np.empty(n)]
        model_terms(X, p.n_points, p.variable_length, p.tau, p.upper, p.start, p.end,
                    p.sensors, p.required, p.altitude, p.peak_rate, p.decay, order, xs, half,
                    p.bandwidth, p.v_max, p.accel, p.alpha, *out, p.scheduled)
        return out

    w = p.model.window
    fast, slow = run(*w), run(w.order, w.xs, np.inf)
    for a, b in zip(fast, slow, strict=True):
        assert np.array_equal(a, b, equal_nan=True), name
    f = p.evaluate(X)[0]  # a row with a NaN is never feasible in evaluate: f = phi = inf
    assert np.array_equal(f[1:], fast[2][1:]) and f[0] == np.inf


def test_greedy_cover_equals_its_reference_on_a_large_map() -> None:
    """L02 (160 sensors, ~1,000 candidate sites with the sweep's k-means centres: large tie
    sets at every pick): the compiled lazy greedy picks the reference's sites, with and without
    sites already chosen."""
    from planner_core.model.mapio import load_map
    from planner_core.search import construct

    p = Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())
    rng = np.random.default_rng(14)
    S = p.model.sensors
    centres = np.vstack([construct._kmeans(S, k, rng) for k in range(1, 81)])
    sites = construct.candidate_sites(p, centres)
    table = construct.CoverTable(p, sites)
    assert len(sites) > 500
    for frac in (0.9, 0.35):
        for chosen in (None, construct._kmeans(S, 30, rng), S[::3] + 400.0):
            fast = construct.greedy_cover(p, sites, frac, chosen=chosen, table=table)
            slow = construct.greedy_cover_reference(p, sites, frac, chosen=chosen)
            assert np.array_equal(fast, slow), frac


@pytest.mark.parametrize("name,problem", RADIO_CASES[:3], ids=[c[0] for c in RADIO_CASES[:3]])
def test_clusters_equal_their_reference(name: str, problem: Problem) -> None:
    """The seeder's clusters with compiled seeding and distances: the reference's centres,
    owners and generator state, for k from 1 to J and several service radii."""
    seeder = problem.seeder
    J = len(problem.model.sensors)
    for k in sorted({1, 2, 3, J // 3, J // 2, J}):
        for seed, radius in ((0, 350.0), (1, 800.0), (2, 60.0)):
            r1, r2 = np.random.default_rng([seed, k]), np.random.default_rng([seed, k])
            C1, o1 = seeder._clusters(r1, k, radius)
            C2, o2 = seeder._clusters_reference(r2, k, radius)
            assert np.array_equal(C1, C2) and np.array_equal(o1, o2), (name, k, seed)
            assert r1.random() == r2.random(), (name, k, seed)


def _lp_cases() -> list[tuple[np.ndarray, float]]:
    """Coverage matrices A (rows, points) >= 0 for the hover-time LP's blocks: random sparse
    ones (blocks of 1 to ~8 points, repeated rows and columns for degenerate vertices, a row no
    point reaches, tight t_max) and the scaled rates of random hover points on L02."""
    from planner_core.model.mapio import load_map

    rng = np.random.default_rng(15)
    out = []
    for case in range(300):
        m, n = int(rng.integers(1, 40)), int(rng.integers(1, 25))
        A = np.zeros((m, n))
        for j in range(m):
            c = int(rng.integers(0, n))
            w = int(rng.integers(1, 4))
            A[j, c:c + w] = rng.uniform(0.001, 0.05, len(range(c, min(c + w, n))))
        if case % 7 == 0 and m > 2:
            A[1] = A[0]  # a repeated row
        if case % 11 == 0 and n > 2:
            A[:, 1] = A[:, 0]  # a repeated point
        if case % 13 == 0:
            A[int(rng.integers(0, m))] = 0.0  # a sensor no point reaches
        out.append((A, float(rng.choice([1e6, 400.0, 60.0]))))
    p = Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())
    need = p.model.required
    for n in (5, 30, 65):
        pts = p.model.sensors[rng.integers(0, len(need), n)] + rng.normal(0, 300, (n, 2))
        R = p.model.rates(pts)
        served = R.sum(axis=0) > 0
        out.append((np.ascontiguousarray((R[:, served] / need[served]).T), p.model.t_max))
    return out


def test_lp_blocks_equal_their_reference() -> None:
    """The hover-time LP's small blocks (`hoverlp._lp_blocks`: blocks listed by a counting
    sort, multipliers solved only at feasible vertices) give the reference's hover times,
    duals, HiGHS points and verdict to the bit."""
    from planner_core.model import hoverlp

    for A, t_max in _lp_cases():
        m, n = A.shape
        res = []
        for f in (hoverlp._lp_blocks, hoverlp._lp_blocks_reference):
            T, y, rest = np.zeros(n), np.zeros(m), np.zeros(n, dtype=np.bool_)
            ok = f(A, hoverlp.TARGET, t_max, hoverlp.BLOCK_VERTICES, hoverlp.BLOCK_COMBOS,
                   T, y, rest)
            res.append((ok, T, y, rest))
        (ok1, T1, y1, r1), (ok2, T2, y2, r2) = res
        assert ok1 == ok2
        if ok1:
            assert np.array_equal(T1, T2) and np.array_equal(y1, y2) and np.array_equal(r1, r2)


@pytest.mark.parametrize("name,problem,pts", CASES[::3], ids=[c[0] for c in CASES[::3]])
def test_connect_equals_its_reference(name: str, problem: Problem, pts: np.ndarray) -> None:
    """The seeder's graph links kept by point (`Seeder.connect`) equal links computed afresh,
    for points met once, met again, in new company and as a single point."""
    seeder = problem.seeder
    again = np.vstack([pts[::2], pts, pts[:1]])
    for batch in (pts, again, pts[1:2], np.vstack([pts[::-1], problem.model.sensors])):
        assert np.array_equal(seeder.connect(batch), seeder.connect_reference(batch)), name


def test_connect_keeps_at_most_its_bound_and_the_same_links(monkeypatch) -> None:
    """`Seeder.connect`'s table of points starts afresh once it holds more than
    `CONNECT_POINTS`, so it never holds more than that plus one call's points, and the links
    stay those computed afresh."""
    from planner_core.model import seeding

    monkeypatch.setattr(seeding, "CONNECT_POINTS", 5)
    name, problem, pts = next(c for c in CASES if len(c[2]) >= 30 and c[1].seeder.graph.n)
    seeder = problem.seeder
    seeder.__dict__.pop("_links", None)
    held = []
    for k in range(0, len(pts), 3):
        batch = pts[k:k + 3]
        assert np.array_equal(seeder.connect(batch), seeder.connect_reference(batch)), name
        held.append(len(seeder.__dict__["_links"]))
        assert held[-1] <= 5 + len(batch), name
    assert any(b < a for a, b in zip(held, held[1:], strict=False)), held  # started afresh


def test_connect_equals_its_reference_on_a_large_map() -> None:
    from planner_core.model.mapio import load_map

    p = Problem(load_map(SUITE.parent / "large" / "L02.json").planning_map())
    rng = np.random.default_rng(17)
    pts = rng.uniform(0, p.model.width, (40, 2))
    for batch in (pts[:25], pts, pts[::-1], p.model.sensors[:30]):
        assert np.array_equal(p.seeder.connect(batch), p.seeder.connect_reference(batch))
    assert np.isfinite(p.seeder.connect(pts)).any()


@pytest.mark.parametrize("task", ["T16", "L02"])
def test_window_c3_flags_equal_the_pairwise_sum_at_the_bandwidth(task: str) -> None:
    """The trial's C3 flags from each point's window summed in order (`_over_bw_window`,
    `_points_over_bw`) equal numpy's pairwise row sum against the bandwidth (`_over_bw`), also
    where the bandwidth is set to a row's pairwise sum or one ulp either side of it, so that the
    window's order cannot decide and the pairwise sum must; an infinite bandwidth (scheduled
    access) or a NaN one flags nothing at once; and points off the map's numbers (NaN) take
    their whole row."""
    import math

    from planner_core.model.mapio import load_map
    from planner_core.search.trial import (
        _decided,
        _over_bw,
        _over_bw_window,
        _points_over_bw,
        _rates_k,
    )

    path = (SUITE / f"{task}.json" if task.startswith("T")
            else SUITE.parent / "large" / f"{task}.json")
    m = Problem(load_map(path).planning_map()).model
    win = m.window
    assert math.isfinite(win.half)
    rng = np.random.default_rng(5)
    near = m.sensors[rng.integers(0, len(m.sensors), 60)] + rng.normal(0, 120, (60, 2))
    pts = np.vstack([near, [[np.nan, 10.0]]])
    args = (m.sensors, win.order, win.xs, float(win.half), m.altitude**2, m.peak_rate, m.decay,
            True)
    R = _rates_k(pts, *args)
    sums = R[:-1].sum(axis=1)
    busy = sums[sums > 0]
    undecided = 0
    for bw in (m.c3_limit, np.inf, np.nan, *busy[:8], *np.nextafter(busy[:8], np.inf),
               *np.nextafter(busy[:8], -np.inf)):
        want = _over_bw(R, bw)
        assert np.array_equal(_over_bw_window(R, pts, win.order, win.xs, float(win.half), True,
                                              bw), want), bw
        assert np.array_equal(_points_over_bw(pts, *args, bw), want), bw
        undecided += sum(_decided(s, R.shape[1], bw) < 0 for s in sums)
    assert undecided >= 24  # the rows at their own sums and one ulp off went the pairwise way
    assert all(_decided(s, R.shape[1], bw) == 0 for s in sums for bw in (np.inf, np.nan))
    assert np.array_equal(_over_bw_window(R, pts, win.order, win.xs, float(win.half), False,
                                          m.c3_limit), _over_bw(R, m.c3_limit))


def _bits_equal(a: np.ndarray, b: np.ndarray) -> bool:
    """The same float64 bits (signed zeros and NaN payloads told apart)."""
    return a.shape == b.shape and np.array_equal(np.asarray(a).view(np.int64),
                                                 np.asarray(b).view(np.int64))


def test_solve_small_skips_only_what_leaves_the_bits() -> None:
    """`hoverlp._solve_small` (zeros skipped) gives `_solve_small_reference`'s verdict and
    solution to the bit: the simplex's bases (sparse rows of scaled rates and unit rows, both
    systems), dense and negative matrices, singular ones, and inputs holding -0.0, NaN or inf
    (which take the reference's loops); and square cuts of L02's scaled rates."""
    from planner_core.model import hoverlp

    rng = np.random.default_rng(8)
    cases: list[tuple[np.ndarray, np.ndarray]] = []
    for _ in range(300):
        k = int(rng.integers(1, 40))
        M = rng.uniform(0.0, 0.05, (k, k)) * (rng.random((k, k)) < rng.uniform(0.02, 0.3))
        unit = rng.random(k) < rng.uniform(0.0, 0.8)  # T_i >= 0 rows of a basis
        M[unit] = 0.0
        M[unit, rng.integers(0, k, int(unit.sum()))] = 1.0
        b = np.where(unit, 0.0, 1.0)
        cases += [(M, b), (np.ascontiguousarray(M.T), np.ones(k))]
        D = rng.normal(0.0, 1.0, (k, k))
        cases.append((D, rng.normal(0.0, 1.0, k)))
        S = D.copy()
        S[-1] = S[0] * 2.0  # singular
        cases.append((S, np.ones(k)))
        odd = D.copy()
        odd[rng.integers(0, k), rng.integers(0, k)] = rng.choice([-0.0, np.nan, np.inf])
        cases.append((odd, -0.0 * np.ones(k)))
    for A, _ in _lp_cases():  # L02's scaled rates of 30 and 65 points, cut square
        if A.shape[1] > 20 and A.shape[0] >= A.shape[1]:
            m, k = A.shape
            cases.append((np.ascontiguousarray(A[:k]), np.ones(k)))
    for M, b in cases:
        k = M.shape[0]
        out1, out2 = np.empty(k), np.empty(k)
        ok1 = hoverlp._solve_small(M, b, out1)
        ok2 = hoverlp._solve_small_reference(M, b, out2)
        assert ok1 == ok2
        if ok1:
            assert _bits_equal(out1, out2)


def test_rest_block_equals_numpys_indexing() -> None:
    """`hoverlp._rest_block` gives the rows and the sub-matrix that numpy's mask and `np.ix_`
    give, for the LP cases and random masks (none, some, all points)."""
    from planner_core.model import hoverlp

    rng = np.random.default_rng(21)
    for A, _ in _lp_cases():
        for rest in (np.zeros(A.shape[1], dtype=bool), rng.random(A.shape[1]) < 0.5,
                     np.ones(A.shape[1], dtype=bool)):
            rows, sub = hoverlp._rest_block(A, rest)
            want = (A[:, rest] > 0.0).any(axis=1)
            assert np.array_equal(rows, want)
            assert _bits_equal(sub, np.ascontiguousarray(A[np.ix_(want, rest)]))
            assert sub.flags.c_contiguous
