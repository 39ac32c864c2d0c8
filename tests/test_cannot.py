"""`check` proves CANNOT where C3 (the paper's simultaneous uplink) leaves a sensor unservable
(issue 31): `planner_core.model.diagnose.bandwidth_bound`, sound over the whole area."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from planner_core.model.diagnose import bandwidth_bound, diagnose
from planner_core.model.hoverlp import hover_lp_sparse
from planner_core.model.mapio import load_map
from tests.conftest import MAPS, SUITE, run_cli


def dense_field(n: int = 12, size: float = 1000.0, **extra: object) -> dict:
    """n sensors on a 20 m ring (all within 40 m) at the centre of a size x size map, the
    defaults (H 100 m, R_c 10 Mbit/s, xi 0.01, R_lambda 25 Mbit/s): overhead they send
    n x ~9 Mbit/s at once; a point keeps C3 only where each sends ~25 / n Mbit/s, a slant of
    ~790 m for n = 12, beyond every corner of a 1000 m map (707 m: 12 x 2.86 = 34 Mbit/s)."""
    c = size / 2
    m = {
        "name": "dense-field", "area": {"width": size, "height": size},
        "start": [50, 50], "end": [size - 50, size - 50],
        "sensors": [{"id": f"s{k + 1:02d}", "x": c + 20 * math.cos(2 * math.pi * k / n),
                     "y": c + 20 * math.sin(2 * math.pi * k / n)} for k in range(n)],
    }  # fmt: skip
    m.update(extra)
    return m


def _bound(m: object, **over: float) -> object:
    pm = m.planning_map()
    s = pm.spec
    kw = dict(width=pm.width, height=pm.height, altitude=s.uav.altitude,
              peak_rate=s.radio.peak_rate, decay=s.radio.decay, bandwidth=s.radio.bandwidth,
              t_max=s.uav.max_hover_time, i_max=pm.max_hover_points)  # fmt: skip
    kw.update(over)
    return bandwidth_bound(pm.sensors, pm.required_data, list(pm.sensor_ids), **kw)


@pytest.mark.slow  # measured 1.6 s on a loaded machine (default suite <= 5 min)
def test_check_says_cannot_for_a_dense_field_naming_every_sensor(tmp_path) -> None:
    path = tmp_path / "dense.json"
    path.write_text(json.dumps(dense_field()))
    r = run_cli("check", path)
    assert r.returncode == 1, r.stdout + r.stderr
    lines = [ln for ln in r.stdout.splitlines() if ln.strip().startswith("CANNOT")]
    # the first SHOWN_PER_KIND in full, the other two on one line naming them
    # (lamde_mission.commands.check.finding_lines)
    assert len(lines) == 11
    for k in range(12):
        assert sum(f"'s{k + 1:02d}'" in ln for ln in lines) == 1
    assert all("breaks C3" in ln and "proven" in ln for ln in lines[:10])
    assert lines[10].strip().startswith("CANNOT  2 more sensors alike (C3_")
    assert "scheduled" in r.stdout  # the hint
    assert r.stdout.rstrip().endswith("no plan can meet this map (see CANNOT above)")


def test_hover_time_cannot_is_proven_with_the_ring_inside_the_area() -> None:
    """On a 3000 m map the C3 ring (~790 m out) lies inside the area, but every point on it
    takes ~25 Mbit/s in all: 12 x 204 Mbit need >= 97.9 s, more than 10 x 8 s."""
    m = load_map(dense_field(size=3000.0, uav={"max_hover_time": 8.0}))
    d = diagnose(m)
    kinds = [f.kind for f in d.findings if f.fatal]
    assert kinds == ["C3_HOVER_TIME"] * 12
    assert d.bandwidth.v_low == pytest.approx(12 * 204 / 25, rel=1e-3)
    assert d.bandwidth.v_low > d.bandwidth.cap == 80.0
    # none of them alone needs more than the cap (8.2 s): each line names the others
    assert d.bandwidth.alone == ()
    (s01,) = [f.message for f in d.findings if f.fatal and f.sensor == "s01"]
    assert s01.startswith("sensor 's01': with sensors 's02', 's03', 's04' and 8 more it needs at "
                          "least 97.9"), s01
    # with 10 s per point the relaxation stays below the cap: nothing is claimed
    m = load_map(dense_field(size=3000.0, uav={"max_hover_time": 10.0}))
    assert diagnose(m).feasible_so_far


def test_a_sensor_that_alone_needs_more_hover_time_is_named_alone() -> None:
    """fleet-demo with S4 asking 200,000 Mbit: check noted "sensor 'S1': with 1 other sensor
    named here it needs at least 22689.3 s of hover time ..." though S1 asks 200 Mbit, 1.5 km
    from S4, and the other sensor was not named on the line; S4's notes said "at least 16
    sorties" beside the CANNOT's 184. S4 alone needs 204,000 / 9 = 22,667 s: it alone is named,
    and each count of sorties gives the most any finding of S4 proves."""
    doc = json.loads((MAPS / "fleet-demo.json").read_text())
    doc["sensors"][3]["required_data"] = 200000
    d = diagnose(load_map(doc))
    assert d.bandwidth.short == ("S4",) and d.bandwidth.alone == pytest.approx((204000 / 9,))
    assert not [f for f in d.findings if f.sensor == "S1"]
    lines = {f.kind: f.message for f in d.findings if f.sensor == "S4"}
    assert lines["C3_HOVER_TIME"].startswith(
        "sensor 'S4': it alone needs at least 22666.7 s of hover time at hover points that keep "
        "C3 (sum of rates <= R_lambda = 25 Mbit/s), more than I_max x T_max = 5 x 300 s = "
        "1500 s (proven over the whole area on cells down to ")
    assert lines["C3_HOVER_TIME"].endswith(
        "; that bounds one sortie: at least 16 sorties must share its hover time, and at least "
        "184 for the battery (below)")
    assert lines["SEVERAL_SORTIES"].endswith(
        "more than one flight's I_max = 5: at least 16 sorties must share it, and at least 184 "
        "for the battery (below)")
    assert "so at least 184 sorties must share its data" in lines["SORTIE_LIMIT"]


@pytest.mark.parametrize("seed", range(6))
def test_the_proven_least_hover_time_is_below_every_real_plan(seed: int) -> None:
    """Soundness: v_low <= the hover-time LP's value over any set of real points that keep
    C3 (random fields, random points); the cap is made tiny so that the relaxation runs."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 20))
    centre = rng.uniform(800, 1200, 2)
    sensors = centre + rng.normal(0, 60, (n, 2))
    req = rng.uniform(50, 400, n)
    kw = dict(width=2000.0, height=2000.0, altitude=100.0, peak_rate=10.0, decay=0.01,
              bandwidth=float(rng.uniform(15, 40)))  # fmt: skip
    b = bandwidth_bound(sensors, req, [f"s{j}" for j in range(n)], t_max=1e-6, i_max=1, **kw)
    pts = rng.uniform(0, 2000, (4000, 2))
    d = np.sqrt(((pts[:, None, :] - sensors[None]) ** 2).sum(-1) + 100.0**2)
    R = np.maximum(10.0 - 0.01 * d, 0.0)
    R = R[R.sum(axis=1) <= kw["bandwidth"]]
    import scipy.sparse as sp

    sol = hover_lp_sparse(sp.csr_matrix(R), req, math.inf)
    if sol is None:  # no real point serves them all: the test may still have proven less
        return
    assert b.v_low <= sol[1] * (1 + 1e-6)


