"""Detour corners (issue 31): a point of 0 s is written as NAV_WAYPOINT (hold 0, param2 the
corner's acceptance radius), never as a 0-second LOITER_TIME; the sim replays it as a stop
that is not a hover point, and `verify` passes on what is written."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from lamde_mission.formats import read_mission, write_mission
from lamde_mission.formats.geojson import geojson_document
from lamde_mission.items import (
    CMD,
    CORNER_RADIUS_MIN_M,
    corner_radius,
    corner_stops,
    items_to_route,
    plan_to_items,
)
from lamde_mission.storage import storable_plan, stored_items
from planner_core.model.mapio import load_map
from sim import replay, verify

#: a wall from the bottom edge up to y = 900 between the start and sensor 'a': the leg from
#: the west to the east must go over its top end
WALL_MAP = {
    "name": "wall",
    "origin": {"lat": 23.0493, "lon": 113.3975, "alt": 10.0},
    "area": {"width": 2000, "height": 1200},
    "start": [100, 500],
    "end": [1900, 500],
    "sensors": [{"id": "a", "x": 1500, "y": 500}, {"id": "b", "x": 300, "y": 300}],
    "obstacles": {"rectangles": [{"x": 1000, "y": 450, "length": 40, "width": 900,
                                  "angle_deg": 0}]},  # fmt: skip
    "uav": {"altitude": 80, "max_speed": 15, "acceleration": 3, "max_hover_points": 4},
    "safety": {"clearance": 5, "data_margin": 0},
}

#: hover point near 'b', a corner over the wall's top end, hover point near 'a'
PLAN = SimpleNamespace(hover_points=[[300, 420], [1000, 960], [1500, 560]],
                       hover_times=[30.0, 0.0, 30.0])  # fmt: skip


@pytest.fixture(scope="module")
def m():
    return load_map(WALL_MAP)


def _navigation(items):
    return [it for it in items if it.command in (CMD.WAYPOINT, CMD.LOITER_TIME)]


def test_the_straight_leg_is_blocked_and_the_corner_clears_it(m):
    """The fixture is what the test says: without the corner the leg crosses the wall."""
    from sim.obstacles import obstacle_shapes, overlap_lengths

    shapes = obstacle_shapes(m.planning_map())
    hp = np.asarray(PLAN.hover_points, dtype=float)
    straight = np.array([hp[0], hp[2]])
    assert overlap_lengths(straight, shapes).sum() > 40.0  # the wall is 40 m thick
    assert overlap_lengths(np.vstack([m.start, hp, m.end]), shapes).sum() == 0.0


def test_a_zero_second_point_is_a_nav_waypoint_corner(m):
    items = plan_to_items(PLAN, m)
    nav = _navigation(items)
    assert [it.command for it in nav] == [CMD.LOITER_TIME, CMD.WAYPOINT, CMD.LOITER_TIME,
                                          CMD.WAYPOINT]  # fmt: skip
    corner = nav[1]
    assert corner.param1 == 0.0 and corner.param2 == corner_radius(m) == 5.0
    assert not any(it.command == CMD.LOITER_TIME and it.param1 == 0.0 for it in items)
    route = items_to_route(items, m)
    assert list(route.is_hover) == [True, False, True, False, False]  # + LAND
    np.testing.assert_allclose(corner_stops(route), [[1000.0, 960.0]], atol=0.05)


def test_the_corner_radius_is_the_clearance_and_never_zero(m):
    """param2 = 0 would mean the autopilot's default (PX4 NAV_ACC_RAD, 10 m)."""
    assert corner_radius(m) == 5.0
    bare = load_map({**WALL_MAP, "safety": {"clearance": 0, "data_margin": 0}})
    assert corner_radius(bare) == CORNER_RADIUS_MIN_M > 0.0


@pytest.mark.parametrize("autopilot,radius", [("px4", 5.0), ("ardupilot", 0.0),
                                              ("generic", 0.0)])
def test_a_corner_keeps_its_radius_only_where_the_autopilot_stores_it(m, tmp_path: Path,
                                                                      autopilot, radius):
    """ArduPilot's AP_Mission keeps only a WAYPOINT's param1 on Copter builds (param2 reads
    back 0), so the ardupilot and generic files write 0 and an upload's read-back matches."""
    stored = storable_plan(PLAN, m, autopilot, planning_map=m.planning_map())
    path = write_mission(tmp_path / "wall.plan", stored, m, autopilot=autopilot)
    items, _fence = read_mission(path)
    corners = [it for it in _navigation(items)[:-1] if it.command == CMD.WAYPOINT]
    assert [it.param2 for it in corners] == [radius]
    assert stored_items(items, autopilot) == items  # what is written is what is stored


