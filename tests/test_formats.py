"""Mission files: QGroundControl .plan, ArduPilot .waypoints, GeoJSON; atomic writes."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from pymavlink import mavwp

from lamde_mission.formats import (
    MissionFileError,
    format_for,
    home_of,
    load_mission_items,
    read_mission,
    write_mission,
)
from lamde_mission.formats.qgc_plan import parse_plan_document, plan_document
from lamde_mission.formats.waypoints import format_waypoints, parse_waypoints
from lamde_mission.items import MissionError, geofence_items, items_equal, plan_to_items
from lamde_mission.storage import grid_degrees, storable_plan, stored_items
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem

MAP = {
    "name": "formats",
    "origin": {"lat": -35.3632, "lon": 149.1652, "alt": 584.0},
    "area": {"width": 3000, "height": 2000},
    "start": [100, 50],
    "end": [2900, 1900],
    "sensors": [
        {"id": "s1", "x": 500, "y": 400},
        {"id": "s2", "x": 1500, "y": 1000, "required_data": 300},
        {"id": "s3", "x": 2500, "y": 1500},
    ],
    "obstacles": {
        "circles": [{"x": 2000, "y": 300, "radius": 80}],
        "rectangles": [{"x": 800, "y": 1500, "length": 160, "width": 90, "angle_deg": 120}],
        "no_fly_zones": [{"vertices": [[1800, 1200], [2100, 1150], [2200, 1400], [1900, 1500]]}],
    },
    "uav": {"altitude": 90, "max_speed": 18, "acceleration": 3.5, "max_hover_points": 5},
}
HOVER = [[500, 420], [1500, 980], [2480, 1500]]
TIMES = [40.0, 55.5, 47.25]


def stored(plan, m, autopilot="generic", finish="land"):
    """The items a file written for `autopilot` holds: the storable plan, as stored."""
    sp = storable_plan(plan, m, autopilot, finish=finish)
    return stored_items(plan_to_items(sp, m, finish=finish), autopilot)


@pytest.fixture(scope="module")
def m():
    return load_map(MAP)


@pytest.fixture(scope="module")
def plan(m):
    p = Problem(m)
    b = p.breakdown(p.encode(HOVER, TIMES))
    return SimpleNamespace(hover_points=np.array(b["hover_points"]),
                           hover_times=np.array(b["hover_times"]), f=b["f"], phi=b["phi"],
                           feasible=b["phi"] == 0, breakdown=b)  # fmt: skip


def test_format_from_suffix():
    assert format_for("a/b.plan") == "plan"
    assert format_for("x.WAYPOINTS") == "waypoints"
    assert format_for("x.geojson") == "geojson"
    assert format_for("x.txt", "waypoints") == "waypoints"
    with pytest.raises(MissionFileError, match="suffix"):
        format_for("x.kml")
    with pytest.raises(MissionFileError, match="unknown mission format"):
        format_for("x.plan", "kml")


def test_a_format_that_disagrees_with_the_suffix_is_refused(m, plan, tmp_path):
    """`write_mission("x.plan", ..., fmt="waypoints")` wrote QGC WPL text into x.plan, which
    QGroundControl would not open: a known suffix takes only its own format; a file without
    one (x.txt) takes any."""
    assert format_for("x.PLAN", "plan") == "plan" and format_for("x.waypoints", ".WAYPOINTS")
    assert format_for("x.geojson", "json") == "geojson" and format_for("x", "plan") == "plan"
    for path, fmt, owner in (("x.plan", "waypoints", "QGroundControl JSON"),
                             ("x.waypoints", "plan", "QGC WPL text"),
                             ("x.geojson", "plan", "GeoJSON")):  # fmt: skip
        suffix = path[1:]
        with pytest.raises(MissionFileError, match=rf"^format {fmt} disagrees with the suffix "
                           rf"{suffix} of {path} \(a {suffix} file is {owner}, "):
            format_for(path, fmt)
    out = tmp_path / "x.plan"
    with pytest.raises(MissionFileError, match="disagrees"):
        write_mission(out, plan, m, fmt="waypoints")
    assert not out.exists()
    assert read_mission(write_mission(tmp_path / "x.txt", plan, m, fmt="waypoints"))[0]


def test_qgc_plan_layout(m, plan, tmp_path):
    path = write_mission(tmp_path / "m.plan", plan, m, autopilot="px4")
    doc = json.loads(path.read_text())
    assert doc["fileType"] == "Plan" and doc["version"] == 1
    assert doc["groundStation"] == "lamde-mission"
    ms = doc["mission"]
    assert ms["version"] == 2 and ms["firmwareType"] == 12 and ms["vehicleType"] == 2
    assert ms["cruiseSpeed"] == 18.0 and ms["hoverSpeed"] == 18.0
    home = ms["plannedHomePosition"]
    assert len(home) == 3 and home[2] == 584.0
    assert home == pytest.approx(list(home_of(m)), abs=1e-7)
    assert home[:2] == [grid_degrees(v) for v in home_of(m)[:2]]
    items = ms["items"]
    assert [it["doJumpId"] for it in items] == list(range(1, len(items) + 1))
    assert [it["command"] for it in items] == [22, 178, 19, 19, 19, 16, 21]
    for it in items:
        assert it["type"] == "SimpleItem" and it["autoContinue"] is True
        assert len(it["params"]) == 7
        assert it["AMSLAltAboveTerrain"] is None and it["AltitudeMode"] == 1
        assert it["Altitude"] == it["params"][6]
    assert items[0]["params"][3] is None  # NaN yaw written as null, like QGC
    assert items[2]["params"][0] == 40.0 and items[2]["frame"] == 3
    fence = doc["geoFence"]
    assert fence["version"] == 2
    assert len(fence["circles"]) == 1 and len(fence["polygons"]) == 2
    c = fence["circles"][0]
    assert c["inclusion"] is False and c["version"] == 1 and c["circle"]["radius"] == 80.0
    assert len(c["circle"]["center"]) == 2
    for p in fence["polygons"]:
        assert p["inclusion"] is False and p["version"] == 1 and len(p["polygon"]) == 4
    assert doc["rallyPoints"] == {"points": [], "version": 2}
    assert "NaN" not in path.read_text()


@pytest.mark.slow  # measured 1.5 s on a loaded machine (default suite <= 5 min)
def test_qgc_plan_round_trip(m, plan, tmp_path):
    path = write_mission(tmp_path / "m.plan", plan, m)
    items, fence = read_mission(path)
    assert items_equal(items, stored(plan, m))
    assert items_equal(fence, stored_items(geofence_items(m), "generic"))
    assert items_equal(fence, geofence_items(m), abs_=1e-7)  # the uninflated obstacles
    # RTL finish and no fence
    path = write_mission(tmp_path / "rtl.plan", plan, m, finish="rtl", fence=False)
    items, fence = read_mission(path)
    assert items_equal(items, stored(plan, m, finish="rtl")) and fence == []


def test_qgc_plan_reader_rejects_what_it_cannot_use(m, plan):
    doc = plan_document(plan_to_items(plan, m), home=(0, 0, 0), cruise_speed=5)
    doc["mission"]["items"][2] = {"type": "ComplexItem", "complexItemType": "survey"}
    with pytest.raises(MissionError, match="ComplexItem"):
        parse_plan_document(doc)
    with pytest.raises(MissionError, match="fileType"):
        parse_plan_document({"fileType": "Mission"})
    doc = plan_document(plan_to_items(plan, m), home=(0, 0, 0), cruise_speed=5)
    doc["mission"]["items"][0]["params"] = [0, 0, 0]
    with pytest.raises(MissionError, match="7 values"):
        parse_plan_document(doc)
    # a polygon without "inclusion" is an inclusion fence, as QGC reads it
    doc = plan_document(plan_to_items(plan, m), geofence_items(m), home=(0, 0, 0), cruise_speed=5)
    del doc["geoFence"]["polygons"][0]["inclusion"]
    _, fence = parse_plan_document(doc)
    assert fence[1].command == 5001


def test_waypoints_layout_and_round_trip(m, plan, tmp_path):
    path = write_mission(tmp_path / "m.waypoints", plan, m)
    lines = path.read_text().splitlines()
    assert lines[0] == "QGC WPL 110"
    home = lines[1].split("\t")
    assert len(home) == 12 and home[:4] == ["0", "1", "0", "16"] and float(home[10]) == 584.0
    assert all(len(ln.split("\t")) == 12 for ln in lines[1:])
    assert "nan" not in path.read_text().lower()
    expected = [it.without_nan() for it in stored(plan, m)]
    items, fence = read_mission(path)
    assert fence == [] and items_equal(items, expected)


def test_waypoints_load_in_pymavlink(m, plan, tmp_path):
    """A real client: MAVProxy's loader reads the file back to the same items."""
    path = write_mission(tmp_path / "m.waypoints", plan, m)
    expected = [it.without_nan() for it in stored(plan, m)]
    loader = mavwp.MAVWPLoader()
    assert loader.load(str(path)) == len(expected) + 1
    home = loader.wp(0)
    lat, lon, alt = home_of(m)
    lat, lon = grid_degrees(lat), grid_degrees(lon)
    assert (home.command, home.frame, home.x, home.y, home.z) == (16, 0, lat, lon, alt)
    for k, it in enumerate(expected):
        w = loader.wp(k + 1)
        assert w.seq == k + 1
        got = (w.command, w.frame, w.current, w.autocontinue,
               w.param1, w.param2, w.param3, w.param4, w.x, w.y, w.z)  # fmt: skip
        want = (it.command, it.frame, it.current, it.autocontinue, *it.params)
        assert got == want


