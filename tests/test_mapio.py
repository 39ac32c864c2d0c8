"""Map validation: every problem named on its own line; defaults; the CLI's exit status."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from planner_core import MapError, load_map, map_json_schema
from tests.conftest import run_cli


def _problems(data: dict) -> list[str]:
    with pytest.raises(MapError) as info:
        load_map(data)
    return info.value.problems


def test_defaults_in_force(hand_map: dict) -> None:
    del hand_map["uav"]
    m = load_map(hand_map)
    assert m.max_hover_points == 10
    assert m.spec.uav.altitude == 100 and m.spec.radio.required_data == 200
    np.testing.assert_array_equal(m.required_data, [200, 400])
    hand_map["area"] = {"width": 6000, "height": 1000}
    assert load_map(hand_map).max_hover_points == 20


def test_unknown_key_suggests_closest(hand_map: dict) -> None:
    hand_map["uav"]["max_sped"] = 10
    hand_map["sensor"] = []
    lines = _problems(hand_map)
    assert "uav.max_sped: unknown field (did you mean 'max_speed'?)" in lines
    assert "sensor: unknown field (did you mean 'sensors'?)" in lines


def test_missing_nan_nonpositive_empty(hand_map: dict) -> None:
    del hand_map["end"]
    hand_map["area"]["width"] = -5
    hand_map["start"] = [math.nan, 0]
    lines = _problems(hand_map)
    assert "end: required field is missing" in lines
    # a range error names the whole valid range, whichever end was broken
    assert "area.width: must be in (0, 100000] (got -5)" in lines
    assert any(line.startswith("start[0]:") and "finite" in line for line in lines)
    hand_map2 = {"area": {"width": 10, "height": 10}, "start": [0, 0], "end": [1, 1],
                 "sensors": []}
    assert _problems(hand_map2) == ["sensors: at least one sensor is required"]
    # a point of the wrong shape is said in the map's terms, not pydantic's ("a valid tuple")
    assert _problems({**hand_map2, "sensors": [{"id": "a", "x": 1, "y": 1}], "start": "abc"}) \
        == ['start: must be a JSON array of two numbers [x, y] (metres), got "abc" (a string)']
    assert _problems({**hand_map2, "sensors": [{"id": "a", "x": 1, "y": 1}],
                      "end": [1, 2, 3]}) == [
        "end: must be a JSON array of two numbers [x, y] (metres), got [1, 2, 3] (an array)"]
    # too short too: once, not pydantic's "start[1]: required field is missing" per item
    for short in ([1], []):
        assert _problems({**hand_map2, "sensors": [{"id": "a", "x": 1, "y": 1}],
                          "start": short}) == [
            f"start: must be a JSON array of two numbers [x, y] (metres), got {short} (an array)"]
    pads = {**hand_map2, "sensors": [{"id": "a", "x": 1, "y": 1}],
            "fleet": {"depots": [{"name": "d", "x": 5, "y": 5, "pads": [[6]]}]}}
    assert _problems(pads) == ["fleet.depots[0].pads[0]: must be a JSON array of two numbers "
                               "[x, y] (metres), got [6] (an array)"]


def test_a_bound_of_zero_is_not_explained_by_the_caps_reason(hand_map: dict) -> None:
    """A negative radius was told "no obstacle is larger than 1000 km" (the upper bound's
    reason); a lower bound above 0 keeps its own reason."""
    hand_map["obstacles"] = {"circles": [{"x": 500, "y": 500, "radius": -5}]}
    hand_map["area"]["width"] = 0
    hand_map["uav"]["max_speed"] = 0.01
    lines = _problems(hand_map)
    radius = next(line for line in lines if line.startswith("obstacles.circles[0].radius:"))
    assert radius.startswith("obstacles.circles[0].radius: must be in [0.01, 1000000] (got -5); "
                             "at least 1 cm: smaller")  # fmt: skip
    assert "area.width: must be in (0, 100000] (got 0)" in lines
    speed = next(line for line in lines if line.startswith("uav.max_speed:"))
    assert speed.startswith("uav.max_speed: must be in [0.1, 200] (got 0.01); below 0.1 m/s "
                            "flight times")
    # a value too low was also told "no rotary-wing UAV flies 200 m/s": each end its reason
    assert "200 m/s" not in speed and "must be in [0.1, 200]" in speed
    hand_map["uav"]["max_speed"] = 500
    (speed,) = [x for x in _problems(hand_map) if x.startswith("uav.max_speed:")]
    assert speed == ("uav.max_speed: must be in [0.1, 200] (got 500); above 200 m/s: no "
                     "rotary-wing UAV flies that fast")
    hand_map["obstacles"]["circles"][0]["radius"] = 2e6
    assert any("1000 km" in line for line in _problems(hand_map))


def test_bounds_print_in_plain_digits_and_a_zero_bound_keeps_its_own_reason(
        hand_map: dict) -> None:
    """Obstacle sizes printed "must be in [0.01, 1e+06] (got 2e+06)" where the others print
    plain numbers ("(0, 100000]"); they now read [0.01, 1000000] (got 2000000). And
    fleet.separation_m's reason below its open 0 ("0 m is a collision") never showed: a 0
    bound dropped every reason, meant for fields whose one reason is the cap's."""
    hand_map["obstacles"] = {"circles": [{"x": 500, "y": 500, "radius": 2e6}]}
    (radius,) = [x for x in _problems(hand_map) if x.startswith("obstacles.circles[0]")]
    assert radius.startswith("obstacles.circles[0].radius: must be in [0.01, 1000000] (got "
                             "2000000); ")
    del hand_map["obstacles"]
    for value in (0.0, -5.0):
        hand_map["fleet"] = {"separation_m": value}
        (line,) = [x for x in _problems(hand_map) if x.startswith("fleet.separation_m")]
        assert line == (f"fleet.separation_m: must be in (0, 1000] (got {value:g}); 0 m is a "
                        "collision")
    hand_map["fleet"] = {"separation_m": 1500.0}
    (line,) = [x for x in _problems(hand_map) if x.startswith("fleet.separation_m")]
    assert line.endswith("(got 1500); beyond a kilometre the vehicles of a map fly one after "
                         "the other")