@pytest.mark.parametrize("autopilot", ["px4", "ardupilot", "generic"])
@pytest.mark.parametrize("suffix", [".plan", ".waypoints"])
def test_written_corners_replay_and_pass_verify(m, tmp_path: Path, autopilot, suffix):
    stored = storable_plan(PLAN, m, autopilot, planning_map=m.planning_map())
    path = write_mission(tmp_path / f"wall{suffix}", stored, m, autopilot=autopilot)
    items, _fence = read_mission(path)
    nav = _navigation(items)
    corners = [it for it in nav[:-1] if it.command == CMD.WAYPOINT]
    assert len(corners) == 1 and corners[0].param1 == 0.0
    assert all(it.param1 > 0.0 for it in nav if it.command == CMD.LOITER_TIME)
    tl = replay(items, m)
    assert len(tl.hover_times) == 2  # the corner is not a hover point
    v = verify(tl, m)
    assert v.passed, (v.failed, v.table())


def test_the_corner_is_charged_as_a_full_stop(m):
    """The sim keeps Eq. 1's full stop at a corner: the same flight time as a 0-s hover point
    had (conservative for a blended turn)."""
    from dataclasses import replace

    items = plan_to_items(PLAN, m)
    as_loiter = [replace(it, command=CMD.LOITER_TIME, param2=0.0, param4=0.0)
                 if it.command == CMD.WAYPOINT and it.param1 == 0.0 and k < len(items) - 2
                 else it for k, it in enumerate(items)]  # fmt: skip
    a, b = replay(items, m).totals, replay(as_loiter, m).totals
    assert a.t_fly == pytest.approx(b.t_fly, rel=1e-12)
    assert a.t_hover == b.t_hover


def test_geojson_names_the_corner(m):
    doc = geojson_document(PLAN, m)
    kinds = [f["properties"]["kind"] for f in doc["features"]]
    assert kinds.count("hover") == 2 and kinds.count("corner") == 1
    path = next(f for f in doc["features"] if f["properties"]["kind"] == "path")
    assert path["properties"]["n_hover"] == 2 and path["properties"]["n_corner"] == 1
    json.dumps(doc, allow_nan=False)


@pytest.mark.slow  # measured 3.5 s (one plan at 2,000 evaluations)
def test_a_planned_detour_is_written_with_corners_and_verifies(m, tmp_path: Path, capsys):
    """End to end: `plan` on the walled map routes over the wall through a 0-s point; the
    written mission holds it as NAV_WAYPOINT, no 0-s LOITER_TIME, and `verify` passes."""
    from lamde_mission.cli import main

    map_path = tmp_path / "wall.json"
    map_path.write_text(json.dumps(WALL_MAP))
    out = tmp_path / "wall.plan"
    assert main(["plan", str(map_path), "-o", str(out), "--seed", "0", "--budget", "2000"]) == 0
    text = capsys.readouterr().out
    items, _fence = read_mission(out)
    nav = _navigation(items)
    assert not any(it.command == CMD.LOITER_TIME and it.param1 == 0.0 for it in items)
    corners = [it for it in nav[:-1] if it.command == CMD.WAYPOINT]
    assert corners, "the planned detour has a corner"
    assert f"+ {len(corners)} corner" in text
    assert verify(replay(items, m), m).passed
    assert main(["verify", str(map_path), str(out)]) == 0
    assert "corner" in capsys.readouterr().out


# ----------------------------------------------------------------------------- corner slots


def _problem(m, k=0):
    from planner_core.model.problem import Problem

    return Problem(m.planning_map(), corner_slots=k)


def test_the_paper_problem_is_unchanged_and_corner_slots_only_add_v6(m):
    """corner_slots 0 is the paper's Problem; with K slots a plan that fits I_max scores the
    same f and phi as in the paper's model (the extra slots inactive), so v6 is the only new
    term."""
    from planner_core.model.problem import Problem

    paper, zero, k3 = Problem(m.planning_map()), _problem(m, 0), _problem(m, 3)
    assert paper.dim == zero.dim == 4 * m.max_hover_points and k3.dim == paper.dim + 12
    assert paper.hover_limit == k3.hover_limit == m.max_hover_points
    rng = np.random.default_rng(7)
    X = paper.lower + rng.random((64, paper.dim)) * (paper.upper - paper.lower)
    for a, b in zip(paper.evaluate(X), zero.evaluate(X), strict=True):
        np.testing.assert_array_equal(a, b)
    hp, ht = np.array(PLAN.hover_points), np.array(PLAN.hover_times)
    fa, pa = paper.evaluate(paper.encode(hp, ht)[None, :])
    fb, pb = k3.evaluate(k3.encode(hp, ht)[None, :])
    assert fa[0] == pytest.approx(fb[0], rel=1e-12) and pa[0] == pytest.approx(pb[0], abs=1e-9)