def test_waypoints_reader_errors():
    with pytest.raises(MissionError, match="QGC WPL 110"):
        parse_waypoints("QGC WPL 100\n")
    with pytest.raises(MissionError, match="line 3: expected 12"):
        parse_waypoints("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n1\t0\t3\t16\n")
    with pytest.raises(MissionError, match="not a number"):
        parse_waypoints("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t1\t2\tx\t1\n")
    with pytest.raises(MissionError, match="no items"):
        parse_waypoints("QGC WPL 110\n\n# only a comment\n")
    text = format_waypoints([], (1.0, 2.0, 3.0))
    home, items = parse_waypoints(text)
    assert items == [] and (home.x, home.y, home.z) == (1.0, 2.0, 3.0)


def _ring_area(ring):
    a = np.asarray(ring)
    return 0.5 * float(np.sum(a[:-1, 0] * a[1:, 1] - a[1:, 0] * a[:-1, 1]))


def test_geojson(m, plan, tmp_path):
    path = write_mission(tmp_path / "m.geojson", plan, m)
    doc = json.loads(path.read_text())
    assert doc["type"] == "FeatureCollection"
    by_kind: dict[str, list] = {}
    for f in doc["features"]:
        assert f["type"] == "Feature"
        by_kind.setdefault(f["properties"]["kind"], []).append(f)
    assert {k: len(v) for k, v in by_kind.items()} == {
        "area": 1, "circle": 1, "rectangle": 1, "no_fly_zone": 1, "sensor": 3, "path": 1,
        "hover": 3, "start": 1, "end": 1,
    }  # fmt: skip
    for kind in ("area", "circle", "rectangle", "no_fly_zone"):
        ring = by_kind[kind][0]["geometry"]["coordinates"][0]
        assert ring[0] == ring[-1]  # closed
        assert _ring_area(ring) > 0  # counter-clockwise exterior
    lon0, lat0 = by_kind["start"][0]["geometry"]["coordinates"]
    assert abs(lon0 - 149.1652) < 0.01 and abs(lat0 + 35.3632) < 0.01  # [lon, lat] order
    circle = by_kind["circle"][0]["properties"]
    assert circle["radius"] == 80.0 and circle["centre_local"] == [2000.0, 300.0]
    path_coords = by_kind["path"][0]["geometry"]["coordinates"]
    assert by_kind["path"][0]["geometry"]["type"] == "LineString" and len(path_coords) == 5
    assert [f["properties"]["hover_time"] for f in by_kind["hover"]] == TIMES
    s2 = next(f["properties"] for f in by_kind["sensor"] if f["properties"]["id"] == "s2")
    assert s2["required"] == 300.0
    assert s2["collected"] == pytest.approx(plan.breakdown["collected"]["s2"])
    with pytest.raises(MissionFileError, match="GeoJSON"):
        read_mission(path)


