"""Real maps in and out (issue 15): GeoJSON / QGroundControl import, GeoJSON export, the campus.

The campus case (`../shared/cases/gis/campus.geojson`, copied to tests/data/) has two L-shaped
halls with a corridor, a block with a courtyard, an annex with a collinear and a 2 mm duplicate
vertex, a clockwise no-fly zone, three sensors (one in the corridor, one in the courtyard).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from lamde_mission.gis import GisError, build_map, map_to_geojson, read_layers
from planner_core.model.geometry import overlap_lengths
from planner_core.model.mapio import load_map
from sim.geo import enu_to_latlon, latlon_to_enu
from tests.conftest import ROOT

CAMPUS = ROOT / "tests" / "data" / "campus.geojson"


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "lamde_mission.cli", *args],
                          capture_output=True, text=True, timeout=300)  # fmt: skip


@pytest.fixture(scope="module")
def campus(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    out = tmp_path_factory.mktemp("campus") / "campus.json"
    r = _cli("map", "from-geojson", str(CAMPUS), "-o", str(out))
    return out, r


def test_the_manuals_campus_is_the_one_tested() -> None:
    # docs/maps.md imports examples/gis/campus.geojson, and tests/test_readme.py's COVERED_BY
    # names the `campus` fixture above (tests/data/campus.geojson) as what exercises it
    assert (ROOT / "examples" / "gis" / "campus.geojson").read_bytes() == CAMPUS.read_bytes()


def _by_name(m) -> dict:
    return {sh.name: sh for sh in m.shapes}


@pytest.mark.slow  # measured 7 s (issue 35: default suite <= 5 min)
def test_campus_imports_exactly(campus) -> None:
    path, r = campus
    assert r.returncode == 0, r.stderr
    m = load_map(path)
    assert not m.notes  # written clean: loading it again changes nothing
    assert m.sensor_ids == ("gw-1", "gw-2", "gw-3")
    np.testing.assert_array_equal(m.required_data, [150.0, 200.0, 200.0])
    shapes = _by_name(m)
    assert set(shapes) == {"hall-west", "hall-east", "court", "annex", "restricted"}
    assert len(shapes["hall-west"].shell) == 6 and len(shapes["hall-east"].shell) == 6  # L-shapes
    assert len(shapes["court"].holes) == 1 and len(shapes["court"].holes[0]) == 4  # the courtyard
    assert len(shapes["annex"].shell) == 4  # cleaned: collinear and 2 mm duplicate vertex gone
    assert shapes["restricted"].kind == "no_fly_zone"
    assert Polygon(shapes["restricted"].shell).exterior.is_ccw  # given clockwise, reordered
    # the origin is the data's south-west corner grown by the 100 m margin (documented)
    assert "south-west corner of the data's bounds grown by 100 m" in r.stderr
    assert "'annex': merged 1 near-duplicate vertex and removed 1 vertex in the middle " \
        "of an edge (tolerance 5 mm)" in r.stderr
    xy = np.vstack([m.sensors, m.start, m.end] + [sh.shell for sh in m.shapes])
    assert xy.min() == pytest.approx(100.0, abs=0.05)
    assert m.width - xy[:, 0].max() == pytest.approx(100.0, abs=0.05)
    assert m.height - xy[:, 1].max() == pytest.approx(100.0, abs=0.05)
    # the corridor between the halls stays open: a sensor in it is outside every footprint
    from planner_core.model.geometry import points_inside
    assert not points_inside(m.sensors, m.obstacles).any()


def test_campus_overlap_equals_shapely(campus) -> None:
    path, _ = campus
    m = load_map(path)
    rng = np.random.default_rng(7)
    for name in ("hall-west", "hall-east", "court"):
        sh = _by_name(m)[name]
        poly = Polygon(sh.shell, sh.holes)
        obs = type(m.obstacles).build([], [], [(sh.shell, sh.holes)])
        lo, hi = sh.shell.min(axis=0) - 50, sh.shell.max(axis=0) + 50
        a = lo + rng.random((200, 2)) * (hi - lo)
        b = lo + rng.random((200, 2)) * (hi - lo)
        got = overlap_lengths(a, b, obs)
        want = [LineString([p, q]).intersection(poly).length for p, q in zip(a, b, strict=True)]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)
    # a leg straight across the courtyard block is charged for the walls, not the courtyard
    sh = _by_name(m)["court"]
    (x0, y0), (x1, y1) = sh.shell.min(axis=0), sh.shell.max(axis=0)
    y = 0.5 * (y0 + y1)
    leg = np.array([[x0 - 10, y], [x1 + 10, y]])
    inside = float(overlap_lengths(leg[0], leg[1], m.obstacles))
    hole = sh.holes[0]
    walls = (x1 - x0) - (hole[:, 0].max() - hole[:, 0].min())
    assert inside == pytest.approx(walls, abs=0.01)  # walls a few mm off the grid lines
    assert inside == pytest.approx(LineString(leg).intersection(Polygon(sh.shell, sh.holes)).length,
                                   abs=1e-6)  # fmt: skip


@pytest.mark.slow
def test_campus_plans_and_serves_every_sensor(campus) -> None:
    from lamde_mission.api import plan

    path, _ = campus
    m = load_map(path)
    result = plan(m, seed=0, budget=3000)
    assert result.feasible
    collected = result.breakdown["collected"]
    for sid, q in zip(m.sensor_ids, m.required_data, strict=True):
        assert collected[sid] >= q * (1 - 1e-9)
    nodes = np.vstack([m.start, np.asarray(result.hover_points).reshape(-1, 2), m.end])
    assert float(overlap_lengths(nodes[:-1], nodes[1:], m.obstacles).sum()) == 0.0


@pytest.mark.slow  # measured 16 s (issue 35: default suite <= 5 min)
def test_campus_plan_cli_verifies(campus, tmp_path) -> None:
    path, _ = campus
    out = tmp_path / "campus.plan"
    r = _cli("plan", str(path), "-o", str(out), "--budget", "2000", "--quiet")
    assert r.returncode == 0, r.stderr
    r = _cli("verify", str(path), str(out))
    assert r.returncode == 0, r.stdout + r.stderr
    assert "C5 L_vio = 0               PASS" in r.stdout


def _metres(lonlat_a, lonlat_b, origin) -> float:
    a = np.asarray(lonlat_a, dtype=float).reshape(-1, 2)
    b = np.asarray(lonlat_b, dtype=float).reshape(-1, 2)
    xa, ya = latlon_to_enu(a[:, 1], a[:, 0], origin)
    xb, yb = latlon_to_enu(b[:, 1], b[:, 0], origin)
    return np.hypot(xa[:, None] - xb[None, :], ya[:, None] - yb[None, :])


@pytest.mark.slow  # measured 10 s (issue 35: default suite <= 5 min)
def test_round_trip_keeps_every_vertex_within_a_centimetre(campus, tmp_path) -> None:
    path, _ = campus
    m = load_map(path)
    out = tmp_path / "campus.geojson"
    r = _cli("map", "to-geojson", str(path), "-o", str(out))
    assert r.returncode == 0, r.stderr
    back = json.loads(out.read_text())
    src = json.loads(CAMPUS.read_text())
    origin = (m.spec.origin.lat, m.spec.origin.lon, 0.0)
    def key(f):
        p = f["properties"]
        return p["kind"] if p["kind"] in ("start", "end") else p.get("name", p.get("id"))

    named = {key(f): f for f in back["features"] if f["properties"]["kind"] != "area"}
    for f in src["features"]:
        name = f["properties"]["name"]
        g = named[key(f) if f["properties"]["kind"] in ("start", "end") else name]
        if f["geometry"]["type"] == "Point":
            d = _metres(f["geometry"]["coordinates"], g["geometry"]["coordinates"], origin)
            assert d.max() < 0.01, name
            continue
        for ring_in, ring_out in zip(f["geometry"]["coordinates"], g["geometry"]["coordinates"],
                                     strict=True):  # fmt: skip
            d = _metres(ring_in, ring_out, origin)
            assert d.min(axis=0).max() < 0.01, name  # every output vertex is an input vertex
            if name != "annex":  # the annex lost its collinear and duplicate vertex (noted)
                assert d.min(axis=1).max() < 0.01, name  # and every input vertex survives
            else:
                far = d.min(axis=1) >= 0.01
                assert far.sum() == 1  # the vertex in the middle of an edge, within 5 mm of it
                ring_xy = np.column_stack(latlon_to_enu(np.array(ring_out)[:, 1],
                                                        np.array(ring_out)[:, 0], origin))
                p = np.column_stack(latlon_to_enu(np.array(ring_in)[far, 1],
                                                  np.array(ring_in)[far, 0], origin))
                assert LineString(ring_xy).distance(
                    LineString([p[0], p[0] + 1e-9])) < 0.005
    # and GeoJSON -> map again: the same map, to the centimetre (the frame comes from the area)
    out2 = tmp_path / "again.json"
    r = _cli("map", "from-geojson", str(out), "-o", str(out2))
    assert r.returncode == 0, r.stderr
    m2 = load_map(out2)
    assert (m2.width, m2.height) == (m.width, m.height)
    assert m2.spec.origin == m.spec.origin
    for a, b in zip(m.shapes, m2.shapes, strict=True):
        np.testing.assert_allclose(a.shell, b.shell, atol=0.01)
    np.testing.assert_allclose(m2.sensors, m.sensors, atol=0.01)


def _fc(*features) -> dict:
    return {"type": "FeatureCollection", "features": list(features)}


def _feat(kind, geom_type, coords, **props) -> dict:
    p = dict(props)
    if kind is not None:
        p["kind"] = kind
    return {"type": "Feature", "properties": p,
            "geometry": {"type": geom_type, "coordinates": coords}}  # fmt: skip


LON, LAT = 7.32, 46.21
D = 0.001  # ~ 77 m east, 111 m north


def _pt(i, j) -> list[float]:
    return [LON + i * D, LAT + j * D]


def _basics() -> list[dict]:
    return [_feat("sensor", "Point", _pt(1, 1), id="s1"), _feat("start", "Point", _pt(0, 0)),
            _feat("end", "Point", _pt(5, 5))]  # fmt: skip


def _write(tmp_path, name, doc) -> Path:
    p = tmp_path / name
    p.write_text(json.dumps(doc))
    return p


@pytest.mark.slow  # measured 7 s (issue 35: default suite <= 5 min)
def test_errors_name_file_and_feature(tmp_path) -> None:
    bow = [[_pt(2, 2), _pt(4, 4), _pt(4, 2), _pt(2, 4), _pt(2, 2)]]
    doc = _fc(*_basics(), _feat("building", "Polygon", bow, name="bowtie"),
              _feat(None, "Point", _pt(3, 3), name="nokind"),
              _feat("tower", "Point", _pt(3, 3)),
              _feat("obstacle", "LineString", [_pt(1, 2), _pt(2, 2)]),
              _feat("sensor", "Point", [600000.0, 5100000.0]))  # fmt: skip
    f = _write(tmp_path, "bad.geojson", doc)
    out = tmp_path / "map.json"
    r = _cli("map", "from-geojson", str(f), "-o", str(out))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert any("features[4] 'nokind': no 'kind' property" in x for x in lines)
    assert any("features[5]: unknown kind 'tower'" in x for x in lines)
    assert any("features[6]: obstacle features must be a Polygon or MultiPolygon, got "
               "LineString" in x for x in lines)  # fmt: skip
    assert any("features[7]" in x and "not a WGS84" in x for x in lines)
    assert not out.exists()
    # with the others fixed, the self-intersection is refused naming the feature and the place
    doc = _fc(*_basics(), _feat("building", "Polygon", bow, name="bowtie"))
    r = _cli("map", "from-geojson", str(_write(tmp_path, "bow.geojson", doc)), "-o", str(out))
    assert r.returncode == 2
    assert "features[3] 'bowtie': self-intersection at (lon 7.323000, lat 46.213000)" in \
        r.stderr  # fmt: skip
    assert not out.exists()


def test_whole_file_layers_and_multipolygons(tmp_path) -> None:
    square = lambda i, j: [[_pt(i, j), _pt(i + 1, j), _pt(i + 1, j + 1), _pt(i, j + 1)]]  # noqa: E731
    footprints = _fc(_feat(None, "MultiPolygon", [square(2, 2), square(3.5, 2)], name="twin"),
                     _feat(None, "Polygon", square(2, 3.5)))  # fmt: skip
    sensors = _fc(_feat(None, "Point", _pt(1, 1), required_data=50),
                  _feat(None, "Point", _pt(4, 4), id="roof"))  # fmt: skip
    ends = _fc(_feat("start", "Point", _pt(0, 0)), _feat("end", "Point", _pt(5, 5)))
    layers = read_layers([(_write(tmp_path, "e.geojson", ends), None),
                          (_write(tmp_path, "o.geojson", footprints), "obstacle"),
                          (_write(tmp_path, "s.geojson", sensors), "sensor")])  # fmt: skip
    doc, notes = build_map(layers, margin=50.0, name="layers")
    m = load_map(doc)
    assert len(m.spec.obstacles.polygons) == 3  # the MultiPolygon's two parts, and one more
    assert [p.name for p in m.spec.obstacles.polygons] == ["twin", "twin", None]
    assert m.sensor_ids == ("s1", "roof")
    assert m.required_data[0] == 50.0
    with pytest.raises(GisError, match="no 'kind' property"):
        read_layers([(_write(tmp_path, "o2.geojson", footprints), None)])


def test_given_origin_clips_obstacles_and_refuses_sensors_outside(tmp_path) -> None:
    wide = [[_pt(-1, 2), _pt(3, 2), _pt(3, 3), _pt(-1, 3), _pt(-1, 2)]]
    doc = _fc(*_basics(), _feat("obstacle", "Polygon", wide, name="long"),
              _feat("obstacle", "Polygon", [[_pt(-3, 2), _pt(-2, 2), _pt(-2, 3)]], name="gone"))
    layers = read_layers([(_write(tmp_path, "c.geojson", doc), None)])
    origin = (LAT - 0.5 * D, LON - 0.5 * D, 0.0)
    mdoc, notes = build_map(layers, origin=origin)
    assert any("'long': clipped to the area" in n for n in notes)
    assert any("'gone': outside the area; dropped" in n for n in notes)
    m = load_map(mdoc)
    assert [p.name for p in m.spec.obstacles.polygons] == ["long"]
    assert m.shapes[0].shell[:, 0].min() == pytest.approx(0.0, abs=1e-6)
    doc["features"].append(_feat("sensor", "Point", _pt(-1, 1), id="west"))
    layers = read_layers([(_write(tmp_path, "c2.geojson", doc), None)])
    with pytest.raises(GisError, match="sensor .* is outside the area") as err:
        build_map(layers, origin=origin)
    # the position quoted is the feature's own, as the file gives it
    lon, lat = _pt(-1, 1)
    assert f"sensor (lon {lon:.6f}, lat {lat:.6f}) is outside the area" in str(err.value)


def test_a_stray_far_feature_is_named_as_the_cause(tmp_path) -> None:
    # one sensor on another continent: the data cannot be one map; said once, with the
    # longitudes and latitudes the file spans, not as every other feature being "outside"
    doc = _fc(*_basics(), _feat("sensor", "Point", [-70.0, -33.0], id="far"))
    layers = read_layers([(_write(tmp_path, "far.geojson", doc), None)])
    with pytest.raises(GisError) as err:
        build_map(layers)
    assert len(err.value.problems) == 1
    assert err.value.problems[0].startswith(
        "the features lie too far apart for one map (longitude -70.000000 to ")
    # and which one: the rest fit one map without it (no swap brings it among them)
    assert err.value.problems[0].endswith(
        "far.geojson: features[3] 'far' at (lon -70.000000, lat -33.000000) lies far from the "
        "others")
    # with an origin given the frame is the user's: only the stray sensor is outside it
    with pytest.raises(GisError) as err:
        build_map(layers, origin=(LAT - 0.5 * D, LON - 0.5 * D, 0.0))
    assert len(err.value.problems) == 1
    assert err.value.problems[0].endswith(
        "sensor (lon -70.000000, lat -33.000000) is outside the area")


def test_a_feature_written_lat_lon_is_named_with_the_swap_asked(tmp_path) -> None:
    """A reviewer's sensor written [lat, lon] among [lon, lat] ones: "the features lie too far
    apart" named neither the feature nor the likely cause."""
    doc = _fc(*_basics(), _feat("sensor", "Point", _pt(3, 2)[::-1], id="b"),
              _feat("obstacle", "Polygon", [[_pt(2, 2), _pt(3, 2), _pt(3, 3), _pt(2, 2)]],
                    name="barn"))  # fmt: skip
    layers = read_layers([(_write(tmp_path, "swap.geojson", doc), None)])
    with pytest.raises(GisError) as err:
        build_map(layers)
    (line,) = err.value.problems
    lon, lat = _pt(3, 2)
    assert line.startswith("the features lie too far apart for one map (longitude "), line
    assert line.endswith(
        f"swap.geojson: features[3] 'b' at (lon {lat:.6f}, lat {lon:.6f}) lies far from the "
        "others; GeoJSON positions are [longitude, latitude]: is this one written [latitude, "
        "longitude]?"), line
    # a polygon written so is named by its name, around its vertices' mean
    ring = [[p[::-1] for p in [_pt(2, 2), _pt(3, 2), _pt(3, 3), _pt(2, 2)]]]
    doc = _fc(*_basics(), _feat("obstacle", "Polygon", ring, name="barn"))
    with pytest.raises(GisError) as err:
        build_map(read_layers([(_write(tmp_path, "swap2.geojson", doc), None)]))
    assert "swap2.geojson: features[3] 'barn' around (lon 46.2" in err.value.problems[0]
    assert err.value.problems[0].endswith("is this one written [latitude, longitude]?")


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_qgroundcontrol_geofence(tmp_path) -> None:
    def ll(i, j):
        lon, lat = _pt(i, j)
        return [lat, lon]

    plan = {
        "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
        "mission": {"items": [], "plannedHomePosition": [*ll(0.5, 0.5), 400.0], "version": 2},
        "geoFence": {"version": 2, "polygons": [
            {"inclusion": True, "version": 1,
             "polygon": [ll(0, 0), ll(6, 0), ll(6, 3), ll(3, 3), ll(3, 6), ll(0, 6)]},
            {"inclusion": False, "version": 1, "polygon": [ll(1, 2), ll(2, 2), ll(2, 2.5)]},
        ], "circles": [
            {"inclusion": False, "version": 1, "circle": {"center": ll(1, 4), "radius": 30.0}},
        ]},
        "rallyPoints": {"points": [], "version": 2},
    }  # fmt: skip
    p = _write(tmp_path, "fence.plan", plan)
    s = _write(tmp_path, "s.geojson", _fc(_feat(None, "Point", _pt(2, 1), id="a")))
    out = tmp_path / "fence.json"
    r = _cli("map", "from-geojson", str(p), "--sensors", str(s), "-o", str(out))
    assert r.returncode == 0, r.stderr
    m = load_map(out)
    assert len(m.spec.obstacles.circles) == 1 and m.spec.obstacles.circles[0].radius == 30.0
    zones = [sh for sh in m.shapes if sh.kind == "no_fly_zone"]
    assert len(zones) == 2  # the exclusion triangle and the part of the box outside the L fence
    outside = next(z for z in zones if z.name == "outside the inclusion fence")
    assert Polygon(outside.shell).area == pytest.approx(m.width * m.height / 4, rel=1e-3)
    assert m.spec.origin.alt == 400.0  # the planned home's altitude (AMSL), not 0
    home = latlon_to_enu(ll(0.5, 0.5)[0], ll(0.5, 0.5)[1],
                         (m.spec.origin.lat, m.spec.origin.lon, m.spec.origin.alt))  # fmt: skip
    np.testing.assert_allclose(m.start, np.ravel(home), atol=1e-3)
    assert "start and end default to" in r.stderr
    np.testing.assert_allclose(m.start, m.end)


