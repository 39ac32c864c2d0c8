"""Plan -> MAVLink mission items, geofence items, and items -> local route."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from pymavlink import mavutil

from lamde_mission.geo import latlon_to_enu
from lamde_mission.items import (
    CMD,
    FRAME,
    MissionError,
    MissionItem,
    fence_from_items,
    geofence_items,
    items_equal,
    items_to_route,
    plan_to_items,
)
from planner_core.model.mapio import load_map
from tests.conftest import ROOT

M = mavutil.mavlink

MAP = {
    "name": "items",
    "origin": {"lat": 23.0493, "lon": 113.3975, "alt": 10.0},
    "area": {"width": 2000, "height": 1500},
    "start": [0, 0],
    "end": [1800, 1400],
    "sensors": [{"id": "a", "x": 400, "y": 300}, {"id": "b", "x": 1200, "y": 900}],
    "obstacles": {
        "circles": [{"x": 1000, "y": 200, "radius": 60}, {"x": 300, "y": 1200, "radius": 45}],
        "rectangles": [{"x": 1500, "y": 600, "length": 150, "width": 90, "angle_deg": 35}],
        "no_fly_zones": [{"vertices": [[600, 900], [800, 850], [850, 1100], [650, 1150]]}],
    },
    "uav": {"altitude": 80, "max_speed": 15, "acceleration": 3, "max_hover_points": 4},
}

PLAN = SimpleNamespace(hover_points=[[400, 320], [1190, 880.5]], hover_times=[42.5, 61.25])


@pytest.fixture(scope="module")
def m():
    return load_map(MAP)


def _local(m, it):
    e, n = latlon_to_enu(it.x, it.y, m)
    return np.array([float(e), float(n)])


def test_mission_structure_and_parameters(m):
    items = plan_to_items(PLAN, m)
    assert [it.command for it in items] == [
        M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_CMD_NAV_LOITER_TIME,
        M.MAV_CMD_NAV_LOITER_TIME, M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LAND,
    ]  # fmt: skip
    assert [it.seq for it in items] == list(range(len(items)))
    assert all(it.mission_type == M.MAV_MISSION_TYPE_MISSION for it in items)
    assert all(it.autocontinue == 1 and it.current == 0 for it in items)
    takeoff, speed, h1, h2, wp, land = items
    nav = [takeoff, h1, h2, wp, land]
    assert all(it.frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT for it in nav)
    assert takeoff.z == 80.0 and h1.z == 80.0 and wp.z == 80.0 and land.z == 0.0
    assert (speed.param1, speed.param2, speed.param3) == (1.0, 15.0, -1.0)
    assert (h1.param1, h2.param1) == (42.5, 61.25)
    assert h1.param3 == 0.0  # loiter radius 0: hover on the spot
    assert math.isnan(takeoff.param4) and math.isnan(wp.param4) and math.isnan(land.param4)
    np.testing.assert_allclose(_local(m, takeoff), [0, 0], atol=1e-6)
    np.testing.assert_allclose(_local(m, h1), [400, 320], atol=1e-6)
    np.testing.assert_allclose(_local(m, h2), [1190, 880.5], atol=1e-6)
    np.testing.assert_allclose(_local(m, wp), [1800, 1400], atol=1e-6)
    np.testing.assert_allclose(_local(m, land), [1800, 1400], atol=1e-6)


def test_rtl_finish_speed_override_and_bad_finish(m):
    items = plan_to_items(PLAN, m, finish="rtl", speed=9.0)
    assert items[-1].command == M.MAV_CMD_NAV_RETURN_TO_LAUNCH
    assert items[-2].command == M.MAV_CMD_NAV_WAYPOINT
    assert items[1].param2 == 9.0
    with pytest.raises(ValueError, match="finish"):
        plan_to_items(PLAN, m, finish="crash")
    with pytest.raises(ValueError, match="differ"):
        plan_to_items(SimpleNamespace(hover_points=[[1, 2]], hover_times=[1, 2]), m)


def test_no_hover_points_still_flies_start_to_end(m):
    items = plan_to_items(SimpleNamespace(hover_points=np.zeros((0, 2)), hover_times=[]), m)
    assert [it.command for it in items] == [22, 178, 16, 21]


def test_geofence_items(m):
    fence = geofence_items(m)
    assert all(it.mission_type == M.MAV_MISSION_TYPE_FENCE for it in fence)
    assert [it.seq for it in fence] == list(range(len(fence)))
    # QGroundControl's order and flags: polygon vertices first, then circles; autocontinue 0
    kinds = [it.command == M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION for it in fence]
    assert kinds == sorted(kinds) and all(it.autocontinue == 0 for it in fence)
    circles = [it for it in fence if it.command == M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION]
    verts = [it for it in fence if it.command == M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION]
    assert len(circles) == 2 and len(verts) == 4 + 4
    assert [c.param1 for c in circles] == [60.0, 45.0]
    np.testing.assert_allclose(_local(m, circles[0]), [1000, 200], atol=1e-6)
    assert all(v.param1 == 4 for v in verts)
    rect = np.array([_local(m, v) for v in verts[:4]])
    np.testing.assert_allclose(rect, m.rectangle_polygons[0], atol=1e-6)
    nfz = np.array([_local(m, v) for v in verts[4:]])
    np.testing.assert_allclose(nfz, m.nfz_polygons[0], atol=1e-6)
    circ, polys = fence_from_items(fence)
    assert len(circ) == 2 and [len(p) for p in polys] == [4, 4]
    assert not any(c[3] for c in circ) and not any(p[0][2] for p in polys)


def test_geofence_items_equal_each_shape_converted_on_its_own():
    """Every vertex and centre is converted to lat/lon in one call: the same items, number for
    number, as one conversion per polygon and per circle (a large map's thousand obstacles)."""
    from lamde_mission.items import fence_item, fence_shapes
    from sim.geo import enu_to_latlon

    m = load_map(ROOT / "examples/maps/large/L02.json")
    circles, polys = fence_shapes(m)
    ref = []
    for poly in polys:
        lat, lon = enu_to_latlon(np.asarray(poly)[:, 0], np.asarray(poly)[:, 1], m)
        for a, b in zip(lat, lon, strict=True):
            ref.append(fence_item(len(ref), CMD.FENCE_POLYGON_VERTEX_EXCLUSION, len(poly),
                                  float(a), float(b)))  # fmt: skip
    for centre, r in circles:
        lat, lon = enu_to_latlon(centre[:1], centre[1:], m)  # (1,) arrays, as before
        ref.append(fence_item(len(ref), CMD.FENCE_CIRCLE_EXCLUSION, r, float(lat[0]),
                              float(lon[0])))  # fmt: skip
    assert len(polys) > 200 and len(circles) > 200
    got = geofence_items(m)
    # the same items; lat/lon to 1e-12 degree (~0.1 um: a vectorised sin may differ in the
    # last bit from a short array's), far below the 1e-7 degree grid the file stores
    assert [replace(a, x=0.0, y=0.0) for a in got] == [replace(b, x=0.0, y=0.0) for b in ref]
    np.testing.assert_allclose([(a.x, a.y) for a in got], [(b.x, b.y) for b in ref],
                               rtol=0, atol=1e-12)  # fmt: skip


def test_fence_grouping_rejects_broken_polygons(m):
    fence = geofence_items(m)
    verts = [it for it in fence if it.command == CMD.FENCE_POLYGON_VERTEX_EXCLUSION]
    with pytest.raises(MissionError, match="fewer vertices"):
        fence_from_items(verts[:3])
    circle = next(it for it in fence if it.command == CMD.FENCE_CIRCLE_EXCLUSION)
    with pytest.raises(MissionError, match="interrupted"):
        fence_from_items([verts[0], circle])


def test_route_is_the_inverse(m):
    items = plan_to_items(PLAN, m)
    r = items_to_route(items, m)
    np.testing.assert_allclose(r.launch, [0, 0], atol=1e-6)
    assert r.takeoff_altitude == 80.0
    np.testing.assert_allclose(r.stops, [[400, 320], [1190, 880.5], [1800, 1400], [1800, 1400]],
                               atol=1e-6)  # fmt: skip
    assert r.is_hover.tolist() == [True, True, False, False]
    np.testing.assert_allclose(r.hover_durations, [42.5, 61.25])
    np.testing.assert_allclose(r.hover_points, [[400, 320], [1190, 880.5]], atol=1e-6)
    assert r.speed == 15.0 and r.finish == "land" and r.notes == ()
    assert r.seqs == (2, 3, 4, 5)


def test_route_edge_cases(m):
    items = plan_to_items(PLAN, m)
    # LAND at the current position (lat = lon = 0) lands where the vehicle is
    land_here = replace(items[-1], x=0.0, y=0.0)
    r = items_to_route([*items[:-1], land_here], m)
    np.testing.assert_allclose(r.stops[-1], [1800, 1400], atol=1e-6)
    # an unsupported navigation command is refused, naming the item
    bad = MissionItem(seq=3, command=M.MAV_CMD_NAV_LOITER_TURNS, x=items[2].x, y=items[2].y)
    with pytest.raises(MissionError, match="item 3: MAV_CMD_NAV_LOITER_TURNS"):
        items_to_route([*items[:3], bad], m)
    # DO commands are ignored with a note; items after the landing too
    servo = MissionItem(seq=6, command=M.MAV_CMD_DO_SET_SERVO, frame=FRAME.MISSION)
    r = items_to_route([*items[:2], servo, *items[2:], items[4].with_seq(7)], m)
    assert any("DO_SET_SERVO" in n for n in r.notes)
    assert any("after the landing" in n for n in r.notes)
    # terrain frames are not supported
    terrain = replace(items[2], frame=M.MAV_FRAME_GLOBAL_TERRAIN_ALT)
    with pytest.raises(MissionError, match="frame"):
        items_to_route([items[0], terrain], m)
    # an AMSL frame is read relative to the origin's altitude
    amsl = replace(items[2], frame=FRAME.GLOBAL, z=90.0)
    assert items_to_route([items[0], amsl], m).altitudes[0] == pytest.approx(80.0)
    with pytest.raises(MissionError, match="no navigation items"):
        items_to_route(items[:2], m)
    with pytest.raises(MissionError, match="LOITER_TIME"):
        items_to_route([items[0], replace(items[2], param1=-1.0)], m)


def test_item_equality_helpers(m):
    a = plan_to_items(PLAN, m)
    b = plan_to_items(PLAN, m)
    assert items_equal(a, b)
    assert not items_equal(a, b[:-1])
    assert not items_equal(a, [*b[:-1], replace(b[-1], param4=0.0)])
    clean = a[0].without_nan()
    assert clean.param4 == 0.0 and clean.x == a[0].x
    assert a[2].params == (42.5, 0.0, 0.0, 0.0, a[2].x, a[2].y, 80.0)
    assert not items_equal(a, [*b[:2], replace(b[2], param1=42.5 + 1e-3), *b[3:]])


def test_items_carry_the_mavlink_spec_numbers_on_disk(m):
    """What other tools read is the raw numbers: check them against MAVLink's common.xml
    (MAV_CMD_NAV_TAKEOFF 22, MAV_CMD_DO_CHANGE_SPEED 178, MAV_CMD_NAV_LOITER_TIME 19,
    MAV_CMD_NAV_WAYPOINT 16, MAV_CMD_NAV_LAND 21; MAV_FRAME_GLOBAL_RELATIVE_ALT 3,
    MAV_FRAME_MISSION 2), not against pymavlink's own constants."""
    from lamde_mission.formats import home_of
    from lamde_mission.formats.waypoints import format_waypoints

    lines = format_waypoints(plan_to_items(PLAN, m), home_of(m)).splitlines()
    assert lines[0] == "QGC WPL 110"
    rows = [ln.split("\t") for ln in lines[2:]]  # lines[1] is the home position
    assert [int(r[3]) for r in rows] == [22, 178, 19, 19, 16, 21]
    assert [int(r[2]) for r in rows] == [3, 2, 3, 3, 3, 3]
    assert [float(r[4]) for r in rows if int(r[3]) == 19] == [42.5, 61.25]  # hover seconds
    fence = geofence_items(m)
    assert {it.mission_type for it in fence} == {1}  # MAV_MISSION_TYPE_FENCE
    assert {it.command for it in fence} == {5002, 5004}  # FENCE_POLYGON_VERTEX_/CIRCLE_EXCLUSION