def test_read_errors_name_the_file(tmp_path):
    with pytest.raises(MissionFileError, match="file not found"):
        read_mission(tmp_path / "missing.plan")
    bad = tmp_path / "bad.plan"
    bad.write_text("{ not json")
    with pytest.raises(MissionFileError, match="bad.plan: not valid JSON"):
        read_mission(bad)
    junk = tmp_path / "junk.waypoints"
    junk.write_text("hello\n")
    with pytest.raises(MissionFileError, match="not a mission file"):
        read_mission(junk)


def test_plan_result_json_is_accepted(m, plan, tmp_path):
    path = tmp_path / "result.json"
    path.write_text(json.dumps({"hover_points": HOVER, "hover_times": TIMES, "f": 1.0}))
    items, fence = load_mission_items(path, m)
    assert items_equal(items, plan_to_items(plan, m))
    assert items_equal(fence, geofence_items(m))
    path.write_text(json.dumps({"hover_points": [[1, 2, 3]], "hover_times": [1]}))
    with pytest.raises(MissionFileError, match="hover_points"):
        load_mission_items(path, m)


def test_writes_are_atomic_and_leave_no_temp_files(m, plan, tmp_path):
    for name in ("a.plan", "a.waypoints", "a.geojson"):
        write_mission(tmp_path / name, plan, m)
    with pytest.raises(MissionFileError):
        write_mission(tmp_path / "a.kml", plan, m)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.geojson", "a.plan", "a.waypoints"]
    # overwriting keeps a complete file
    write_mission(tmp_path / "a.plan", plan, m, finish="rtl")
    assert json.loads((tmp_path / "a.plan").read_text())["mission"]["items"][-1]["command"] == 20