@pytest.mark.parametrize("path", sorted(SUITE.glob("T*.json")) + sorted(MAPS.glob("*-demo.json"))
                         + [MAPS / "tiny.json"], ids=lambda p: p.stem)  # fmt: skip
def test_suite_and_example_maps_get_no_bandwidth_finding(path) -> None:
    d = diagnose(load_map(path))
    assert not [f for f in d.findings if f.kind.startswith("C3_")]
    assert d.bandwidth is not None and d.bandwidth.rounds == 0  # the overhead points suffice


@pytest.mark.slow  # measured 1.5 s on a loaded machine (default suite <= 5 min)
def test_unreachable_names_its_cause_and_the_heading_does_not_say_ok(tmp_path) -> None:
    # a sensor no hover point hears: the finding says why, the link itself (altitude, R_c,
    # xi: nothing is heard even overhead) or the distance to the nearest point a UAV may hover
    # at (a sensor deep inside a no-fly zone, beyond the link's ground reach); `check`'s first
    # line then does not read OK (exit 1)
    high = load_map(dense_field(2, uav={"altitude": 10000}))
    msgs = [f.message for f in diagnose(high).findings if f.kind == "UNREACHABLE"]
    assert len(msgs) == 2 and "even overhead the link rate R_c - xi H = 10 - 0.01 x 10000 m " \
        "is -90 Mbit/s <= 0 (radio.peak_rate, radio.decay, uav.altitude)" in msgs[0]
    deep = dense_field(1, size=5000.0, obstacles={"no_fly_zones": [{"vertices": [
        [500, 500], [4500, 500], [4500, 4500], [500, 4500]]}]})
    deep["start"], deep["end"] = [100, 100], [4900, 4900]
    msgs = [f.message for f in diagnose(load_map(deep)).findings if f.kind == "UNREACHABLE"]
    reach = math.sqrt((10 / 0.01) ** 2 - 100**2)  # R_c / xi slant, H 100 m: 995 m
    assert len(msgs) == 1 and f"beyond the link's ground reach of {reach:.1f} m" in msgs[0]
    path = tmp_path / "high.json"
    path.write_text(json.dumps(dense_field(2, uav={"altitude": 10000})))
    r = run_cli("check", path)
    assert r.returncode == 1
    assert r.stdout.splitlines()[0] == \
        "map 'dense-field': valid, but no plan can meet it (CANNOT below)"


