"""Safety margins are a transformation of the map: obstacles inflated by `safety.clearance`,
required data raised by `safety.data_margin`, the paper's model unchanged."""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely

import lamde_mission
from lamde_mission.items import geofence_items, plan_to_items
from lamde_mission.storage import storable_plan, stored_items
from planner_core.model.mapio import DEFAULT_CLEARANCE, DEFAULT_DATA_MARGIN, load_map
from planner_core.model.problem import Problem
from sim import replay, verify
from sim.obstacles import obstacle_shapes
from tests.conftest import SUITE, run_cli


def _default_margins(task: str) -> dict:
    d = json.loads((SUITE / f"{task}.json").read_text())
    d.pop("safety")  # the documented defaults
    d.pop("witness")
    return d


def _flown_distance(m, timeline) -> np.ndarray:
    """Per obstacle: the shortest distance (m) of the flown path, by shapely."""
    path = shapely.linestrings(timeline.path)
    return np.array([shapely.distance(path, o.shape) for o in obstacle_shapes(m)])


def _check_clearance(task: str) -> None:
    m = load_map(_default_margins(task))
    assert m.spec.safety.clearance == DEFAULT_CLEARANCE >= 5.0
    plan = lamde_mission.plan(m, seed=0, budget=5000)
    sp = storable_plan(plan, m, "px4", planning_map=m.planning_map())
    tl = replay(stored_items(plan_to_items(sp, m), "px4"), m)
    v = verify(tl, m)
    assert v.passed, v.table()
    dist = _flown_distance(m, tl)
    force = np.array(m.obstacle_clearances)
    assert np.all(dist >= force), (task, float((dist - force).min()))
    assert np.all(force == DEFAULT_CLEARANCE)  # no suite start/end is that close to a building
    assert v.clearance == pytest.approx(dist.min())
    got = np.array([v.data_margins[s] for s in m.sensor_ids])
    assert np.all(got >= DEFAULT_DATA_MARGIN - 1e-6)


@pytest.mark.parametrize("task", ["T01", "T08"])
def test_default_clearance_is_kept_on_suite_maps(task):
    _check_clearance(task)


@pytest.mark.slow
@pytest.mark.parametrize("task", [f"T{k:02d}" for k in range(1, 17)])
def test_default_clearance_is_kept_on_every_suite_map(task):
    _check_clearance(task)


def test_zero_margins_score_exactly_as_the_paper_model():
    m = load_map(SUITE / "T03.json")
    assert m.spec.safety.clearance == 0 and m.spec.safety.data_margin == 0
    assert m.planning_map() is m
    X = np.random.default_rng(0).random((50, Problem(m).dim)) * Problem(m).upper
    f0, p0 = Problem(m).evaluate(X)
    f1, p1 = Problem(m.planning_map()).evaluate(X)
    assert np.array_equal(f0, f1) and np.array_equal(p0, p1)


def test_required_data_with_its_margin_stays_within_the_limit():
    # a required data the validator accepts (<= 1e7 Mbit) but the margin raises past the limit
    # used to fail later, inside the planning map, with a traceback naming a field the user
    # never wrote; now the map is refused on load, one problem naming the field written
    from planner_core.model.mapio import MapError

    d = _default_margins("T01")
    d["sensors"][0]["required_data"] = 1e7
    with pytest.raises(MapError) as err:
        load_map(d)
    assert [str(p) for p in err.value.problems] == [
        "sensors[0].required_data: 10000000 Mbit with safety.data_margin 0.02 is 10200000 Mbit "
        "to plan, above the limit 10000000 (lower one of them)"]
    d["safety"] = {"data_margin": 0.0}  # the paper's model: the limit itself is allowed
    assert load_map(d).planning_map().required_data[0] == 1e7
    d = _default_margins("T01")
    d.setdefault("radio", {})["required_data"] = 9.9e6
    with pytest.raises(MapError) as err:
        load_map(d)
    assert [str(p).split(":")[0] for p in err.value.problems] == ["radio.required_data"]