def test_v6_counts_hover_points_beyond_imax_and_never_corners(m):
    lim = load_map({**WALL_MAP, "uav": {**WALL_MAP["uav"], "max_hover_points": 2}})
    k1 = _problem(lim, 1)
    hp, ht = np.array(PLAN.hover_points), np.array(PLAN.hover_times)  # 2 hover + 1 corner
    with pytest.raises(ValueError, match=r"3 hover points exceed I_max = 2$"):
        _problem(lim, 0).encode(hp, ht)
    with pytest.raises(ValueError, match=r"4 hover points exceed I_max = 2 \+ 1 corner slot$"):
        k1.encode(np.vstack([hp, hp[:1]]), np.append(ht, 0.0))  # it said "I_max = 3"
    assert repr(k1).endswith(", 1 corner slot)")  # "1 corner slots", as the line above
    with pytest.raises(ValueError, match=r"^hover_times: 1 value for 3 hover points; give one"):
        k1.encode(hp, ht[:1])
    x_ok = k1.encode(hp, ht)
    x_bad = k1.encode(hp, np.where(ht == 0.0, 5.0, ht))  # the corner hovers: 3 > I_max 2
    f, phi = k1.evaluate(np.vstack([x_ok, x_bad]))
    parts = k1._evaluate_parts(np.vstack([x_ok, x_bad]))
    np.testing.assert_array_equal(parts["v6"], [0.0, 1.0])
    np.testing.assert_allclose(phi, parts["phi"], rtol=1e-9, atol=1e-9)
    assert phi[1] >= phi[0] + 1.0
    b = k1.breakdown(x_ok)
    assert b["v6"] == 0.0 and b["n_corner"] == 1
    with pytest.raises(ValueError, match="corner_slots"):
        _problem(lim, -1)


def test_a_written_mission_hovers_at_most_imax_points_while_corners_may_exceed_it(tmp_path):
    lim = load_map({**WALL_MAP, "uav": {**WALL_MAP["uav"], "max_hover_points": 2}})
    stored = storable_plan(PLAN, lim, "ardupilot", planning_map=lim.planning_map())
    path = write_mission(tmp_path / "wall.plan", stored, lim, autopilot="ardupilot")
    items, _fence = read_mission(path)
    nav = _navigation(items)
    assert sum(it.command == CMD.LOITER_TIME for it in nav) <= lim.max_hover_points
    assert len(nav) - 1 > lim.max_hover_points  # the corner is one more point
    assert verify(replay(items, lim), lim).passed


def test_corner_slots_bad_input_is_one_line_and_exit_2(tmp_path: Path, capsys):
    from lamde_mission.cli import main

    map_path = tmp_path / "wall.json"
    map_path.write_text(json.dumps(WALL_MAP))
    out = tmp_path / "x.plan"
    assert main(["plan", str(map_path), "-o", str(out), "--corner-slots", "-1"]) == 2
    assert "--corner-slots" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.slow  # measured ~4 s (one plan at 2,000 evaluations)
def test_planning_with_corner_slots_keeps_imax_hover_points(tmp_path: Path):
    """I_max 2 on the walled map: the corner over the wall does not take a slot of the two."""
    import lamde_mission

    spec = {**WALL_MAP, "uav": {**WALL_MAP["uav"], "max_hover_points": 2}}
    lim = load_map(spec)
    plan = lamde_mission.plan(lim, seed=0, budget=2000, corner_slots=2)
    assert plan.feasible and plan.config["corner_slots"] == 2
    assert np.count_nonzero(np.asarray(plan.hover_times) > 0.0) <= 2
    stored = storable_plan(plan, lim, "generic", planning_map=lim.planning_map())
    items, _fence = read_mission(write_mission(tmp_path / "w.plan", stored, lim))
    assert sum(it.command == CMD.LOITER_TIME for it in items) <= 2
    assert verify(replay(items, lim), lim).passed


def _on_the_boundary(m, points, times) -> SimpleNamespace:
    """The plan (points, times scaled) whose tightest sensor collects 1 - 5e-7 of its
    requirement as planned: short by less than `storage.PLANNED_SHORT`, so storing it (float32
    times, px4) leaves a shortfall that storage must make up, as it does for the planner's
    LP plans on a constraint's boundary (a plan short by more is written as it is)."""
    from lamde_mission.storage import _grid_point

    # the points on the 1e-7 degree grid already: storing moves none (a move of a few mm
    # changes a point's rates by ~1e-5, more than the shortfall made here), so the float32
    # times alone leave the tightest sensor short
    points = np.array([_grid_point(m, np.asarray(q, dtype=float)) for q in points])
    plan = SimpleNamespace(hover_points=points, hover_times=np.asarray(times, dtype=float))
    got = replay(plan_to_items(plan, m), m).collected
    need = np.asarray(m.planning_map().required_data, dtype=float)
    scale = float(np.max(need[need > 0] / got[need > 0])) * (1.0 - 5e-7)
    return SimpleNamespace(hover_points=points, hover_times=plan.hover_times * scale)