def test_points_outside_area_and_inside_obstacles(hand_map: dict) -> None:
    hand_map["sensors"][0]["x"] = 5000
    hand_map["obstacles"] = {"circles": [{"x": 0, "y": 0, "radius": 50}]}
    lines = _problems(hand_map)
    assert any(line.startswith("sensors[0]:") and "outside the area" in line for line in lines)
    hand_map["sensors"][0]["x"] = 10
    lines = _problems(hand_map)
    assert lines == ["start: (0, 0) lies inside circle 0"]


def test_an_end_inside_an_obstacle_names_it_as_verify_does(hand_map: dict) -> None:
    """A reviewer's end point in the barn: "end: (700, 700) lies inside an obstacle or no-fly
    zone" said not which; now each shape holding it, named as `verify` names it (the sim's
    `Obstacle.label`), the same for a depot and a listed pad."""
    from sim.obstacles import obstacle_shapes

    barn = [[600, 600], [750, 600], [750, 750], [650, 750], [650, 800], [600, 800]]
    hand_map["area"] = {"width": 2000, "height": 1500}
    hand_map["end"] = [700, 700]
    hand_map["start"] = [1010, 500]
    hand_map["obstacles"] = {
        "circles": [{"x": 1000, "y": 500, "radius": 30}],
        "rectangles": [{"x": 1000, "y": 500, "length": 200, "width": 80, "angle_deg": 15}],
        "polygons": [{"name": "barn", "vertices": barn}],
        "no_fly_zones": [{"vertices": [[1200, 900], [1500, 900], [1500, 1100], [1200, 1100]]}],
    }
    assert _problems(hand_map) == ["start: (1010, 500) lies inside circle 0, rectangle 0",
                                   "end: (700, 700) lies inside polygon 0 'barn'"]
    hand_map["start"], hand_map["end"] = [50, 50], [50, 80]
    hand_map["fleet"] = {"depots": [{"name": "yard", "x": 50, "y": 50},
                                    {"name": "roof", "x": 1300, "y": 1000,
                                     "pads": [[700, 610]]}]}  # fmt: skip
    assert _problems(hand_map) == [
        "fleet.depots[1]: depot 'roof' at (1300, 1000) lies inside no-fly-zone 0: no sortie "
        "can take off or land there",
        "fleet.depots[1].pads[0]: the pad of depot 'roof' at (700, 610) lies inside polygon 0 "
        "'barn': no vehicle can stand there"]
    # one wording: the map's labels are the sim's (what `verify` prints), names and all
    del hand_map["fleet"]
    m = load_map(hand_map)
    assert m.obstacle_labels == tuple(o.label for o in obstacle_shapes(m)) == (
        "circle 0", "rectangle 0", "no-fly-zone 0", "polygon 0 'barn'")


