"""No silent coercion (issue 32, item 5): map numbers are JSON numbers, a JSON key is given
once, `map from-geojson` reads a `.plan` under `verify`'s rules, a witness lies in the area and
the start and end keep clear of obstacles by more than a mission file's grid moves them.

(`.waypoints` numbers in ASCII only: tests/test_hostile.py::test_waypoints_fields_named_by_line.)
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from lamde_mission.fuzz import run_cli
from planner_core.defaults import MAP_DEFAULTS
from planner_core.model.mapio import END_GAP, MapError, load_map
from planner_core.textio import InputError, loads_json, read_json

DATA = Path(__file__).resolve().parent / "data" / "hostile"
TINY = DATA / "tiny-map.json"


def full_map() -> dict[str, Any]:
    """The tiny map with every kind of number present: each optional section at its default,
    a sensor's required_data, a rectangle's angle, a no-fly zone with a hole, a polygon
    obstacle, a witness, a battery (its energy_wh: the battery is given once, so
    uav.endurance_s is left out) and a depot."""
    d = json.loads(TINY.read_text())
    for name, default in MAP_DEFAULTS.items():
        *sections, key = name.split(".")
        value = {"max_hover_points": 10, "energy_wh": 100.0}.get(key, default.value)
        if value is None:  # uav.endurance_s (tests/test_energy.py refuses its strings)
            continue
        node = d
        for section in sections:
            node = node.setdefault(section, {})
        node[key] = value
    d["fleet"]["depots"] = [{"name": "pad", "x": 100.0, "y": 60.0}]
    d["sensors"][0]["required_data"] = 150.0
    d["obstacles"]["no_fly_zones"] = [{"vertices": [[900, 100], [1100, 100], [1100, 300],
                                                    [900, 300]],
                                       "holes": [[[950, 150], [1050, 150], [1050, 250],
                                                  [950, 250]]]}]  # fmt: skip
    d["obstacles"]["polygons"] = [{"vertices": [[100, 1000], [200, 1000], [150, 1100]]}]
    d["witness"] = {"hover_points": [[500.0, 500.0]], "hover_times": [10.0]}
    return d


def number_paths(node: Any, path: tuple = ()) -> list[tuple]:
    """Every path to a number in a JSON tree."""
    if isinstance(node, dict):
        return [p for k, v in node.items() for p in number_paths(v, (*path, k))]
    if isinstance(node, list):
        return [p for i, v in enumerate(node) for p in number_paths(v, (*path, i))]
    return [path] if isinstance(node, int | float) and not isinstance(node, bool) else []


def shown(path: tuple) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out


def set_at(d: dict, path: tuple, value: Any) -> dict:
    node = d
    for part in path[:-1]:
        node = node[part]
    node[path[-1]] = value
    return d


PATHS = number_paths(full_map())


def test_the_full_map_loads_and_covers_every_kind_of_number() -> None:
    load_map(full_map())
    names = {shown(p) for p in PATHS}
    assert {"area.width", "origin.lat", "start[0]", "sensors[0].required_data",
            "obstacles.rectangles[0].angle_deg", "obstacles.no_fly_zones[0].holes[0][0][1]",
            "witness.hover_times[0]", "uav.max_hover_points"} <= names  # fmt: skip
    assert {f"{n}" for n in MAP_DEFAULTS} - {"uav.endurance_s"} <= names
    assert {"fleet.depots[0].x", "fleet.depots[0].y"} <= names
    assert len(PATHS) > 60


@pytest.mark.parametrize("path", PATHS, ids=shown)
def test_every_map_number_refuses_a_string_and_a_boolean(path: tuple) -> None:
    for bad, kind in ((str(_value(path)), "a string"), (True, "a boolean")):
        with pytest.raises(MapError) as info:
            load_map(set_at(full_map(), path, bad))
        first = info.value.problems[0]
        assert first.startswith(f"{shown(path)}: must be a JSON "), first
        assert kind in first, first
        assert len(info.value.problems) == 1, info.value.problems  # the field alone is blamed


def object_paths(node: Any, path: tuple = ()) -> list[tuple]:
    """Every path to a JSON object below the top level (a section, an item of a list)."""
    here = [path] if isinstance(node, dict) and path else []
    if isinstance(node, dict):
        return here + [p for k, v in node.items() for p in object_paths(v, (*path, k))]
    if isinstance(node, list):
        return [p for i, v in enumerate(node) for p in object_paths(v, (*path, i))]
    return here


def test_every_map_object_refuses_another_type_in_json_words() -> None:
    """A section or item that must be an object (`obstacles`, `uav.battery`, `sensors[0]`,
    `fleet.depots[0]`, ...) given as an array, a number or a string reads as every type error
    does, "must be a JSON object, got [] (an array)": it named pydantic's class ("Input should
    be a valid dictionary or instance of ObstaclesSpec")."""
    paths = object_paths(full_map())
    assert {"obstacles", "uav.battery", "sensors[0]", "fleet.depots[0]", "witness",
            "obstacles.no_fly_zones[0]"} <= {shown(p) for p in paths}  # fmt: skip
    for path in paths:
        for bad, got in (([], "[] (an array)"), (5, "5 (an integer)"), ("x", '"x" (a string)')):
            with pytest.raises(MapError) as info:
                load_map(set_at(full_map(), path, bad))
            assert info.value.problems == [f"{shown(path)}: must be a JSON object, got {got}"]


