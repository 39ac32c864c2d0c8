"""The sim's leg-against-obstacle work is bounded: each distinct leg is measured once, and only
against the obstacles near it (`sim.obstacles.overlap_totals`, `distances_to`), with the same
answers as the plain table of every leg against every obstacle (`overlap_lengths`)."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
import shapely

from lamde_mission.items import CMD, plan_to_items
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from sim import obstacles as sim_obstacles
from sim import replay, verify
from sim.obstacles import distances_to, obstacle_shapes, overlap_lengths, overlap_totals


def _random_map(rng: np.random.Generator) -> object:
    circles = [{"x": float(x), "y": float(y), "radius": float(r)}
               for x, y, r in zip(rng.uniform(50, 950, 4), rng.uniform(50, 950, 4),
                                  rng.uniform(5, 80, 4), strict=True)]  # fmt: skip
    rects = [{"x": float(x), "y": float(y), "length": float(a), "width": float(b),
              "angle_deg": float(t)}
             for x, y, a, b, t in zip(rng.uniform(50, 950, 5), rng.uniform(50, 950, 5),
                                      rng.uniform(5, 120, 5), rng.uniform(5, 120, 5),
                                      rng.uniform(0, 180, 5), strict=True)]  # fmt: skip
    return load_map({
        "area": {"width": 1000, "height": 1000}, "start": [1, 1], "end": [999, 999],
        "sensors": [{"id": "a", "x": 500, "y": 2}],
        "obstacles": {"circles": circles, "rectangles": rects,
                      "no_fly_zones": [{"vertices": [[300, 300], [420, 310], [360, 330],
                                                     [410, 420], [290, 400]]}]},
    })  # fmt: skip


@pytest.mark.parametrize("seed", range(8))
def test_overlap_totals_and_distances_equal_the_plain_table(seed: int) -> None:
    rng = np.random.default_rng(seed)
    obs = obstacle_shapes(_random_map(rng))
    path = rng.uniform(0, 1000, (30, 2))
    loop = np.vstack([path[:5]] * 7)  # the same legs flown again (a DO_JUMP loop)
    paths = [path, loop, path[:1]]
    plain = sum(overlap_lengths(p, obs).sum(axis=0) for p in paths)
    assert plain.sum() > 0.0
    np.testing.assert_allclose(overlap_totals(paths, obs), plain, rtol=1e-12, atol=1e-9)
    shapes = np.array([o.shape for o in obs], dtype=object)
    lines = shapely.multilinestrings([shapely.linestrings(p) for p in paths if len(p) >= 2])
    np.testing.assert_allclose(distances_to(paths, shapes), shapely.distance(lines, shapes),
                               rtol=0, atol=1e-9)  # fmt: skip
    assert np.all(overlap_totals([path[:1]], obs) == 0.0)
    assert np.all(np.isinf(distances_to([path[:1]], shapes)))


def test_verify_measures_each_distinct_leg_only_near_obstacles(monkeypatch) -> None:
    """A DO_JUMP loop over a map of many obstacles: no table of every leg by every obstacle
    (which ran a 24,000-pass loop on 5,000 rectangles out of memory in verify)."""
    rects = [{"x": 20 + (i % 20) * 45, "y": 20 + (i // 20) * 45, "length": 2, "width": 2}
             for i in range(400)]  # fmt: skip
    m = load_map({"origin": {"lat": 22.3, "lon": 114.2, "alt": 0.0},
                  "area": {"width": 1000, "height": 1000}, "start": [5, 5], "end": [990, 990],
                  "sensors": [{"id": "a", "x": 500, "y": 500}, {"id": "b", "x": 800, "y": 200}],
                  "obstacles": {"rectangles": rects}})  # fmt: skip
    p = Problem(m)
    b = p.breakdown(p.encode([[500, 500], [800, 200]], [30.0, 30.0]))
    plan = SimpleNamespace(hover_points=np.array(b["hover_points"]),
                           hover_times=np.array(b["hover_times"]))
    items = plan_to_items(plan, m)
    k = [i for i, it in enumerate(items) if it.command == CMD.LOITER_TIME]
    jump = replace(items[k[1]], command=CMD.DO_JUMP, param1=float(items[k[0]].seq), param2=300.0,
                   param3=0.0, param4=0.0, x=0.0, y=0.0, z=0.0)  # fmt: skip
    items = items[:k[1] + 1] + [jump] + items[k[1] + 1:]
    items = [replace(it, seq=i) if it.seq is not None else it for i, it in enumerate(items)]
    items = [replace(jump, seq=k[1] + 1, param1=float(k[0])) if i == k[1] + 1 else it
             for i, it in enumerate(items)]  # fmt: skip
    tl = replay(items, m)
    assert len(tl.path) > 600  # the loop flown 300 more times
    biggest = [0]
    real = shapely.intersection

    def counting(a, b, **kw):
        biggest[0] = max(biggest[0], np.broadcast(np.asarray(a), np.asarray(b)).size)
        return real(a, b, **kw)

    monkeypatch.setattr(sim_obstacles.shapely, "intersection", counting)
    v = verify(tl, m)
    assert any(x.name == "C5" for x in v.items)
    assert 0 < biggest[0] <= 100, biggest[0]  # not (legs x 400)


def test_the_figure_cuts_each_distinct_leg_by_the_obstacles_it_meets_only(monkeypatch) -> None:
    """`show` of a DO_JUMP loop on a map of many obstacles cut every leg by the union of every
    obstacle (over 150 s at 5,000 rectangles); the segments drawn are the same."""
    import lamde_mission.plot as plot

    rects = [{"x": 20 + (i % 20) * 45, "y": 20 + (i // 20) * 45, "length": 8, "width": 8}
             for i in range(400)]  # fmt: skip
    m = load_map({"area": {"width": 1000, "height": 1000}, "start": [1, 1], "end": [990, 990],
                  "sensors": [{"id": "a", "x": 500, "y": 500}],
                  "obstacles": {"rectangles": rects}})  # fmt: skip
    lap = np.array([[1.0, 1.0], [990.0, 22.0], [990.0, 990.0], [3.0, 990.0]])
    path = np.vstack([lap] * 50)
    union = shapely.union_all([o.shape for o in obstacle_shapes(m)])
    want = [shapely.LineString(seg).intersection(union)
            for seg in np.stack([lap, np.roll(lap, -1, axis=0)], axis=1)]
    biggest = [0]
    real = shapely.union_all

    def counting(geoms, **kw):
        biggest[0] = max(biggest[0], len(np.atleast_1d(np.asarray(geoms, dtype=object))))
        return real(geoms, **kw)

    monkeypatch.setattr(shapely, "union_all", counting)
    got = plot._violation_segments(m, path)
    assert 0 < biggest[0] <= 40, biggest[0]  # the rectangles one leg crosses, not all 400
    total = sum(float(np.sum(np.hypot(*np.diff(g, axis=0).T))) for g in got)
    assert total == pytest.approx(sum(w.length for w in want), rel=1e-12) and total > 0.0


def _pair_by_pair(path: np.ndarray, obs: list) -> np.ndarray:
    """The slow reference of `overlap_lengths`: each leg against each obstacle on its own
    (shapely's intersection for a polygon, one `_chords` call per circle)."""
    out = np.zeros((len(path) - 1, len(obs)))
    for i in range(len(path) - 1):
        leg = shapely.linestrings(path[i:i + 2])
        for k, o in enumerate(obs):
            if o.circle is None:
                out[i, k] = shapely.length(shapely.intersection(leg, o.shape))
            else:
                cx, cy, r = o.circle
                out[i, k] = sim_obstacles._chords(path[i:i + 1], path[i + 1:i + 2],
                                                  np.array([cx, cy]), r)[0]  # fmt: skip
    return out


@pytest.mark.parametrize("seed", range(6))
def test_overlap_lengths_equals_each_leg_against_each_obstacle(seed: int) -> None:
    """`overlap_lengths` measures every circle in one call and intersects only the polygons
    whose box a leg's box meets: the same table, bit for bit, as leg by leg and obstacle by
    obstacle (legs across the map, short legs, a leg along an edge, a zero-length leg)."""
    rng = np.random.default_rng(seed)
    obs = obstacle_shapes(_random_map(rng))
    path = np.vstack([rng.uniform(0, 1000, (12, 2)),
                      rng.uniform(0, 1000, (1, 2)) + rng.uniform(-30, 30, (6, 2)),
                      [[300, 300], [420, 310], [420, 310]]])  # fmt: skip
    got = overlap_lengths(path, obs)
    assert got.shape == (len(path) - 1, len(obs)) and got.sum() > 0.0
    assert np.array_equal(got, _pair_by_pair(path, obs))
    assert overlap_lengths(path[:1], obs).shape == (0, len(obs))