def test_no_fly_zone_shapes(hand_map: dict) -> None:
    cw = [[100, 600], [300, 900], [400, 600]]
    hand_map["obstacles"] = {"no_fly_zones": [{"vertices": cw}]}
    m = load_map(hand_map)
    assert m.notes == ("obstacles.no_fly_zones[0].vertices: given clockwise; "
                       "reordered counter-clockwise",)
    np.testing.assert_array_equal(m.nfz_polygons[0], np.array(cw[::-1], dtype=float))
    bad = {
        "no_fly_zones": [
            {"vertices": [[100, 600], [300, 900]]},
            {"vertices": [[100, 100], [500, 100], [300, 200], [500, 500], [100, 500]]},
            {"vertices": [[0, 0], [400, 400], [400, 0], [0, 400]]},
        ]
    }
    hand_map["obstacles"] = bad
    lines = _problems(hand_map)
    assert "obstacles.no_fly_zones[0].vertices: needs at least 3 vertices, got 2" in lines
    # a non-convex zone is a valid shape now (issue 15); a bow-tie is not, and is named
    assert not any(line.startswith("obstacles.no_fly_zones[1]") for line in lines)
    assert "obstacles.no_fly_zones[2]: self-intersection at (200, 200)" in lines


def test_tiny_obstacles_and_collinear_zones_are_refused_naming_the_field(hand_map: dict) -> None:
    """A 1e-16 m radius passed check and made the sim's CLEAR margin NaN; a 1e-15 m rectangle
    was refused as 'obstacles: polygon 0: repeated consecutive vertex'; a zone of collinear
    vertices as a 'self-intersection'."""
    from planner_core.model.mapio import MIN_OBSTACLE_SIZE

    assert MIN_OBSTACLE_SIZE == 0.01
    hand_map["obstacles"] = {
        "circles": [{"x": 200, "y": 200, "radius": 1e-16}, {"x": 300, "y": 300, "radius": 0.01}],
        "rectangles": [{"x": 200, "y": 400, "length": 1e-15, "width": 5},
                       {"x": 300, "y": 400, "length": 5, "width": 0.009}],
        "no_fly_zones": [{"vertices": [[100, 100], [200, 200], [300, 300]]},
                         {"vertices": [[100, 500], [300, 500], [200, 500.001], [150, 500]]}],
        "polygons": [{"vertices": [[600, 100], [700, 100], [700, 200], [600, 200]],
                      "holes": [[[620, 120], [640, 140], [660, 160]]]}],
    }  # fmt: skip
    lines = _problems(hand_map)
    want = ["obstacles.circles[0].radius: must be in [0.01, 1000000] (got 1e-16)",
            "obstacles.rectangles[0].length: must be in [0.01, 1000000] (got 1e-15)",
            "obstacles.rectangles[1].width: must be in [0.01, 1000000] (got 0.009)"]
    for w in want:
        assert any(line.startswith(w) for line in lines), (w, lines)
    assert not any("circles[1]" in line or "polygon 0" in line for line in lines), lines
    hand_map["obstacles"] = {k: v for k, v in hand_map["obstacles"].items()
                             if k in ("no_fly_zones", "polygons")}  # fmt: skip
    lines = _problems(hand_map)
    assert "obstacles.no_fly_zones[0]: has zero area (collinear vertices)" in lines, lines
    assert "obstacles.no_fly_zones[1]: has zero area (collinear vertices)" in lines, lines
    assert "obstacles.polygons[0].holes[0]: has zero area (collinear vertices)" in lines, lines
    assert not any("self-intersection" in line for line in lines), lines