@pytest.mark.parametrize(("path", "choices"), [(("radio", "access"), "'simultaneous' or "
                                                 "'scheduled'"),
                                                (("objective", "goal"), "'total' or 'makespan'")])
def test_a_choice_field_says_must_be_and_what_it_got(path: tuple, choices: str) -> None:
    """A field of named choices reads as the others ("must be ..., got ..."), not pydantic's
    "Input should be ..."."""
    with pytest.raises(MapError) as info:
        load_map(set_at(full_map(), path, "other"))
    assert info.value.problems == [f"{shown(path)}: must be {choices}, got \"other\" (a string)"]


def _value(path: tuple) -> Any:
    node: Any = full_map()
    for part in path:
        node = node[part]
    return node


def test_check_names_area_width_for_true_and_a_string(tmp_path: Path) -> None:
    for bad, got in ((True, "got true (a boolean)"), ("2000", 'got "2000" (a string)')):
        p = tmp_path / "m.json"
        p.write_text(json.dumps(set_at(json.loads(TINY.read_text()), ("area", "width"), bad)))
        for argv in (["check", str(p)], ["plan", str(p), "-o", str(tmp_path / "o.plan")]):
            out = run_cli(argv)
            assert out.status == 2 and out.stderr.count("\n") == 1, out.stderr
            assert f"area.width: must be a JSON number, {got}" in out.stderr
        assert not (tmp_path / "o.plan").exists()


def test_an_integer_field_refuses_a_fraction() -> None:
    with pytest.raises(MapError, match=r"uav.max_hover_points: must be a JSON integer"):
        load_map(set_at(full_map(), ("uav", "max_hover_points"), 10.5))


# ------------------------------------------------------------------------- duplicate keys


def test_duplicate_keys_are_refused_naming_the_key() -> None:
    with pytest.raises(InputError, match=r"^area\.width: this key appears more than once"):
        loads_json('{"area": {"width": 1200, "height": 5, "width": 99}}')
    with pytest.raises(InputError, match=r"^sensors\[1\]\.id: this key appears"):
        loads_json('{"sensors": [{"id": "a"}, {"id": "b", "id": "c"}]}')
    with pytest.raises(InputError, match=r"^x: this key appears"):
        loads_json('{"x": 1, "x": 1}')
    assert loads_json('{"a": {"x": 1}, "b": {"x": 2}}') == {"a": {"x": 1}, "b": {"x": 2}}