def test_sensors_spread_beyond_twice_the_reach_need_a_point_each(tmp_path) -> None:
    # a hover point hears only sensors within the ground reach r (995 m at the defaults), so
    # sensors pairwise more than 2 r apart need a point each: 50 sensors on a 30 km map hold
    # 42 such (greedy), more than the default I_max 25: CANNOT before any planning (the plan
    # used to run its whole budget, ~66 s, and end infeasible)
    from planner_core.model.diagnose import spread_sensors
    from planner_core.model.formulas import ground_reach

    rng = np.random.default_rng(0)
    xy = rng.uniform(0.0, 30000.0, (50, 2))
    m = load_map({"name": "spread", "area": {"width": 30000, "height": 30000},
                  "start": [100, 100], "end": [29900, 29900],
                  "sensors": [{"id": f"s{k}", "x": float(x), "y": float(y)}
                              for k, (x, y) in enumerate(xy)]})  # fmt: skip
    reach = float(ground_reach(0.0, 100.0, 10.0, 0.01))
    kept = spread_sensors(xy, np.ones(50), reach)
    d = np.hypot(*(xy[kept][:, None] - xy[kept][None, :]).transpose(2, 0, 1))
    assert len(kept) == 42 and np.all(d[np.triu_indices(len(kept), 1)] > 2 * reach)
    found = [f for f in diagnose(m).findings if f.kind == "SPREAD"]
    assert len(found) == 1 and found[0].fatal
    assert found[0].message.startswith("sensors: at least 42 hover points are needed")
    assert spread_sensors(xy, np.where(np.arange(50) < 10, 1.0, 0.0), reach) == \
        spread_sensors(xy[:10], np.ones(10), reach)  # sensors needing nothing left out


@pytest.mark.parametrize("path", sorted(SUITE.glob("T*.json")) + sorted(MAPS.glob("*.json"))
                         + sorted((MAPS / "large").glob("L*.json")), ids=lambda p: p.stem)
def test_no_shipped_map_is_too_spread(path) -> None:
    if path.name.endswith("_best_known.json") or path.name.endswith("_lower_bounds.json"):
        pytest.skip("not a map")
    from planner_core.model.diagnose import spread_sensors
    from planner_core.model.formulas import ground_reach

    pm = load_map(path).planning_map()
    s = pm.spec
    reach = float(ground_reach(0.0, s.uav.altitude, s.radio.peak_rate, s.radio.decay))
    assert len(spread_sensors(pm.sensors, pm.required_data, reach)) <= pm.max_hover_points