def test_schema_has_fields() -> None:
    s = map_json_schema()
    assert s["$schema"] == "https://json-schema.org/draft/2020-12/schema"  # as `schema` says
    assert set(s["required"]) == {"area", "start", "end", "sensors"}
    assert "no_fly_zones" in json.dumps(s)


def test_to_dict_round_trip(hand_map: dict) -> None:
    m = load_map(hand_map)
    assert load_map(m.to_dict()).to_dict() == m.to_dict()


@pytest.mark.slow  # measured 13 s (issue 35: default suite <= 5 min)
def test_cli_check_and_schema(tmp_path, hand_map: dict) -> None:
    good = tmp_path / "good.json"
    good.write_text(json.dumps(hand_map))
    r = run_cli("check", str(good))
    assert r.returncode == 0, r.stderr
    assert "I_max           2" in r.stdout
    hand_map["radio"]["bandwith"] = 3
    hand_map["area"]["height"] = 0
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(hand_map))
    r = run_cli("check", str(bad))
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 2
    assert any("radio.bandwith: unknown field (did you mean 'bandwidth'?)" in x for x in lines)
    r = run_cli("check", str(tmp_path / "missing.json"))
    assert r.returncode == 2 and "file not found" in r.stderr
    r = run_cli("schema")
    assert r.returncode == 0 and json.loads(r.stdout)["title"] == "MapFile"


def test_a_null_i_max_keeps_the_papers_values_and_grows_with_the_sensors() -> None:
    """uav.max_hover_points null: 10 on 5 km and 20 on 10 km for the paper's sensor counts
    (<= 20 and <= 40), ceil(J / 2) beyond them, at most 200 (issue 31)."""
    from planner_core.model.mapio import MAX_HOVER_POINTS, default_max_hover_points

    assert default_max_hover_points(5000, 5000, 20) == 10
    assert default_max_hover_points(10000, 10000, 40) == 20
    assert default_max_hover_points(10000, 10000, 41) == 21
    assert default_max_hover_points(20000, 20000, 160) == 80
    assert default_max_hover_points(30000, 30000, 1000) == MAX_HOVER_POINTS == 200
    assert default_max_hover_points(30000, 30000, 3) == 20


def test_a_file_of_another_kind_given_as_a_map_is_named_as_such(tmp_path) -> None:
    """A QGroundControl mission, GeoJSON, a fleet.json, a saved plan or a suite's best-known
    file given as the map: one
    line saying what it is (it listed `version: unknown field` and others one by one)."""
    from tests.conftest import ROOT

    cases = {
        "mission.plan": ({"fileType": "Plan", "version": 1, "mission": {}}, "QGroundControl"),
        "f.geojson": ({"type": "FeatureCollection", "features": []}, "this is GeoJSON"),
        "fleet.json": ({"map": "m", "vehicles": []}, "fleet.json, not a map"),
        "saved.json": ({"hover_points": [], "hover_times": [], "f": 1.0}, "a saved plan"),
        # examples/maps holds the suites' best-known files beside the maps: a reviewer's
        # `check` on one listed seven fields one by one
        "suite_best_known.json": (json.loads((ROOT / "examples" / "maps" /
                                              "suite_best_known.json").read_text()),
                                  "a benchmark suite's best-known or lower-bounds file"),
    }
    for name, (doc, needle) in cases.items():
        path = tmp_path / name
        path.write_text(json.dumps(doc))
        with pytest.raises(MapError) as info:
            load_map(path)
        assert len(info.value.problems) == 1 and needle in info.value.problems[0], name
    load_map(ROOT / "examples" / "maps" / "small-demo.json")  # a map is still a map