def test_duplicate_keys_in_map_and_mission_files_exit_2(tmp_path: Path) -> None:
    text = TINY.read_text().replace('"width": 1200', '"width": 1200, "width": 99', 1)
    m = tmp_path / "m.json"
    m.write_text(text)
    out = run_cli(["check", str(m)])
    assert out.status == 2 and "area.width: this key appears more than once" in out.stderr
    plan = (DATA / "hover-1e39.plan").read_text().replace('"fileType"', '"version": 1, '
                                                           '"fileType"', 1)  # fmt: skip
    p = tmp_path / "dup.plan"
    p.write_text(plan)
    out = run_cli(["verify", str(TINY), str(p)])
    assert out.status == 2 and "version: this key appears more than once" in out.stderr
    with pytest.raises(InputError):
        read_json(p)


# -------------------------------------------------------------- map from-geojson of a .plan


def _fence_plan(**changes: Any) -> dict:
    lat, lon = 46.2, 7.3
    doc = {
        "fileType": "Plan", "version": 1,
        "mission": {"items": [], "plannedHomePosition": [lat + 0.001, lon + 0.001, 400.0],
                    "version": 2},
        "geoFence": {"version": 2, "polygons": [
            {"inclusion": False, "version": 1,
             "polygon": [[lat + 0.004, lon + 0.004], [lat + 0.004, lon + 0.005],
                         [lat + 0.005, lon + 0.005]]}],
            "circles": []},
        "rallyPoints": {"points": [], "version": 2},
    }  # fmt: skip
    for path, value in changes.items():
        set_at(doc, tuple(int(p) if p.isdigit() else p for p in path.split("__")), value)
    return doc


@pytest.mark.parametrize(
    ("change", "needle"),
    [({"version": 42}, "version: version 42 is not supported"),
     ({"mission__version": 3}, "mission.version: version 3 is not supported"),
     ({"geoFence__version": "2"}, "geoFence.version: version '2' is not supported"),
     ({"geoFence__polygons__0__inclusion": "false"},
      "geoFence.polygons[0].inclusion: expected true or false, got 'false'")],
)  # fmt: skip
def test_from_geojson_reads_a_plan_as_verify_does(tmp_path: Path, change, needle) -> None:
    p = tmp_path / "fence.plan"
    p.write_text(json.dumps(_fence_plan(**change)))
    out_map = tmp_path / "out.json"
    out = run_cli(["map", "from-geojson", str(p), "--sensors", str(_sensor(tmp_path)),
                   "-o", str(out_map)])  # fmt: skip
    assert out.status == 2 and needle in out.stderr, out.stderr
    assert not out_map.exists()
    ok = tmp_path / "ok.plan"
    ok.write_text(json.dumps(_fence_plan()))
    out = run_cli(["map", "from-geojson", str(ok), "--sensors", str(_sensor(tmp_path)),
                   "-o", str(out_map)])  # fmt: skip
    assert out.status == 0, out.stderr


def _sensor(tmp_path: Path) -> Path:
    s = tmp_path / "s.geojson"
    s.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "a"},
         "geometry": {"type": "Point", "coordinates": [7.302, 46.202]}}]}))  # fmt: skip
    return s


def test_from_geojson_keeps_a_buildings_upper_case_name(tmp_path: Path) -> None:
    lon, lat = 7.3, 46.2
    ring = [[lon + 0.002, lat + 0.002], [lon + 0.003, lat + 0.002], [lon + 0.003, lat + 0.003],
            [lon + 0.002, lat + 0.002]]
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"kind": "building", "NAME": "Town Hall"},
         "geometry": {"type": "Polygon", "coordinates": [ring]}},
        {"type": "Feature", "properties": {"kind": "sensor", "id": "a"},
         "geometry": {"type": "Point", "coordinates": [lon + 0.001, lat + 0.004]}},
        {"type": "Feature", "properties": {"kind": "start"},
         "geometry": {"type": "Point", "coordinates": [lon, lat]}},
        {"type": "Feature", "properties": {"kind": "end"},
         "geometry": {"type": "Point", "coordinates": [lon + 0.004, lat]}}]}  # fmt: skip
    src = tmp_path / "b.geojson"
    src.write_text(json.dumps(fc))
    out_map = tmp_path / "out.json"
    out = run_cli(["map", "from-geojson", str(src), "-o", str(out_map)])
    assert out.status == 0, out.stderr
    polys = json.loads(out_map.read_text())["obstacles"]["polygons"]
    assert [p.get("name") for p in polys] == ["Town Hall"]