def test_planning_map_inflates_obstacles_and_raises_data():
    d = _default_margins("T01")
    d["safety"] = {"clearance": 12.0, "data_margin": 0.05}
    m = load_map(d)
    pm = m.planning_map()
    assert pm.spec.safety.clearance == 0 and pm.spec.safety.data_margin == 0
    assert np.allclose(pm.required_data, m.required_data * 1.05)
    assert [c.radius for c in pm.spec.obstacles.circles] == pytest.approx(
        [c.radius + 12.05 for c in m.spec.obstacles.circles])
    # every rectangle and no-fly zone grown by at least the clearance, and not much more
    real = [o.shape for o in obstacle_shapes(m) if o.kind != "circle"]
    # the planning map: rectangles became polygon obstacles (first), no-fly zones stay
    nr = len(m.spec.obstacles.rectangles)
    planned = [o.shape for o in obstacle_shapes(pm) if o.kind != "circle"]
    nz = len(pm.spec.obstacles.no_fly_zones)
    grown = planned[nz:nz + nr] + planned[:nz] + planned[nz + nr:]
    assert len(real) == len(grown)
    for r, g in zip(real, grown, strict=True):
        assert g.contains(r.buffer(12.0, quad_segs=32))
        assert not r.buffer(12.6, quad_segs=32).within(g)  # tight enough: ~2 % over
    # the fence written to the vehicle is the real shape, not the inflated one
    assert len(geofence_items(m)) == sum(len(p) for p in m.rectangle_polygons) + len(
        m.spec.obstacles.circles) + sum(len(p) for p in m.nfz_polygons)


def test_clearance_near_the_start_leaves_the_start_outside():
    d = {"name": "near", "origin": {"lat": 46.2, "lon": 7.3},
         "area": {"width": 1000, "height": 1000}, "start": [100, 100], "end": [900, 900],
         "sensors": [{"id": "a", "x": 500, "y": 500}],
         "obstacles": {"circles": [{"x": 100, "y": 106, "radius": 4}]},
         "safety": {"clearance": 10}}  # fmt: skip
    m = load_map(d)
    assert m.obstacle_clearances[0] == pytest.approx(2.0 - 0.05)
    pm = m.planning_map()
    assert pm.spec.obstacles.circles[0].radius == pytest.approx(6.0)
    plan = lamde_mission.plan(m, seed=0, budget=1000)
    assert plan.feasible
    v = verify(replay(plan_to_items(storable_plan(plan, m, "px4", planning_map=pm), m), m), m)
    assert v.passed, v.table()
    # the reduced clearance is said where it is judged: the sim's CLEAR row and check's summary
    clear = next(x for x in v.items if x.name == "CLEAR")
    assert clear.title == "clearance >= 10 m (less by the start/end)"
    from lamde_mission.commands.check import _reduced_clearance

    assert _reduced_clearance(m) == (" (less where the start, end or a depot is closer: "
                                     "1.95 m at circle 0)")
    d["obstacles"]["circles"][0]["y"] = 300  # far from both ends: nothing reduced
    assert _reduced_clearance(load_map(d)) == ""


def test_non_convex_polygons_and_holes_are_inflated_too():
    d = {"name": "campus", "origin": {"lat": 46.2, "lon": 7.3},
         "area": {"width": 1000, "height": 1000}, "start": [50, 50], "end": [950, 950],
         "sensors": [{"id": "a", "x": 500, "y": 800}, {"id": "b", "x": 800, "y": 300}],
         "obstacles": {
             "polygons": [{"vertices": [[300, 300], [600, 300], [600, 400], [400, 400],
                                        [400, 600], [300, 600]], "name": "L"}],
             "no_fly_zones": [{"vertices": [[650, 550], [900, 550], [900, 800], [650, 800]],
                               "holes": [[[700, 600], [850, 600], [850, 750], [700, 750]]]}]},
         "safety": {"clearance": 15}}  # fmt: skip
    m = load_map(d)
    pm = m.planning_map()
    assert len(pm.spec.obstacles.polygons) == 1 and len(pm.spec.obstacles.no_fly_zones) == 1
    assert pm.spec.obstacles.polygons[0].name == "L"
    real = [o.shape for o in obstacle_shapes(m)]
    grown = [o.shape for o in obstacle_shapes(pm)]
    assert grown[0].contains(real[0].buffer(15.0, quad_segs=32))  # the no-fly zone, hole shrunk
    assert grown[1].contains(real[1].buffer(15.0, quad_segs=32))  # the L
    plan = lamde_mission.plan(m, seed=0, budget=3000)
    sp = storable_plan(plan, m, "px4", planning_map=pm)
    tl = replay(stored_items(plan_to_items(sp, m), "px4"), m)
    assert np.all(_flown_distance(m, tl) >= 15.0)