def _degrees_map(origin: bool = True) -> dict:
    """A reviewer's map with its positions typed as longitude, latitude (the origin's) in a
    2000 m x 1500 m area: check said OK and plan flew a one-point mission."""
    doc = {
        "name": "deg", "area": {"width": 2000, "height": 1500},
        "start": [5.1201, 52.0101], "end": [5.1201, 52.0101],
        "sensors": [{"id": "a", "x": 5.1230, "y": 52.0130}, {"id": "b", "x": 5.1290, "y": 52.0150},
                    {"id": "c", "x": 5.1250, "y": 52.0110}],
    }  # fmt: skip
    if origin:
        doc["origin"] = {"lat": 52.0100, "lon": 5.1200}
    return doc


def _degree_notes(m: object) -> list[str]:
    return [n for n in m.notes if "look like longitude, latitude" in n]


def test_positions_typed_in_degrees_get_a_note_naming_the_field_and_the_fix(
    tmp_path, capsys
) -> None:
    from lamde_mission.cli import main

    assert _degree_notes(load_map(_degrees_map())) == [
        "sensors: their x, y look like longitude, latitude (sensor 'a' at (5.123, 52.013) is "
        "next to the origin's lon, lat (5.12, 52.01); the sensors, start and end all lie within "
        "0.0089 m of one another in a 2000 m x 1500 m area): x, y are metres east and north of "
        "the origin"]
    # without an origin the points' spread alone says it
    (note,) = _degree_notes(load_map(_degrees_map(origin=False)))
    assert "(sensor 'a' at (5.123, 52.013); the sensors, start and end" in note
    # a note, not an error: check still exits 0 and says it (on stderr, as every map note), and
    # plan, which prints the map's notes, says it too
    path = tmp_path / "deg.json"
    path.write_text(json.dumps(_degrees_map()))
    assert main(["check", str(path)]) == 0
    err = capsys.readouterr().err
    assert f"note: {path}: sensors: their x, y look like longitude, latitude" in err
    from lamde_mission.commands._common import load_map_or_fail

    load_map_or_fail(str(path))  # what plan loads its map with
    assert "look like longitude, latitude" in capsys.readouterr().err


@pytest.mark.parametrize("change", ["metres", "spread", "one-point", "beyond-90"])
def test_maps_in_metres_near_5_52_get_no_degrees_note(change: str) -> None:
    doc = _degrees_map()
    if change == "metres":  # the same map in metres east and north of the origin
        doc["start"] = doc["end"] = [7, 11]
        for s, (x, y) in zip(doc["sensors"], [(205, 333), (615, 556), (342, 111)], strict=True):
            s["x"], s["y"] = x, y
    elif change == "spread":  # a real map may hold a point at (5, 52) m, the others elsewhere
        doc["end"] = [1900, 1400]
    elif change == "one-point":  # everything at one spot: no spread to judge by
        doc["start"] = doc["end"] = [5.123, 52.013]
        doc["sensors"] = [{"id": "a", "x": 5.123, "y": 52.013}]
    else:  # close together, but y beyond any latitude (100 m north)
        doc["start"] = doc["end"] = [5.1201, 100.0101]
        for s in doc["sensors"]:
            s["y"] += 48
    assert _degree_notes(load_map(doc)) == []


def test_no_committed_example_or_suite_map_gets_the_degrees_note() -> None:
    from tests.conftest import MAPS

    maps = [p for p in sorted(MAPS.rglob("*.json")) if "sensors" in json.loads(p.read_text())]
    assert len(maps) >= 20  # the demos, the suite T01-T16 and the large L01-L08
    for path in maps:
        assert _degree_notes(load_map(path)) == [], path