def test_from_geojson_area_frame_numbers_are_strict(tmp_path: Path) -> None:
    ring = [[7.3, 46.2], [7.31, 46.2], [7.31, 46.21], [7.3, 46.2]]
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"kind": "area", "origin": [46.2, 7.3],
                                           "width_m": "500", "height_m": 500},
         "geometry": {"type": "Polygon", "coordinates": [ring]}}]}  # fmt: skip
    src = tmp_path / "a.geojson"
    src.write_text(json.dumps(fc))
    out = run_cli(["map", "from-geojson", str(src), "-o", str(tmp_path / "o.json")])
    assert out.status == 2 and "width_m: must be a finite JSON number, got '500'" in out.stderr


# ----------------------------------------------------------------- witness, start and end


def test_a_witness_outside_the_area_is_refused(tmp_path: Path) -> None:
    d = json.loads(TINY.read_text())
    d["witness"] = {"hover_points": [[300.0, 900.0], [-5531.0, 10.0]], "hover_times": [1, 2]}
    p = tmp_path / "w.json"
    p.write_text(json.dumps(d))
    out = run_cli(["check", str(p)])
    assert out.status == 2, out.stdout
    assert "witness.hover_points[1]: (-5531, 10) is outside the area" in out.stderr
    assert "known feasible plan" not in out.stdout
    d["witness"]["hover_points"][1] = [1200.0, 1200.0]  # on the area's corner: inside
    p.write_text(json.dumps(d))
    assert run_cli(["check", str(p)]).status == 0


#: the west point of the tiny map's circle (centre (600, 600), radius 70) and the outward normal
_WEST = (530.0, 600.0, (-1.0, 0.0))


@pytest.mark.parametrize("where", ["start", "end"])
@pytest.mark.parametrize(
    ("gap", "ok"),
    [(0.0, False), (END_GAP / 2, False), (END_GAP * 0.99, False), (END_GAP * 1.01, True),
     (1.0, True)],
)  # fmt: skip
def test_the_start_and_end_keep_clear_of_an_obstacles_edge(where, gap, ok, tmp_path) -> None:
    x, y, (nx, ny) = _WEST
    d = json.loads(TINY.read_text())
    d[where] = [x + nx * gap, y + ny * gap]
    if ok:
        load_map(d)
        return
    with pytest.raises(MapError) as info:
        load_map(d)
    line = info.value.problems[0]
    # the obstacle named, as "lies inside circle 0" names it (a reviewer)
    assert line.startswith(f"{where}: (") and "from the edge of circle 0, closer than 1 cm" in line
    p = tmp_path / "e.json"
    p.write_text(json.dumps(d))
    out = run_cli(["check", str(p)])
    assert out.status == 2 and out.stderr.count("\n") == 1


def test_a_start_on_a_polygon_edge_is_refused() -> None:
    d = json.loads(TINY.read_text())
    d["obstacles"]["no_fly_zones"] = [{"vertices": [[100, 100], [200, 100], [200, 200],
                                                    [100, 200]]}]  # fmt: skip
    d["start"] = [150.0, 100.0]
    with pytest.raises(MapError,
                       match=r"start: \(150, 100\) lies 0 mm from the edge of no-fly-zone 0"):
        load_map(d)
    d["start"] = [150.0, 99.98]
    load_map(d)


def test_the_planning_map_may_touch_the_start() -> None:
    """Inflation stops at the start (a clearance reduced there): the planning map keeps it on
    the inflated edge, and loads."""
    d = {"name": "near", "origin": {"lat": 46.2, "lon": 7.3},
         "area": {"width": 1000, "height": 1000}, "start": [100, 100], "end": [900, 900],
         "sensors": [{"id": "a", "x": 500, "y": 500}],
         "obstacles": {"circles": [{"x": 100, "y": 106, "radius": 4}]},
         "safety": {"clearance": 10}}  # fmt: skip
    assert load_map(d).planning_map().spec.obstacles.circles[0].radius == pytest.approx(6.0)