def test_export_has_kinds_and_orientation(campus) -> None:
    path, _ = campus
    doc = map_to_geojson(load_map(path))
    kinds = [f["properties"]["kind"] for f in doc["features"]]
    assert kinds.count("obstacle") == 4 and kinds.count("no_fly_zone") == 1
    assert kinds.count("sensor") == 3 and kinds.count("area") == 1
    court = next(f for f in doc["features"] if f["properties"].get("name") == "court")
    shell, hole = court["geometry"]["coordinates"]
    assert shell[0] == shell[-1] and hole[0] == hole[-1]
    assert LineString(shell).is_ring and Polygon(shell).exterior.is_ccw
    assert not Polygon(hole).exterior.is_ccw  # RFC 7946: holes clockwise


def test_campus_generator_is_seeded_and_non_convex() -> None:
    from lamde_mission.gis.synthetic import campus_map

    a, b = campus_map(40, seed=3), campus_map(40, seed=3)
    assert a == b and a != campus_map(40, seed=4)
    m = load_map(a)
    assert len(m.shapes) == 40 and not any(sh.convex for sh in m.shapes)
    assert m.obstacles.n_regions == 40


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_bench_evaluate_prints_suite_and_campus_in_one_run() -> None:
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_evaluate.py"),
                        str(ROOT / "examples" / "maps" / "tiny.json"), "campus-30",
                        "--batches", "2", "--population", "10", "--reference-solutions", "3"],
                       capture_output=True, text=True, timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "map campus-30-seed0: " in r.stdout and "30 polygon footprints" in r.stdout
    assert r.stdout.count("fast evaluator:") == 2
    assert r.stdout.count("(results agree: True)") == 2