def test_the_inside_notes_name_every_obstacle_holding_a_sensor_in_map_order() -> None:
    """`diagnose` finds the obstacles holding each sensor in one tree query (one shapely call
    per sensor and obstacle was most of its time on maps of a thousand obstacles): the same
    notes as that pairwise test, every obstacle named in the map's order (a sensor in a
    circle and the rectangle over it names both), none for a sensor in a polygon's hole or on
    an edge, and the distance and rate the same as one `distance` call per sensor."""
    from shapely.geometry import Point

    from planner_core.model.diagnose import _airspace
    from planner_core.model.mapio import _obstacle_polygons

    hole = [[450, 450], [550, 450], [550, 550], [450, 550]]
    m = load_map({
        "name": "inside", "area": {"width": 2000, "height": 2000},
        "start": [20, 20], "end": [1980, 1980],
        "sensors": [{"id": "both", "x": 1200, "y": 1200}, {"id": "hole", "x": 500, "y": 500},
                    {"id": "edge", "x": 300, "y": 500}, {"id": "zone", "x": 400, "y": 500},
                    {"id": "free", "x": 1700, "y": 300}, {"id": "circle", "x": 1500, "y": 1500}],
        "obstacles": {
            "circles": [{"x": 1500, "y": 1500, "radius": 80}, {"x": 1200, "y": 1200, "radius": 50}],
            "rectangles": [{"x": 1200, "y": 1200, "length": 300, "width": 60}],
            "polygons": [{"vertices": [[300, 300], [700, 300], [700, 700], [300, 700]],
                          "holes": [hole]}],
        },
        "safety": {"clearance": 10},
    })  # fmt: skip
    d = diagnose(m)
    inside = {f.sensor: f.message for f in d.findings if f.kind == "INSIDE"}
    assert sorted(inside) == ["both", "circle", "zone"]
    assert "lies inside circle 1, rectangle 0:" in inside["both"]
    assert "lies inside circle 0:" in inside["circle"] and "polygon 0:" in inside["zone"]
    # pairwise, as it was: every sensor against every obstacle, one distance call each
    real, pm = _obstacle_polygons(m), m.planning_map()
    reach = min(_airspace(pm), key=lambda g: g.distance(Point(*pm.start)))
    for sid, s in zip(pm.sensor_ids, pm.sensors, strict=True):
        p = Point(*s)
        named = [m.obstacle_labels[k] for k, g in enumerate(real) if g.contains(p)]
        assert (sid in inside) == bool(named)
        if named:
            dist = float(reach.distance(p))
            assert f"lies inside {', '.join(named)}: it can only be served from outside, " \
                   f"{dist:.1f} m away at best ({d.best_rate[sid]:.3g} Mbit/s)" in inside[sid]


def test_inside_notes_name_the_shape_as_verify_does() -> None:
    """A reviewer's sensor in the barn: check said "inside polygon 0" and "inside no-fly-zone
    1" where verify says "polygon 0 'barn'" and the zone is named 'range': one wording
    (`defaults.obstacle_label`, the sim's `Obstacle.label` too)."""
    m = load_map({
        "name": "farm", "area": {"width": 2000, "height": 1500},
        "start": [50, 50], "end": [50, 80],
        "sensors": [{"id": "soil-1", "x": 700, "y": 700}, {"id": "soil-2", "x": 1500, "y": 400},
                    {"id": "pump", "x": 1000, "y": 700}],
        "obstacles": {
            "rectangles": [{"x": 1000, "y": 500, "length": 200, "width": 80, "angle_deg": 15}],
            "polygons": [{"name": "barn", "vertices": [[600, 600], [750, 600], [750, 750],
                                                      [650, 750], [650, 800], [600, 800]]}],
            "no_fly_zones": [
                {"vertices": [[1200, 900], [1500, 900], [1500, 1100], [1200, 1100]]},
                {"name": "range", "vertices": [[1300, 150], [2000, 150], [2000, 1500],
                                               [1300, 1500]]}],
        },
    })  # fmt: skip
    inside = {f.sensor: f.message for f in diagnose(m).findings if f.kind == "INSIDE"}
    assert inside["soil-1"].startswith("sensor 'soil-1' lies inside polygon 0 'barn': it can ")
    assert inside["soil-2"].startswith("sensor 'soil-2' lies inside no-fly-zone 1 'range': ")