def test_storage_raises_hover_times_beside_a_corner(m):
    """The storage step raises short hover times where the replay's hover points (the corner is
    not one) are fewer than the plan's points: rows stay aligned (it failed with a shape error
    on T16 at 3,000 evaluations)."""
    short = _on_the_boundary(m, PLAN.hover_points, [1.0, 0.0, 1.0])
    stored = storable_plan(short, m, "px4", planning_map=m.planning_map())
    assert stored.hover_times[1] == 0.0
    assert np.any(stored.hover_times[[0, 2]] > short.hover_times[[0, 2]] * (1 + 2e-7))
    items = stored_items(plan_to_items(stored, m), "px4")
    assert verify(replay(items, m), m).passed


#: four sensors within 60 m: a point amid them hears 35.5 of 25 Mbit/s, one 500 m north
#: 20.1 Mbit/s (altitude 100 m, the default radio)
DENSE_FIELD = {
    "name": "field",
    "origin": {"lat": 46.2, "lon": 7.3, "alt": 500.0},
    "area": {"width": 2000, "height": 2000},
    "start": [100, 1000],
    "end": [1900, 1500],
    "sensors": [{"id": "a", "x": 1000, "y": 1000}, {"id": "b", "x": 1000, "y": 1060},
                {"id": "c", "x": 1060, "y": 1000}, {"id": "d", "x": 940, "y": 1000}],
    "uav": {"altitude": 100},
    "safety": {"clearance": 0, "data_margin": 0},
}  # fmt: skip


def test_storage_never_raises_a_point_that_would_break_c3():
    """A corner (0 s) amid a dense field hears 35.5 of 25 Mbit/s: a sensor short once stored
    gets its data from the hover point that keeps C3, not from the corner with the better
    rate (L08's 25-min battery map, seed 3: the corner of sortie 7 was raised to 1 s and the
    stored sortie failed C3 at 49.7 of 25 Mbit/s)."""
    from sim.replay import hover_rates

    fm = load_map(DENSE_FIELD)
    radio = fm.spec.radio
    # the corner's rates sum above R_lambda: hovering there breaks C3
    rates = hover_rates(np.array([[1000.0, 1000.0], [1000.0, 1500.0]]), np.array([100.0, 100.0]),
                        np.asarray(fm.sensors, dtype=float), radio.peak_rate, radio.decay)
    assert rates[0].sum() > radio.bandwidth >= rates[1].sum()
    # the hover point on the boundary of c's and d's data (200 Mbit at 4.87 Mbit/s: 41.07 s)
    short = _on_the_boundary(fm, [[1000, 1000], [1000, 1500]], [0.0, 41.0])
    stored = storable_plan(short, fm, "px4", planning_map=fm.planning_map())
    assert stored.hover_times[0] == 0.0  # the corner keeps C3: not raised
    assert stored.hover_times[1] > short.hover_times[1] * (1 + 2e-7)  # raised, not rounded
    v = verify(replay(stored_items(plan_to_items(stored, fm), "px4"), fm), fm)
    assert v.passed, v.failed


def test_storage_in_scheduled_access_keeps_the_dense_point():
    """In scheduled access (the sensors share R_lambda by time slots) a point whose summed
    rates exceed R_lambda may hover, and may be raised: 31 s there leaves the field short
    (800 Mbit at 25 Mbit/s takes 32 s), and the stored plan serves it and passes the sim's
    allocation check."""
    fm = load_map({**DENSE_FIELD, "name": "field-scheduled", "radio": {"access": "scheduled"}})
    plan = _on_the_boundary(fm, [[1000, 1000]], [31.0])  # 800 Mbit at 25 Mbit/s: 32 s
    assert 31.9 < plan.hover_times[0] < 32.0
    stored = storable_plan(plan, fm, "px4", planning_map=fm.planning_map())
    assert np.hypot(*(stored.hover_points[0] - [1000.0, 1000.0])) < 0.05
    assert stored.hover_times[0] > plan.hover_times[0] * (1 + 2e-7)  # raised, not rounded
    v = verify(replay(stored_items(plan_to_items(stored, fm), "px4"), fm), fm)
    assert v.passed, v.failed
