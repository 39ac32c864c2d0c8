"""`verify` as a field engineer editing a mission by hand reads it (review of s60): a mission
without its LAND item fails ENDS (it holds at its last stop until a failsafe); one without its
TAKEOFF item passes with the take-off said to be assumed (ArduCopter would not start it on the
ground, PX4 climbs first); C5 and CLEAR name the hover points and legs at fault by item; a
mission verified on a map whose area lies far away says so first.

(Per-sortie lines of `verify MAP DIR/`: tests/test_sorties_dir.py.)
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from lamde_mission.cli import main
from lamde_mission.formats.qgc_plan import write_qgc_plan
from lamde_mission.geo import enu_to_latlon
from lamde_mission.items import CMD, plan_to_items
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from sim import replay, verify
from sim.checks import NAMED_OFFENDERS
from tests.test_sim import MAP as SIM_MAP

MAP = {  # test_sim's map (its area, ends and sensors) with two named buildings
    **SIM_MAP,
    "name": "review",
    "origin": {"lat": 46.2, "lon": 7.3, "alt": 0.0},
    "obstacles": {
        "polygons": [
            {"name": "court", "vertices": [[100, 500], [400, 500], [400, 800], [100, 800]]},
            {"name": "annex", "vertices": [[650, 900], [750, 900], [750, 1050], [650, 1050]]},
        ],
    },
    "uav": {"max_hover_points": 5},
    "radio": {"bandwidth": 25},
}
HOVER = [[300, 120], [1000, 980], [1700, 1480]]
TIMES = [40.0, 30.0, 35.0]


@pytest.fixture(scope="module")
def m():
    return load_map(MAP)


def _items(m, hover=HOVER, times=TIMES):
    p = Problem(m)
    b = p.breakdown(p.encode(hover, times))
    plan = SimpleNamespace(hover_points=np.array(b["hover_points"]),
                           hover_times=np.array(b["hover_times"]))  # fmt: skip
    return plan_to_items(plan, m)


def _renumbered(items):
    return [replace(it, seq=k) for k, it in enumerate(items)]


def _write(path, items, m):
    home = (m.spec.origin.lat, m.spec.origin.lon, 0.0)
    return write_qgc_plan(path, items, home=home, cruise_speed=20.0)


def _verify_cli(capsys, map_path, mission, *more):
    rc = main(["verify", str(map_path), str(mission), *more])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


@pytest.fixture(scope="module")
def map_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("review") / "review.json"
    path.write_text(json.dumps(MAP))
    return path


# ------------------------------------------------------------------------------------ A: ENDS


def test_a_mission_without_land_fails_ends(m):
    items = _items(m)
    assert items[-1].command == CMD.LAND
    v = verify(replay(items, m), m)
    assert v.passed
    cut = items[:-1]  # the LAND item deleted, as in QGroundControl
    v = verify(replay(cut, m), m)
    assert v.failed == ["ENDS"], v.table()
    ends = v["ENDS"]
    assert ends.margin == -math.inf  # no finite slack: it never comes down
    assert ends.detail.startswith("the mission does not land (no LAND or RETURN_TO_LAUNCH item)")
    assert f"its last stop, item {cut[-1].seq}" in ends.detail
    assert json.loads(json.dumps(v.to_dict()))["verdicts"][7]["margin"] is None


def test_a_mission_without_takeoff_says_the_take_off_is_assumed(m, map_path, tmp_path, capsys):
    items = _items(m)
    assert items[0].command == CMD.TAKEOFF
    tl = replay(_renumbered(items[1:]), m)
    v = verify(tl, m)
    assert v.passed  # PX4 flies it (it climbs first); ArduCopter refuses it, never flies it
    assert "no TAKEOFF item: take-off assumed at the start" in v["ENDS"].detail
    (note,) = [n for n in tl.notes if n.startswith("no TAKEOFF item")]
    assert "ArduCopter will not start this mission on the ground" in note and "PX4" in note
    rc, out, err = _verify_cli(capsys, map_path, _write(tmp_path / "no-takeoff.plan",
                                                        _renumbered(items[1:]), m))
    assert rc == 0 and "ArduCopter" in err
    (line,) = [ln for ln in out.splitlines() if ln.startswith("mission time")]
    assert "take-off " in line and "s assumed (no TAKEOFF item), landing " in line, line
    # neither item: ENDS fails; the summary has no landing
    rc, out, err = _verify_cli(capsys, map_path, _write(tmp_path / "neither.plan",
                                                        _renumbered(items[1:-1]), m))
    assert rc == 1 and "result: FAILED ENDS" in out, out
    (line,) = [ln for ln in out.splitlines() if ln.startswith("mission time")]
    assert "assumed (no TAKEOFF item), no landing (it holds at its last stop)" in line, line


# ------------------------------------------------------------------------------ B: C5, CLEAR


def test_c5_and_clear_name_the_hover_point_and_legs_at_fault(m, map_path, tmp_path, capsys):
    items = _items(m)
    assert [it.seq for it in items if it.command == CMD.LOITER_TIME] == [2, 3, 4]
    lat, lon = enu_to_latlon(250.0, 750.0, m)  # hover point 2 moved into 'court'
    items[3] = replace(items[3], x=float(lat), y=float(lon))
    v = verify(replay(items, m), m)
    assert "C5" in v.failed and "CLEAR" in v.failed
    c5 = v["C5"].detail
    assert c5.startswith("path inside obstacles for ")
    hold = f"{items[3].param1:.6g}"
    assert f"hover point 2 (item 3) inside polygon 0 'court' for {hold} s" in c5, c5
    legs = c5.split("; legs crossing: ")[1]
    # both legs at item 3 cross 'court'; the one leaving it crosses 'annex' too
    assert "item 2 -> item 3 (" in legs and "item 3 -> item 4 (" in legs, legs
    assert "polygon 1 'annex'" in legs.split("item 3 -> item 4 (")[1], legs
    assert "\n" not in c5 and "more" not in c5
    assert "on the leg item 2 -> item 3 " in v["CLEAR"].detail, v["CLEAR"].detail
    rc, out, _ = _verify_cli(capsys, map_path, _write(tmp_path / "court.plan", items, m),
                             "--json")
    (c5_json,) = [x for x in json.loads(out)["verdicts"] if x["name"] == "C5"]
    assert rc == 1 and c5_json["detail"] == c5


def test_c5_names_a_few_offenders_then_counts_the_rest(m):
    inside = [[150, 550], [200, 600], [250, 650], [300, 700], [350, 750]]  # all in 'court'
    items = _items(m, inside, [20.0] * 5)
    v = verify(replay(items, m), m)
    c5 = v["C5"].detail
    n = len(inside)
    assert c5.count(" inside polygon 0 'court' for ") == NAMED_OFFENDERS
    assert f" and {n - NAMED_OFFENDERS} more; legs crossing: " in c5, c5
    # legs: take-off -> 1st, four between, last -> the LAND leg out of it: 6 cross 'court'
    assert c5.endswith(f" and {n + 1 - NAMED_OFFENDERS} more"), c5


def test_clear_names_the_nearest_leg_on_a_passing_mission(m):
    v = verify(replay(_items(m), m), m)
    assert v["CLEAR"].passed and " on the leg item " in v["CLEAR"].detail


# ------------------------------------------------------------------------- D: the wrong map


def test_a_mission_far_from_the_maps_area_says_so_first(m, tmp_path, capsys):
    items = _items(m)
    far_map = {**MAP, "origin": {"lat": 47.2, "lon": 7.3, "alt": 0.0}}  # 111 km north
    mf = load_map(far_map)
    tl = replay(items, mf)
    assert tl.notes[0].startswith("the mission lies 10") and tl.notes[0].endswith(
        " km from this map's area (origin lat 47.2, lon 7.3): the wrong map, or another "
        "origin? (the figures below are measured that far away, on a projection made for this "
        "map: they mean nothing)"), tl.notes
    v = verify(tl, mf)
    assert "C1" in v.failed and "ENDS" in v.failed  # the verdicts are kept
    assert not any("km from this map" in n for n in replay(items, m).notes)
    path = tmp_path / "far.json"
    path.write_text(json.dumps(far_map))
    rc, out, err = _verify_cli(capsys, path, _write(tmp_path / "m.plan", items, m))
    assert rc == 1 and err.splitlines()[0].startswith("note: ")
    assert "the mission lies " in err.splitlines()[0], err
    assert out.splitlines()[0].startswith("mission ")


def test_a_mission_just_outside_the_area_gets_no_wrong_map_note(m):
    items = _items(m)
    lat, lon = enu_to_latlon(-1500.0, 980.0, m)  # 1.5 km west: less than the area's 2 km
    items[3] = replace(items[3], x=float(lat), y=float(lon))
    tl = replay(items, m)
    assert not any("km from this map" in n for n in tl.notes), tl.notes
    assert "C1" in verify(tl, m).failed


def test_a_clear_pass_beside_a_negative_margin_says_why(tmp_path, capsys):
    """A reviewer: the start 2 cm outside a circle, and CLEAR printed PASS beside a margin of
    -0.00125 m with nothing saying why. A stored mission may pass up to `CLEAR_TOL` inside the
    clearance (its positions lie on the 1e-7 degree grid); the row now says so."""
    from sim.checks import CLEAR_TOL
    from tests.test_strict_inputs import TINY

    doc = json.loads(TINY.read_text())
    doc["start"] = [670.02, 600.0]  # the circle (600, 600) r 70: 2 cm outside it
    path, mission = tmp_path / "near.json", tmp_path / "near.plan"
    path.write_text(json.dumps(doc))
    assert main(["plan", str(path), "-o", str(mission), "--budget", "2000", "--quiet"]) == 0
    capsys.readouterr()
    assert main(["verify", str(path), str(mission)]) == 0
    row = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("CLEAR"))
    margin = float(row.split("PASS")[1].split()[0])
    assert -CLEAR_TOL <= margin < 0.0, row
    assert row.endswith(f"; within the {100 * CLEAR_TOL:g} cm a stored mission may pass inside "
                        "it (positions on the 1e-7 degree grid)")