def test_a_cannot_sensor_gets_no_inside_note_saying_how_it_can_be_served(tmp_path) -> None:
    """A reviewer's sensor deep in a no-fly zone: a note "can only be served from outside,
    1510.1 m away at best (0 Mbit/s)" beside a CANNOT for it; now the CANNOT alone, saying
    where the sensor lies."""
    doc = {"name": "deep", "area": {"width": 5000, "height": 5000},
           "start": [100, 100], "end": [200, 100],
           "sensors": [{"id": "ok", "x": 500, "y": 500}, {"id": "buried", "x": 2500, "y": 2500},
                       {"id": "edge", "x": 1050, "y": 2500}],
           "obstacles": {"no_fly_zones": [{"name": "range", "vertices": [
               [1000, 1000], [4000, 1000], [4000, 4000], [1000, 4000]]}]}}  # fmt: skip
    d = diagnose(load_map(doc))
    about = [(f.kind, f.fatal, f.message) for f in d.findings if f.sensor == "buried"]
    assert about == [("UNREACHABLE", True, (
        "sensor 'buried': no reachable hover point gets any data from it: the nearest "
        "reachable hover point is 1510.1 m away, beyond the link's ground reach of 995.0 m "
        "(rate 0); it lies inside no-fly-zone 0 'range'"))]
    # a sensor in the zone that can be served keeps its note
    assert [f.kind for f in d.findings if f.sensor == "edge"] == ["INSIDE"]
    path = tmp_path / "deep.json"
    path.write_text(json.dumps(doc))
    r = run_cli("check", path)
    assert r.returncode == 1
    lines = [ln for ln in r.stdout.splitlines() if "'buried'" in ln]
    assert len(lines) == 1 and lines[0].startswith("  CANNOT  sensor 'buried'"), r.stdout


def test_check_prints_large_figures_in_plain_digits(tmp_path) -> None:
    """A 90,000 Wh battery: check printed "90000 Wh = 9e+04 Wh ... 7.2e+04 Wh usable ...
    (2.56e+04 min of hover ...)"; numbers are plain digits (`defaults.number_text`), as are
    the findings' (`planner_core.model.diagnose`)."""
    doc = {"name": "big", "area": {"width": 2000, "height": 1500}, "start": [50, 50],
           "end": [50, 80], "sensors": [{"id": "a", "x": 700, "y": 700}],
           "uav": {"battery": {"energy_wh": 90000}}}  # fmt: skip
    path = tmp_path / "big.json"
    path.write_text(json.dumps(doc))
    r = run_cli("check", path)
    assert r.returncode == 0, r.stderr
    (line,) = [ln for ln in r.stdout.splitlines() if ln.startswith("  battery")]
    assert line.startswith("  battery         90000 Wh, reserve 20 %: 72000 Wh usable per "
                           "sortie (25600 min of hover at P(0) "), line
    assert "e+" not in r.stdout
    # the findings too: 1e6 Mbit asked of one sensor ("needs 1.02e+06 Mbit ... at most
    # 3.24e+04 Mbit" before)
    far = {"name": "far", "area": {"width": 30000, "height": 30000}, "start": [50, 50],
           "end": [50, 80], "sensors": [{"id": "a", "x": 29000, "y": 29000,
                                         "required_data": 1_000_000}],
           "uav": {"battery": {"energy_wh": 20}, "max_hover_time": 3600}}  # fmt: skip
    said = " | ".join(f.message for f in diagnose(load_map(far)).findings)
    assert "sensor 'a' needs 1020000 Mbit (required 1000000 plus the data margin); one hover " \
           "point collects at most 32400 Mbit (T_max 3600 s x 9 Mbit/s)" in said, said
    assert "e+" not in said, said