def _plan_with_circle(m, plan):
    doc = plan_document(plan_to_items(plan, m), geofence_items(m), home=(0, 0, 0), cruise_speed=5)
    doc["geoFence"]["circles"] = [
        {"circle": {"center": [47.0, 8.0], "radius": 50.0}, "inclusion": False, "version": 1}]
    return doc


@pytest.mark.parametrize("bad", ["false", "true", 0, 1, None, [], {}])
@pytest.mark.parametrize(("section", "field"), [
    (("mission", "items", 2), "mission.items[2].autoContinue"),
    (("geoFence", "polygons", 0), "geoFence.polygons[0].inclusion"),
    (("geoFence", "circles", 0), "geoFence.circles[0].inclusion")])
def test_plan_booleans_must_be_json_booleans(m, plan, section, field, bad):
    """A string "false" was read as true; every true/false field now takes JSON booleans only."""
    doc = _plan_with_circle(m, plan)
    node = doc
    for key in section:
        node = node[key]
    node[field.rsplit(".", 1)[1]] = bad
    with pytest.raises(MissionError) as exc:
        parse_plan_document(doc)
    assert str(exc.value).startswith(f"{field}: expected true or false, got ")


def test_plan_booleans_are_read_as_written(m, plan):
    doc = _plan_with_circle(m, plan)
    doc["mission"]["items"][2]["autoContinue"] = False
    doc["geoFence"]["polygons"][0]["inclusion"] = True
    doc["geoFence"]["circles"][0]["inclusion"] = True
    items, fence = parse_plan_document(doc)
    assert items[2].autocontinue == 0 and items[1].autocontinue == 1
    assert fence[0].command == 5001 and fence[-1].command == 5003  # inclusion polygon, circle
    doc["geoFence"]["circles"][0]["inclusion"] = False
    del doc["mission"]["items"][2]["autoContinue"]  # absent: QGC's default, true
    items, fence = parse_plan_document(doc)
    assert items[2].autocontinue == 1 and fence[-1].command == 5004
    # the writer takes each shape's flag from its items (the module doc said always false)
    doc["geoFence"]["circles"][0]["inclusion"] = True
    _, fence = parse_plan_document(doc)
    again = plan_document(items, fence, home=(0, 0, 0), cruise_speed=5)["geoFence"]
    assert [c["inclusion"] for c in again["circles"]] == [True]
    assert [q["inclusion"] for q in again["polygons"]][0] is True


@pytest.mark.parametrize("bad", ["3", True, 2.5])
def test_plan_do_jump_id_must_be_an_integer(m, plan, bad):
    doc = plan_document(plan_to_items(plan, m), home=(0, 0, 0), cruise_speed=5)
    doc["mission"]["items"][1]["doJumpId"] = bad
    with pytest.raises(MissionError, match=r"^mission.items\[1\].doJumpId: expected an integer"):
        parse_plan_document(doc)


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_a_string_boolean_in_a_plan_exits_2_naming_the_field(m, plan, tmp_path):
    """`upload` (before any connection is made) and `verify` refuse it with one line naming
    the field, exit status 2."""
    from tests.conftest import run_cli_many

    doc = plan_document(plan_to_items(plan, m), home=(0, 0, 0), cruise_speed=5)
    doc["mission"]["items"][3]["autoContinue"] = "false"
    f = tmp_path / "s.plan"
    f.write_text(json.dumps(doc))
    map_path = tmp_path / "map.json"
    map_path.write_text(json.dumps(MAP))
    calls = (("upload", f, "--connect", "udpin://127.0.0.1:9", "--timeout", "0.1"),
             ("verify", map_path, f))  # fmt: skip
    for args, r in zip(calls, run_cli_many(*calls), strict=True):
        assert r.returncode == 2, (args, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1, r.stderr
        assert "mission.items[3].autoContinue: expected true or false, got 'false'" in lines[0]