# a start, end or depot within the clearance of a building of any kind (the rectangle of the
# review's map, the same footprint as a polygon obstacle and as a no-fly zone; beside an
# edge and diagonally off a corner): the planning map keeps it outside the inflated shape
_BLOCK = [[500, 200], [600, 200], [600, 800], [500, 800]]
_NEAR_OBSTACLES = {
    "rectangle": {"rectangles": [{"x": 550, "y": 500, "length": 100, "width": 600}]},
    "polygon": {"polygons": [{"vertices": _BLOCK}]},
    "no-fly zone": {"no_fly_zones": [{"vertices": _BLOCK}]},
    "L-shaped polygon": {"polygons": [{"vertices": [[500, 200], [600, 200], [600, 300],
                                                    [550, 300], [550, 800], [500, 800]]}]},
}  # fmt: skip


def _near_map(kind: str, where: list[float], depot: bool = False) -> dict:
    d = {"name": "near-building", "origin": {"lat": 47.0, "lon": 8.0, "alt": 400.0},
         "area": {"width": 1000, "height": 1000}, "start": where, "end": where,
         "sensors": [{"id": "s1", "x": 800, "y": 800}], "obstacles": _NEAR_OBSTACLES[kind]}
    if depot:  # the start far away; the depot beside the building
        d["start"] = d["end"] = [100, 100]
        d["uav"] = {"endurance_s": 1500}
        d["fleet"] = {"depots": [{"name": "near", "x": where[0], "y": where[1]}]}
    return d  # fmt: skip


@pytest.mark.parametrize("kind", list(_NEAR_OBSTACLES))
@pytest.mark.parametrize("where", [[495, 300], [495, 195], [496.5, 198.5], [490.05, 500],
                                   [499.97, 500]])
@pytest.mark.parametrize("depot", [False, True], ids=["start", "depot"])
def test_a_start_or_depot_near_a_building_stays_outside_its_inflation(kind, where, depot):
    # a rectangle or polygon 5 m from the start used to be inflated past it (its buffer divided
    # by cos(pi/16) on every edge): the planning map refused its own start ("lies inside an
    # obstacle"), a traceback in check and plan, and the fleet plan called the depot inside
    from planner_core.model.geometry import points_inside
    from planner_core.model.mapio import CLEARANCE_PAD, OFFSET_OVERSHOOT

    m = load_map(_near_map(kind, where, depot))
    pm = m.planning_map()  # raised MapError
    point = np.array([where], dtype=float)
    assert not points_inside(point, pm.obstacles)[0]
    real = [o.shape for o in obstacle_shapes(m)]
    d = float(shapely.distance(shapely.Point(where), real[0]))
    cl = m.obstacle_clearances[0]
    assert cl < min(d, 10.0)  # reduced by the point (a leg keeps it: CLEAR judges d - 2 cm)
    assert cl == pytest.approx(max(d - 0.06, 0.0)) if d < 10 else cl == 10.0
    if cl > 0:
        grown = [o.shape for o in obstacle_shapes(pm)][0]
        r = cl + CLEARANCE_PAD
        # an outer approximation of the offset with a bounded overshoot (outer_offset)
        assert grown.contains(real[0].buffer(r * (1 - 1e-9), quad_segs=64))
        assert grown.within(real[0].buffer(r * OFFSET_OVERSHOOT * (1 + 1e-9), quad_segs=64))
        assert grown.distance(shapely.Point(where)) >= 0.004  # half CLEARANCE_SLACK
    if depot:
        assert [x.name for x in pm.depots] == ["near"]