@pytest.mark.slow  # measured 19 s (issue 35: default suite <= 5 min)
def test_show_draws_footprints_and_bad_options_exit_2(campus, tmp_path) -> None:
    path, _ = campus
    png = tmp_path / "campus.png"
    r = _cli("show", str(path), "-o", str(png))
    assert r.returncode == 0, r.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    r = _cli("map", "from-geojson", str(CAMPUS), "--origin", "north", "-o", str(tmp_path / "x"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--origin" in r.stderr
    r = _cli("map", "from-geojson", "-o", str(tmp_path / "x"))
    assert r.returncode == 2 and "at least one input FILE" in r.stderr
    r = _cli("map", "from-geojson", str(tmp_path / "missing.geojson"), "-o", str(tmp_path / "x"))
    assert r.returncode == 2 and "missing.geojson: file not found" in r.stderr


def test_round_trip_summary_counts_every_obstacle_and_names_the_subcommand(tmp_path,
                                                                         capsys) -> None:
    """`map from-geojson` of small-demo's export printed "0 obstacles, 1 no-fly zones, 1
    circles" (only polygons counted as obstacles, so the rectangle looked lost), `check` "1
    circles, 1 rectangles"; its errors began "lamde-mission map:" where argparse's name the
    subcommand."""
    from lamde_mission.cli import main

    gj, back = tmp_path / "sd.geojson", tmp_path / "sd-back.json"
    assert main(["map", "to-geojson", str(ROOT / "examples" / "maps" / "small-demo.json"),
                 "-o", str(gj)]) == 0  # fmt: skip
    assert capsys.readouterr().out == f"wrote {gj}: 10 features\n"
    assert main(["map", "from-geojson", str(gj), "-o", str(back)]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"wrote {back}: 4 sensors, 2 obstacles (1 circle, 1 rectangle), 1 "
                          "no-fly zone; area 2000 m x 2000 m from origin "), out
    assert main(["check", str(back)]) == 0
    assert ("  obstacles       1 circle, 1 rectangle, 0 polygons, 1 no-fly zone\n"
            in capsys.readouterr().out)
    assert main(["map", "from-geojson", str(tmp_path / "nope.geojson"), "-o",
                 str(tmp_path / "x.json")]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert err == f"lamde-mission map from-geojson: {tmp_path / 'nope.geojson'}: file not found\n"


def test_multipolygon_problem_names_the_part(tmp_path) -> None:
    ok = [[_pt(2, 2), _pt(3, 2), _pt(3, 3), _pt(2, 2)]]
    bow = [[_pt(2, 4), _pt(3, 5), _pt(3, 4), _pt(2, 5), _pt(2, 4)]]
    doc = _fc(*_basics(), _feat("obstacle", "MultiPolygon", [ok, bow], name="pair"))
    layers = read_layers([(_write(tmp_path, "mp.geojson", doc), None)])
    with pytest.raises(GisError, match=r"features\[3\] 'pair' polygon 1: self-intersection"):
        build_map(layers)


def test_an_import_problem_that_names_no_feature_names_the_file(tmp_path, capsys) -> None:
    """A reviewer: "no features: nothing to build a map from" named no file, where every
    problem of a feature names its file; now each such line leads with the inputs."""
    from lamde_mission.cli import main

    empty = _write(tmp_path, "empty.geojson", _fc())
    assert main(["map", "from-geojson", str(empty), "-o", str(tmp_path / "e.json")]) == 2
    err = capsys.readouterr().err
    assert f"{empty}: no features: nothing to build a map from" in err
    assert not (tmp_path / "e.json").exists()
    sensors_only = _write(tmp_path, "s.geojson", _fc(*[f for f in _basics()
                                                       if f["properties"]["kind"] == "sensor"]))
    assert main(["map", "from-geojson", str(sensors_only), "-o", str(tmp_path / "e.json")]) == 2
    err = capsys.readouterr().err
    assert f"{sensors_only}: no start: add a Point feature" in err
    assert f"{sensors_only}: no end: add a Point feature" in err


@pytest.mark.slow  # measured 5 s (issue 35: default suite <= 5 min)
def test_cli_map_campus_writes_the_benchmark_map(tmp_path) -> None:
    """The README's `lamde-mission map campus -o campus.json`: the seeded 500-footprint map."""
    out = tmp_path / "campus.json"
    r = subprocess.run([sys.executable, "-m", "lamde_mission.cli", "map", "campus", "-o",
                        str(out)], capture_output=True, text=True, timeout=300)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "500 footprints, 15 sensors" in r.stdout
    m = load_map(out)
    assert len(m.shapes) == 500 and len(m.sensor_ids) == 15


# --------------------------------------------------------------- round trips, fences, outputs

#: a map whose every setting differs from the defaults, with each kind of geometry; the no-fly
#: zone 'road' lies on the area's west edge
FARM = {
    "name": "farm", "origin": {"lat": 46.21, "lon": 7.32, "alt": 410.0},
    "area": {"width": 800, "height": 600}, "start": [10, 10], "end": [790, 590],
    "sensors": [{"id": "s1", "x": 200, "y": 150, "required_data": 120},
                {"id": "pump", "x": 600, "y": 400}],
    "obstacles": {
        "circles": [{"x": 400, "y": 300, "radius": 30}],
        "rectangles": [{"x": 300, "y": 500, "length": 60, "width": 20, "angle_deg": 15}],
        "no_fly_zones": [{"vertices": [[0, 200], [100, 200], [100, 260], [0, 260]],
                          "name": "road"}],
        "polygons": [{"vertices": [[500, 100], [560, 100], [560, 160], [500, 160]],
                      "holes": [[[520, 120], [540, 120], [540, 140], [520, 140]]],
                      "name": "barn"}]},
    "uav": {"altitude": 60, "max_speed": 15, "acceleration": 3, "max_hover_time": 200,
            "max_hover_points": 12, "activation_threshold": 0.4,
            "battery": {"energy_wh": 90, "reserve": 0.25}},
    "radio": {"peak_rate": 8, "decay": 0.02, "bandwidth": 20, "required_data": 150,
              "access": "scheduled"},
    "objective": {"alpha": 0.3, "collision_offset": 900, "collision_weight": 8,
                  "goal": "makespan"},
    "safety": {"clearance": 5, "data_margin": 0.05},
    "fleet": {"uavs": 2, "depots": [{"name": "yard", "x": 10, "y": 10}], "swap_s": 200},
}  # fmt: skip


def _assert_same(got, want, where="map") -> None:
    """Equal JSON, numbers within 1 cm (positions pass through WGS84), everything else exact."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and set(got) == set(want), f"{where}: {got} != {want}"
        for k in want:
            _assert_same(got[k], want[k], f"{where}.{k}")
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), f"{where}: {got} != {want}"
        for k, (a, b) in enumerate(zip(got, want, strict=True)):
            _assert_same(a, b, f"{where}[{k}]")
    elif isinstance(want, float | int) and not isinstance(want, bool):
        assert got == pytest.approx(want, abs=0.01), f"{where}: {got} != {want}"
    else:
        assert got == want, f"{where}: {got!r} != {want!r}"


def _layers_of(tmp_path, doc, name="e.geojson"):
    return read_layers([(_write(tmp_path, name, doc), None)])


def test_geojson_round_trip_keeps_every_setting(tmp_path) -> None:
    m = load_map(FARM)
    exported = map_to_geojson(m)
    doc, notes = build_map(_layers_of(tmp_path, exported), default_name="e")
    back = load_map(doc)
    # the settings come back exactly; positions within a centimetre; the rectangle a rectangle
    _assert_same(back.to_dict(), m.to_dict())
    for key in ("name", "uav", "radio", "objective", "safety", "fleet"):
        assert back.to_dict()[key] == m.to_dict()[key], key
    assert back.spec.uav.altitude == 60.0 and back.name == "farm"
    # nothing was clipped (the road lies on the edge) and no inclusion fence was involved
    assert not any("clipped" in n for n in notes), notes
    assert not any("inclusion fence" in n for n in notes), notes
    assert any(n.startswith("map settings (uav, radio, objective, safety, fleet) from ")
               for n in notes)  # fmt: skip
    # a plain GeoJSON (no settings on its area) gets the defaults, and the name it is given;
    # its depot feature is still a depot (a fleet of the defaults with that depot)
    area = exported["features"][0]["properties"]
    for key in ("name", "uav", "radio", "objective", "safety", "fleet"):
        area.pop(key)
    doc, _ = build_map(_layers_of(tmp_path, exported, "plain.geojson"), default_name="plain")
    plain = load_map(doc)
    assert plain.name == "plain" and plain.spec.uav.altitude == 100.0
    assert plain.spec.safety.clearance == 10.0
    assert [d.name for d in plain.spec.fleet.depots] == ["yard"] and plain.uavs == 1
    exported["features"] = [f for f in exported["features"]
                            if f["properties"]["kind"] != "depot"]  # fmt: skip
    doc, _ = build_map(_layers_of(tmp_path, exported, "bare.geojson"), default_name="bare")
    assert load_map(doc).spec.fleet is None


def test_settings_saved_as_json_text_by_a_gis_editor_are_read_back(tmp_path) -> None:
    m = load_map(FARM)
    exported = map_to_geojson(m)
    area = exported["features"][0]["properties"]
    # QGIS keeps nested properties as their JSON text when it saves a layer
    for key in ("uav", "radio", "objective", "safety", "fleet"):
        area[key] = json.dumps(area[key])
    doc, notes = build_map(_layers_of(tmp_path, exported, "qgis.geojson"), default_name="e")
    back = load_map(doc)
    for key in ("name", "uav", "radio", "objective", "safety", "fleet"):
        assert back.to_dict()[key] == m.to_dict()[key], key
    assert "uav, radio, objective, safety, fleet: read from JSON text (a GIS editor saves " \
        "nested properties as text)" in notes
    # text that is not JSON: one line naming the property
    area["uav"] = '{"altitude": 60,'
    with pytest.raises(GisError, match=r"properties\.uav: a JSON text that does not parse"):
        read_layers([(_write(tmp_path, "bad.geojson", exported), None)])


@pytest.mark.parametrize("older", [False, True], ids=["depot features", "older export"])
def test_a_new_origin_moves_the_depots_with_the_map(tmp_path, older) -> None:
    m = load_map(FARM)
    exported = map_to_geojson(m)
    if older:  # as exports before depot features wrote it: the depots in the area's fleet
        exported["features"] = [f for f in exported["features"]
                                if f["properties"]["kind"] != "depot"]  # fmt: skip
        exported["features"][0]["properties"]["fleet"] = m.to_dict()["fleet"]
    layers = _layers_of(tmp_path, exported)
    # the same place, the frame's (0, 0) 100 m further west and south: local x, y grow by ~100
    lat, lon = np.ravel(enu_to_latlon(-100.0, -100.0, (46.21, 7.32, 410.0)))
    doc, notes = build_map(layers, origin=(float(lat), float(lon), 410.0))
    depot = load_map(doc).spec.fleet.depots[0]
    assert (depot.x, depot.y) == (pytest.approx(110.0, abs=0.01), pytest.approx(110.0, abs=0.01))
    assert any("depots" in n and "moved" in n for n in notes) == older


def test_depots_are_point_features_and_come_back(tmp_path) -> None:
    # the depots lived only in the area's fleet settings, in local metres: a GIS showed none,
    # and from-geojson refused {"kind": "depot"} ("unknown kind 'depot'")
    d = json.loads(json.dumps(FARM))
    d["fleet"]["depots"] = [{"name": "yard", "x": 10, "y": 10}, {"name": "barn-2", "x": 700,
                                                                 "y": 300}]  # fmt: skip
    m = load_map(d)
    exported = map_to_geojson(m)
    feats = [f for f in exported["features"] if f["properties"]["kind"] == "depot"]
    assert [(f["properties"]["name"], f["properties"]["index"], f["geometry"]["type"])
            for f in feats] == [("yard", 0, "Point"), ("barn-2", 1, "Point")]  # fmt: skip
    lon, lat = feats[1]["geometry"]["coordinates"]
    x, y = latlon_to_enu(lat, lon, (46.21, 7.32, 410.0))
    assert (float(x), float(y)) == (pytest.approx(700, abs=0.01), pytest.approx(300, abs=0.01))
    # the area's fleet settings no longer repeat them (one place to move a depot: its point)
    assert exported["features"][0]["properties"]["fleet"] == {"uavs": 2, "swap_s": 200.0}
    doc, _ = build_map(_layers_of(tmp_path, exported, "farm.geojson"))
    back = load_map(doc)
    _assert_same(back.to_dict()["fleet"], m.to_dict()["fleet"])
    # a depot moved in the GIS is moved in the map; the features take precedence over depots
    # in the carried fleet settings (older exports), which a note says were replaced
    feats[1]["geometry"]["coordinates"] = [float(v) for v in reversed(np.ravel(
        enu_to_latlon(650.0, 320.0, (46.21, 7.32, 410.0))))]  # fmt: skip
    exported["features"][0]["properties"]["fleet"] = m.to_dict()["fleet"]
    doc, notes = build_map(_layers_of(tmp_path, exported, "moved.geojson"))
    assert [(dp.name, round(dp.x, 2), round(dp.y, 2)) for dp in load_map(doc).spec.fleet.depots] \
        == [("yard", 10.0, 10.0), ("barn-2", 650.0, 320.0)]
    assert any(n.startswith("fleet.depots: the 2 depot features replace the 2 in the fleet "
                            "settings of ") for n in notes), notes
    # one feature left: the verb agrees ("the 1 depot feature replace the 2" was printed)
    exported["features"].remove(feats[1])
    _, notes = build_map(_layers_of(tmp_path, exported, "one.geojson"))
    assert any(n.startswith("fleet.depots: the 1 depot feature replaces the 2 in the fleet "
                            "settings of ") for n in notes), notes


def test_depot_features_in_a_plain_geojson(tmp_path) -> None:
    base = [_feat("sensor", "Point", _pt(2, 2), id="a"), _feat("start", "Point", _pt(1, 1)),
            _feat("end", "Point", _pt(1, 1))]  # fmt: skip
    doc, _ = build_map(_layers_of(tmp_path, _fc(*base, _feat("depot", "Point", _pt(3, 1),
                                                              name="pad"),
                                                _feat("depot", "Point", _pt(1, 3)))))
    m = load_map(doc)
    assert [d.name for d in m.spec.fleet.depots] == ["pad", "d2"] and m.has_fleet
    # a depot outside the area, and a name given twice: one line each naming the feature
    area = [[_pt(0, 0), _pt(6, 0), _pt(6, 6), _pt(0, 6), _pt(0, 0)]]
    doc = _fc(_feat("area", "Polygon", area), *base, _feat("depot", "Point", _pt(3, 1), name="p"),
              _feat("depot", "Point", _pt(4, 1), name="p"), _feat("depot", "Point", _pt(9, 1)))
    with pytest.raises(GisError) as err:
        build_map(_layers_of(tmp_path, doc, "bad.geojson"))
    lines = err.value.problems
    assert any("features[5] 'p': duplicate depot name 'p' (the first: " in x for x in lines)
    assert any("features[6]: depot (lon " in x and "is outside the area" in x for x in lines)
    assert len(lines) == 2, lines
    # a depot is a Point
    with pytest.raises(GisError, match="depot features must be a Point, got Polygon"):
        read_layers([(_write(tmp_path, "poly.geojson", _fc(_feat("depot", "Polygon", area))),
                      None)])


def test_clipped_only_when_area_is_removed_and_the_area_note_names_its_source(tmp_path) -> None:
    lon0, lat0 = LON, LAT
    area = [[_pt(0, 0), _pt(6, 0), _pt(6, 6), _pt(0, 6), _pt(0, 0)]]
    edge = lon0 - 1e-9  # 0.08 mm west of the area's west edge: on it, not beyond it
    on_edge = [[[edge, lat0 + 2 * D], [lon0 + D, lat0 + 2 * D], [lon0 + D, lat0 + 3 * D],
                [edge, lat0 + 3 * D], [edge, lat0 + 2 * D]]]  # fmt: skip
    across = [[_pt(5, 2), _pt(7, 2), _pt(7, 3), _pt(5, 3), _pt(5, 2)]]  # ~77 m beyond the east
    doc = _fc(_feat("area", "Polygon", area, name="farm boundary"), *_basics(),
              _feat("no_fly_zone", "Polygon", on_edge, name="road"),
              _feat("no_fly_zone", "Polygon", across, name="quarry"))  # fmt: skip
    mdoc, notes = build_map(_layers_of(tmp_path, doc), default_name="plain")
    assert not any("'road'" in n for n in notes), notes
    assert any("'quarry': clipped to the area (it reached 7" in n for n in notes), notes
    # the area came from the `area` feature: the note says so, not "inclusion fence"
    assert any(n.startswith("area: the bounding box of the area polygon (") and
               "features[0] 'farm boundary'" in n for n in notes), notes
    assert not any("inclusion fence" in n for n in notes), notes
    assert load_map(mdoc).name == "plain"  # a plain area polygon's name is a label only


def _fence_plan(polygons, circles, home) -> dict:
    return {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
            "mission": {"items": [], "plannedHomePosition": home, "version": 2},
            "geoFence": {"version": 2, "polygons": polygons, "circles": circles},
            "rallyPoints": {"points": [], "version": 2}}  # fmt: skip


def _ll(i, j) -> list[float]:
    lon, lat = _pt(i, j)
    return [lat, lon]


def test_several_inclusion_fences_are_intersected(tmp_path) -> None:
    square = {"inclusion": True, "version": 1,
              "polygon": [_ll(0, 0), _ll(6, 0), _ll(6, 6), _ll(0, 6)]}
    circle = {"inclusion": True, "version": 1, "circle": {"center": _ll(3, 3), "radius": 40.0}}
    plan = _fence_plan([square], [circle], [*_ll(3, 3), 410.0])
    sensors = _fc(_feat(None, "Point", _pt(3.1, 3.1), id="a"))
    layers = read_layers([(_write(tmp_path, "f.plan", plan), None),
                          (_write(tmp_path, "s.geojson", sensors), "sensor")])  # fmt: skip
    doc, notes = build_map(layers)
    m = load_map(doc)
    # the area is the circle's box, not the square's: the circle (inside the square) counts
    assert m.width == pytest.approx(80.0, abs=0.05) and m.height == pytest.approx(80.0, abs=0.05)
    outside = [sh for sh in m.shapes if sh.name == "outside the inclusion fence"]
    assert len(outside) == 4  # the box's corners outside the circle
    assert sum(Polygon(sh.shell, sh.holes).area for sh in outside) == pytest.approx(
        80.0 * 80.0 - np.pi * 40.0**2, rel=0.01)
    said = [n for n in notes if "AC_PolyFence_loader.cpp" in n]
    assert len(said) == 1 and "intersection of the 2 inclusion fences" in said[0]
    assert "PX4" in said[0]
    assert "geoFence.polygons[0]" in said[0] and "geoFence.circles[0]" in said[0]
    # fences with nothing in common: refused in one line naming both
    far = {"inclusion": True, "version": 1, "circle": {"center": _ll(20, 20), "radius": 40.0}}
    plan = _fence_plan([square], [far], [*_ll(3, 3), 410.0])
    layers = read_layers([(_write(tmp_path, "g.plan", plan), None),
                          (_write(tmp_path, "s.geojson", sensors), "sensor")])  # fmt: skip
    with pytest.raises(GisError) as err:
        build_map(layers)
    assert len(err.value.problems) == 1
    line = err.value.problems[0]
    assert "do not overlap" in line and "geoFence.polygons[0]" in line
    assert "geoFence.circles[0]" in line


def test_plan_home_altitude_is_the_origin_altitude(tmp_path) -> None:
    square = {"inclusion": True, "version": 1,
              "polygon": [_ll(0, 0), _ll(6, 0), _ll(6, 6), _ll(0, 6)]}
    sensors = _write(tmp_path, "s.geojson", _fc(_feat(None, "Point", _pt(2, 2), id="a")))
    plan = _write(tmp_path, "f.plan", _fence_plan([square], [], [*_ll(1, 1), 410.0]))
    layers = read_layers([(plan, None), (sensors, "sensor")])
    doc, notes = build_map(layers)
    assert doc["origin"]["alt"] == 410.0
    assert any(n.startswith("origin altitude 410 m from ") for n in notes)
    # --origin LAT,LON (no ALT) takes it too; an ALT given wins
    assert build_map(layers, origin=(LAT, LON, None))[0]["origin"]["alt"] == 410.0
    assert build_map(layers, origin=(LAT, LON, 5.0))[0]["origin"]["alt"] == 5.0
    bad = _write(tmp_path, "b.plan", _fence_plan([square], [], [*_ll(1, 1), 20000.0]))
    with pytest.raises(GisError, match=r"b\.plan: mission\.plannedHomePosition\[2\]: altitude "
                       r"20000 m is outside \[-500, 9000\] m"):  # fmt: skip
        read_layers([(bad, None)])


def test_a_null_sensor_id_falls_back_to_the_name(tmp_path) -> None:
    doc = _fc(_feat("sensor", "Point", _pt(2, 2), id=None, name="well"),
              _feat("sensor", "Point", _pt(3, 3), id=None, NAME="gate"),
              _feat("sensor", "Point", _pt(4, 4), id=None),
              _feat("start", "Point", _pt(0, 0)), _feat("end", "Point", _pt(5, 5)))  # fmt: skip
    mdoc, _ = build_map(_layers_of(tmp_path, doc))
    assert load_map(mdoc).sensor_ids == ("well", "gate", "s3")


@pytest.mark.slow  # four CLI runs
def test_cli_refuses_an_output_that_is_an_input_and_round_trips(tmp_path) -> None:
    src = _write(tmp_path, "farm.json", FARM)
    before = src.read_bytes()
    r = _cli("map", "to-geojson", str(src), "-o", str(src))
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert "-o/--output" in r.stderr and "is the input" in r.stderr
    assert src.read_bytes() == before
    gj = tmp_path / "e.geojson"
    assert _cli("map", "to-geojson", str(src), "-o", str(gj)).returncode == 0
    exported = gj.read_bytes()
    link = tmp_path / "link.geojson"
    link.symlink_to(gj)
    r = _cli("map", "from-geojson", str(link), "--sensors", str(gj), "-o", str(gj))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "-o/--output" in r.stderr
    assert gj.read_bytes() == exported
    out = tmp_path / "rt.json"
    r = _cli("map", "from-geojson", str(gj), "-o", str(out))
    assert r.returncode == 0, r.stderr
    back = json.loads(out.read_text())
    assert back["name"] == "farm" and back["uav"]["altitude"] == 60.0
    assert "clipped" not in r.stderr and "inclusion fence" not in r.stderr


def test_two_plans_with_different_planned_homes_are_refused(tmp_path) -> None:
    square = {"inclusion": True, "version": 1,
              "polygon": [_ll(0, 0), _ll(6, 0), _ll(6, 6), _ll(0, 6)]}
    a = _write(tmp_path, "a.plan", _fence_plan([square], [], [*_ll(1, 1), 410.0]))
    same = _write(tmp_path, "same.plan", _fence_plan([], [], [*_ll(1, 1), 410.0]))
    other = _write(tmp_path, "other.plan", _fence_plan([], [], [*_ll(5, 5), 410.0]))
    # the same home twice (a fence file and a mission of one survey): no conflict
    read_layers([(a, None), (same, None)])
    # another home: the start, end and origin altitude would follow the last file read
    with pytest.raises(GisError, match=r"other\.plan: mission\.plannedHomePosition: a second "
                       r"planned home, not the one of .*a\.plan: planned home"):  # fmt: skip
        read_layers([(a, None), (other, None)])


def test_map_help_and_docstring_name_every_subcommand() -> None:
    """`lamde-mission map`'s help line, description and module docstring name each of its
    subcommands (they named from-geojson and to-geojson, not campus)."""
    import argparse

    import lamde_mission.commands.map as map_command
    from lamde_mission.cli import build_parser

    top = build_parser()
    (sub,) = [a for a in top._actions if isinstance(a, argparse._SubParsersAction)]
    p = sub.choices["map"]
    (msub,) = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
    help_line = next(a.help for a in sub._choices_actions if a.dest == "map")
    assert sorted(msub.choices) == ["campus", "from-geojson", "to-geojson"]
    for name in msub.choices:
        assert f"map {name}" in p.description and name in map_command.__doc__, name
    assert "campus" in help_line