def test_outer_offset_contains_the_offset_and_overshoots_at_most_as_documented():
    # GEOS's buffer puts its arc's vertices on the circle, so its chords cut inside the offset:
    # at a corner turning ~1.49 x pi/8 its one chord sags to r cos(0.75 pi/8) = 0.957 r, and
    # the old r / cos(pi/16) buffer came to 0.976 of the clearance there
    from shapely.geometry import Polygon

    from planner_core.model.mapio import OFFSET_OVERSHOOT, outer_offset

    rng = np.random.default_rng(5)
    a = 1.49 * np.pi / 8
    shapes = [Polygon([(0, 0), (100, 0), (100 + 100 * np.cos(a), 100 * np.sin(a)), (0, 200)]),
              Polygon([(0, 0), (100, 0), (100, 100), (0, 100)],
                      [[(20, 20), (80, 20), (80, 80), (20, 80)]])]  # fmt: skip
    for _ in range(30):
        ang = np.sort(rng.uniform(0, 2 * np.pi, int(rng.integers(3, 10))))
        p = Polygon(np.column_stack([np.cos(ang), np.sin(ang)]) * rng.uniform(20, 100,
                                                                               (len(ang), 1)))
        if p.is_valid:
            shapes.append(p)
    for k, p in enumerate(shapes):
        for r, f in ((12.05, OFFSET_OVERSHOOT), (4.0, 1.002), (25.0, OFFSET_OVERSHOOT)):
            g = outer_offset(p, r, f)
            assert g.geom_type == "Polygon" and g.is_valid, k
            edge = [g.exterior, *g.interiors]
            pts = shapely.points(np.vstack([
                shapely.get_coordinates(shapely.segmentize(e, 0.5)) for e in edge]))
            dist = shapely.distance(p, pts)
            assert dist.min() >= r - 1e-9, (k, r, dist.min())  # every point within r is in
            assert dist.max() <= r * f + 1e-9, (k, r, dist.max())  # at most r x f away
    # the courtyard of the second shape survives a small offset, shrunk by r
    assert len(outer_offset(shapes[1], 12.05).interiors) == 1
    assert len(outer_offset(shapes[1], 31.0).interiors) == 0


@pytest.mark.slow  # measured 1.5 s (the diagnosis' first run in the process)
def test_check_takes_off_beside_a_building(tmp_path, capsys):
    # the review's map: check exited 1 with a traceback (MapError from the planning map)
    from lamde_mission import cli

    path = tmp_path / "nb.json"
    path.write_text(json.dumps(_near_map("rectangle", [495, 300])))
    assert cli.main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("map 'near-building': OK"), out
    assert "(less where the start, end or a depot is closer: 4.94 m at rectangle 0)" in out


@pytest.mark.slow  # measured 11 s: two plans through the CLI, at once
def test_plan_takes_off_beside_a_building(tmp_path):
    # single-flight plan exited 1 with a traceback; the fleet plan said the depot, 5 m outside
    # the building, "lies inside an obstacle"
    from tests.conftest import run_cli_many

    path = tmp_path / "nb.json"
    path.write_text(json.dumps(_near_map("rectangle", [495, 300])))
    fleet = tmp_path / "nbf.json"
    fleet.write_text(json.dumps(_near_map("rectangle", [495, 300], depot=True)))
    one, many = run_cli_many(
        ("plan", path, "-o", tmp_path / "nb.plan", "--budget", "600", "--quiet"),
        ("plan", fleet, "-o", tmp_path / "nbf", "--budget", "600", "--sortie-budget", "300",
         "--rounds", "0", "--quiet"))  # fmt: skip
    assert one.returncode == 0 and "Traceback" not in one.stderr, one.stderr
    assert many.returncode == 0, many.stderr
    for out in (tmp_path / "nb.plan", tmp_path / "nbf"):
        v = run_cli("verify", path if out.suffix else fleet, out)
        assert v.returncode == 0, v.stdout + v.stderr


def test_a_map_error_past_the_commands_checks_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    # a MapError a command meets after loading the map (the planning map, a sortie's map)
    # reaches the user as bad input, one line naming the field, exit 2, no traceback
    import planner_core.model.diagnose as diag
    from lamde_mission import cli
    from planner_core.model.mapio import MapError

    path = tmp_path / "nb.json"
    path.write_text(json.dumps(_near_map("rectangle", [300, 300])))

    def refuse(m):
        raise MapError(["start: (300, 300) lies inside an obstacle or no-fly zone"])

    monkeypatch.setattr(diag, "diagnose", refuse)
    assert cli.main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == (f"lamde-mission check: {path}: start: (300, 300) lies inside an obstacle or "
                   "no-fly zone\n")
