"""The sim: replay mission items with the paper's model and verify C1..C5 independently."""

from __future__ import annotations

import ast
import json
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from lamde_mission.formats import read_mission, write_mission
from lamde_mission.geo import enu_to_latlon
from lamde_mission.items import CMD, plan_to_items
from planner_core.model.formulas import flight_time
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from sim import replay, verify
from sim.checks import ENDS_TOL
from sim.replay import PHASES, _Recorder, leg_position, leg_time
from tests.conftest import ROOT, SUITE

MAP = {
    "name": "sim",
    "origin": {"lat": 22.3193, "lon": 114.1694, "alt": 0.0},
    "area": {"width": 2000, "height": 2000},
    "start": [0, 0],
    "end": [1900, 1800],
    "sensors": [
        {"id": "a", "x": 300, "y": 100},
        {"id": "b", "x": 1000, "y": 1000, "required_data": 150},
        {"id": "c", "x": 1700, "y": 1500},
    ],
    "obstacles": {
        "circles": [{"x": 600, "y": 1400, "radius": 90}],
        "rectangles": [{"x": 1500, "y": 500, "length": 180, "width": 100, "angle_deg": 25}],
        "no_fly_zones": [{"vertices": [[200, 700], [500, 650], [450, 1000]]}],
    },
    "uav": {"max_hover_points": 5},
    "radio": {"bandwidth": 25},
}
HOVER = [[300, 120], [1000, 980], [1700, 1480]]
TIMES = [40.0, 30.0, 35.0]


def _plan(m, hover, times):
    p = Problem(m)
    b = p.breakdown(p.encode(hover, times))
    return SimpleNamespace(hover_points=np.array(b["hover_points"]),
                           hover_times=np.array(b["hover_times"]), f=b["f"], phi=b["phi"],
                           feasible=b["phi"] == 0, breakdown=b)  # fmt: skip


@pytest.fixture(scope="module")
def m():
    return load_map(MAP)


def _rel(a, b):
    return abs(a - b) / max(abs(b), 1e-12)


def _agrees(tl, b, tol):
    t = tl.totals
    assert _rel(t.t_fly, b["t_fly"]) < tol
    assert _rel(t.t_hover, b["t_hover"]) < tol
    assert _rel(t.f, b["f"]) < tol
    for k, q in b["collected"].items():
        assert abs(t.collected[k] - q) <= tol * max(abs(q), 1.0)


# ----------------------------------------------------------------------------- motion model


@pytest.mark.parametrize("d", [0.0, 1e-3, 10.0, 99.9, 100.0, 100.1, 500.0, 12_345.0])
def test_leg_time_is_eq_1(d):
    v, a = 20.0, 4.0  # v^2 / a = 100 m
    assert leg_time(d, v, a) == pytest.approx(float(flight_time(np.array(d), v, a)), rel=1e-15)


@pytest.mark.parametrize("d", [30.0, 100.0, 800.0])
def test_leg_position_profile(d):
    v, a = 20.0, 4.0
    total = leg_time(d, v, a)
    t = np.linspace(0.0, total, 2001)
    s = leg_position(t, d, v, a)
    assert s[0] == 0.0 and s[-1] == pytest.approx(d, abs=1e-9)
    assert np.all(np.diff(s) >= -1e-12)  # never goes backwards
    speed = np.diff(s) / np.diff(t)
    assert speed.max() <= v + 1e-6  # never above v_max
    accel = np.diff(speed) / np.diff(t[:-1])
    assert np.abs(accel).max() <= a * 1.01 + 1e-6  # never above a (finite differences)


# ----------------------------------------------------------------------------- replay


def test_replay_matches_the_model_and_the_timeline_is_consistent(m):
    plan = _plan(m, HOVER, TIMES)
    tl = replay(plan_to_items(plan, m), m, dt=0.5)
    _agrees(tl, plan.breakdown, 1e-9)
    np.testing.assert_allclose(tl.leg_times[:-1], plan.breakdown["leg_times"], rtol=1e-9)
    assert tl.leg_times[-1] == 0.0  # WAYPOINT and LAND at the same end point
    assert np.all(np.diff(tl.t) >= 0)
    assert tl.t[-1] == pytest.approx(tl.totals.t_total)
    assert tl.totals.t_total == pytest.approx(
        tl.totals.t_takeoff + tl.totals.t_fly + tl.totals.t_hover + tl.totals.t_land
    )
    # vertical phases at the climb (2.5 m/s) and descent (1 m/s) speeds, not v_max (20 m/s):
    # 100 / 2.5 + 2.5 / 4 and 100 / 1 + 1 / 4 seconds
    assert tl.totals.t_takeoff == pytest.approx(40.625)
    assert tl.totals.t_land == pytest.approx(100.25)
    phases = [p for k, p in enumerate(tl.phase) if k == 0 or p != tl.phase[k - 1]]
    assert phases == ["takeoff", "fly", "hover", "fly", "hover", "fly", "hover", "fly", "land"]
    assert np.all(np.diff(tl.data, axis=0) >= -1e-12)  # data only accumulates
    fly = np.array([p == "fly" for p in tl.phase])
    for j in range(3):  # nothing collected while flying: constant within each flying stretch
        seg_starts = np.flatnonzero(np.diff(np.r_[False, fly].astype(int)) == 1)
        for s0 in seg_starts:
            s1 = s0
            while s1 + 1 < len(fly) and fly[s1 + 1]:
                s1 += 1
            assert tl.data[s0, j] == tl.data[s1, j]
    np.testing.assert_allclose(tl.collected, list(plan.breakdown["collected"].values()),
                               rtol=1e-9)  # fmt: skip
    assert tl.z.max() == pytest.approx(100.0) and tl.z[0] == 0.0 and tl.z[-1] == 0.0
    np.testing.assert_allclose(tl.xy[-1], [1900, 1800], atol=1e-6)


def test_replay_rtl_flies_back_outside_f(m):
    plan = _plan(m, HOVER, TIMES)
    tl = replay(plan_to_items(plan, m, finish="rtl"), m)
    _agrees(tl, plan.breakdown, 1e-9)
    d = math.hypot(1900, 1800)
    assert tl.totals.t_return == pytest.approx(leg_time(d, 20.0, 4.0))
    assert "return" in tl.phase
    np.testing.assert_allclose(tl.xy[-1], [0, 0], atol=1e-6)


def test_every_phase_of_a_timeline_is_one_of_phases_and_a_misspelt_one_is_refused(m):
    """`sim.replay.PHASES` is the set the replay labels its samples with: an RTL mission flies
    each of them, and a phase name outside it (a typo at a call site) fails at once."""
    tl = replay(plan_to_items(_plan(m, HOVER, TIMES), m, finish="rtl"), m)
    assert set(tl.phase) == set(PHASES)
    rec = _Recorder(1, 1.0)
    t = np.zeros(1)
    with pytest.raises(ValueError, match="'hovr' is not one of"):
        rec.add("hovr", t, np.zeros((1, 2)), t, np.zeros((1, 1)))
    assert rec.phase == []


def test_mission_speed_is_flown(m):
    plan = _plan(m, HOVER, TIMES)
    slow = replay(plan_to_items(plan, m, speed=10.0), m)
    assert slow.totals.speed == 10.0 and slow.totals.t_fly > plan.breakdown["t_fly"]
    fast = replay(plan_to_items(plan, m, speed=50.0), m)
    assert fast.totals.speed == 20.0 and any("exceeds" in n for n in fast.notes)


def test_a_change_of_altitude_between_stops_is_timed_and_costed(m):
    """A stop edited up to 3,000 m: the legs to and from it take the climb and the descent at
    the vertical speeds (they cost nothing before: the same f at 60 m as at 3 km), in t_fly and
    f, and its energy is P(0) over the time the climbs add."""
    from sim.energy import SimPower, mission_energy
    from sim.replay import vertical_time

    plan = _plan(m, HOVER, TIMES)
    items = plan_to_items(plan, m)
    flat = replay(items, m)
    k = next(i for i, it in enumerate(items) if it.command == CMD.LOITER_TIME)
    h = float(items[k].z)
    high = replay([replace(it, z=3000.0) if i == k else it for i, it in enumerate(items)], m)
    a = float(m.spec.uav.acceleration)
    vu, vd = float(m.spec.uav.climb_speed), float(m.spec.uav.descent_speed)
    assert (vu, vd) == (2.5, 1.0)  # the defaults: ArduPilot's climb, PX4's descent
    up, down = vertical_time(3000.0 - h, a, vu, vd), vertical_time(h - 3000.0, a, vu, vd)
    assert up == leg_time(3000.0 - h, vu, a) and down == leg_time(3000.0 - h, vd, a)
    j = int(np.flatnonzero(high.leg_times != flat.leg_times)[0])
    assert high.leg_times[j] == pytest.approx(up) and high.leg_times[j + 1] == pytest.approx(down)
    extra = up + down - flat.leg_times[j] - flat.leg_times[j + 1]
    assert high.totals.t_fly == pytest.approx(flat.totals.t_fly + extra)
    assert high.totals.f > flat.totals.f + 1000.0  # alpha x about 3,000 s more
    assert any("changes altitude between stops" in n for n in high.notes)
    assert not any("altitude" in n for n in flat.notes)
    # the sampled flight climbs to the stop and comes down again, ending where it did
    assert high.z.max() == pytest.approx(3000.0) and high.t[-1] == pytest.approx(
        flat.t[-1] + extra)
    de = mission_energy(high, m).flight - mission_energy(flat, m).flight
    assert de == pytest.approx(SimPower.of(m).hover * extra / 3600.0)


def test_a_stop_at_or_below_the_ground_fails_alt(m):
    plan = _plan(m, HOVER, TIMES)
    items = plan_to_items(plan, m)
    k = next(i for i, it in enumerate(items) if it.command == CMD.LOITER_TIME)
    v = verify(replay(items, m), m)
    assert v["ALT"].passed and v["ALT"].margin == pytest.approx(float(m.spec.uav.altitude))
    low = [replace(it, z=-50.0) if i == k else it for i, it in enumerate(items)]
    v = verify(replay(low, m), m)
    assert "ALT" in v.failed and v["ALT"].margin == -50.0
    assert f"item {items[k].seq} at -50.00 m above home" in v["ALT"].detail


def test_mission_speeds_the_autopilots_ignore_or_that_never_end(m):
    """DO_CHANGE_SPEED <= 0 leaves the speed (PX4 and ArduPilot read it so), with a note; a
    positive speed below the map's least max_speed is refused (1e-6 m/s made a 76-year mission
    that passed every check)."""
    from sim.mission import MIN_MISSION_SPEED, MissionError

    plan = _plan(m, HOVER, TIMES)
    items = plan_to_items(plan, m, speed=10.0)
    k = next(i for i, it in enumerate(items) if it.command == CMD.DO_CHANGE_SPEED)
    ref = replay(items, m)
    for bad in (0.0, -20.0, -1.0):
        tl = replay([replace(it, param2=bad) if i == k else it for i, it in enumerate(items)], m)
        assert tl.totals.speed == float(m.spec.uav.max_speed)
        assert any("leaves the speed as it was" in n for n in tl.notes)
    assert ref.totals.speed == 10.0
    with pytest.raises(MissionError, match=r"DO_CHANGE_SPEED speed 1e-06 m/s is below 0\.1"):
        replay([replace(it, param2=1e-6) if i == k else it for i, it in enumerate(items)], m)
    assert MIN_MISSION_SPEED == 0.1


def test_a_climb_or_descent_speed_type_is_flown_as_px4_flies_it_with_a_note(m):
    """DO_CHANGE_SPEED of speed type 2 (climb) or 3 (descent): PX4's navigator takes param2 as
    the cruise speed whatever the type, ArduPilot Copter changes only its vertical speed. The
    sim flies PX4's reading (the slower, costlier one) and says both; types 0 and 1 say nothing."""
    plan = _plan(m, HOVER, TIMES)
    items = plan_to_items(plan, m, speed=10.0)
    k = next(i for i, it in enumerate(items) if it.command == CMD.DO_CHANGE_SPEED)
    assert items[k].param1 == 1.0 and not any("speed type" in n for n in replay(items, m).notes)
    for kind, name in ((2.0, "climb speed"), (3.0, "descent speed")):
        tl = replay([replace(it, param1=kind, param2=2.5) if i == k else it
                     for i, it in enumerate(items)], m)
        assert tl.totals.speed == 2.5
        assert [n for n in tl.notes if "speed type" in n] == [
            f"item {items[k].seq}: DO_CHANGE_SPEED of speed type {kind:g} ({name}) is flown "
            "as the cruise speed, as PX4 flies any speed type; ArduPilot Copter changes only "
            f"its {name} for what follows"]


def test_autocontinue_0_is_noted_once_per_item(m):
    plan = _plan(m, HOVER, TIMES)
    items = plan_to_items(plan, m)
    assert not any("autocontinue" in n for n in replay(items, m).notes)
    k = next(i for i, it in enumerate(items) if it.command == CMD.LOITER_TIME)
    tl = replay([replace(it, autocontinue=0) if i == k else it for i, it in enumerate(items)], m)
    held = [n for n in tl.notes if "autocontinue" in n]
    assert held == [f"item {items[k].seq}: autocontinue 0: PX4 holds there until told to go on "
                    "(ArduPilot ignores the flag); the sim flies on"]


def test_a_note_repeated_by_do_jump_is_made_once_with_its_count(m):
    """A DO_JUMP loop around an ignored DO_SET_SERVO: one note saying how often (24,000
    identical lines before)."""
    plan = _plan(m, HOVER, TIMES)
    items = plan_to_items(plan, m)
    k = [i for i, it in enumerate(items) if it.command == CMD.LOITER_TIME]
    servo = replace(items[k[0]], command=183, param1=1.0, param2=1500.0, x=0.0, y=0.0, z=0.0)
    jump = replace(items[k[0]], command=CMD.DO_JUMP, param1=float(items[k[0]].seq),
                   param2=2400.0, x=0.0, y=0.0, z=0.0)  # fmt: skip
    out = items[:k[0] + 1] + [servo, jump] + items[k[0] + 1:]
    out = [replace(it, seq=i) for i, it in enumerate(out)]
    tl = replay(out, m)
    servo_notes = [n for n in tl.notes if "DO_SET_SERVO" in n]
    assert servo_notes == [f"item {k[0] + 1}: MAV_CMD_DO_SET_SERVO ignored by the sim "
                           "(2,401 times: DO_JUMP repeats)"], tl.notes
    assert len(tl.notes) == len(set(tl.notes)) <= 3


# ----------------------------------------------------------------------------- verify


def test_feasible_plan_passes_every_check(m):
    plan = _plan(m, HOVER, TIMES)
    assert plan.feasible
    v = verify(replay(plan_to_items(plan, m), m), m)
    assert v.passed and v.failed == []
    assert [x.name for x in v] == ["C1", "C2", "C3", "C4", "C5", "CLEAR", "MARGIN", "ENDS", "ALT"]
    assert v["C1"].margin == pytest.approx(120.0)  # hover point 1 is 120 m from the edge
    assert v["C2"].margin == pytest.approx(30.0)
    assert v["C5"].margin > 0 and "clearance" in v["C5"].detail
    assert v["ENDS"].margin == ENDS_TOL  # the slack: >= 0 when it holds, as every margin
    assert all(x.margin >= 0 for x in v)
    table = v.table()
    for name in ("C1", "C2", "C3", "C4", "C5"):
        assert name in table
    assert "FAIL" not in table
    d = json.loads(json.dumps(v.to_dict()))  # JSON-ready, and it says what the object says
    assert d["passed"] is True and d["failed"] == []
    assert [x["name"] for x in d["verdicts"]] == ["C1", "C2", "C3", "C4", "C5", "CLEAR", "MARGIN",
                                                  "ENDS", "ALT"]
    assert d["verdicts"][0]["margin"] == pytest.approx(120.0)
    assert (d["t_fly"], d["t_hover"], d["f"]) == (v.t_fly, v.t_hover, v.f)


def test_cut_hover_time_fails_c4(m):
    items = plan_to_items(_plan(m, HOVER, TIMES), m)
    k = next(i for i, it in enumerate(items) if it.command == CMD.LOITER_TIME)
    items[k] = replace(items[k], param1=items[k].param1 / 10)
    v = verify(replay(items, m), m)
    assert not v.passed and v.failed == ["C4", "MARGIN"]  # short of data: short of margin too
    assert v["C4"].margin < 0 and "'a'" in v["C4"].detail


def test_c1_c2_c3_failures(m):
    items = plan_to_items(_plan(m, HOVER, TIMES), m)
    # C1: move hover point 2 outside the area (x = -50)
    lat, lon = enu_to_latlon(-50.0, 980.0, m)
    out = list(items)
    out[3] = replace(out[3], x=float(lat), y=float(lon))
    v = verify(replay(out, m), m)
    assert "C1" in v.failed and v["C1"].margin == pytest.approx(-50.0, abs=1e-6)
    assert "hover point 2 (item 3)" in v["C1"].detail
    # C2: a hover time above T_max
    out = list(items)
    out[2] = replace(out[2], param1=301.0)
    v = verify(replay(out, m), m)
    assert v.failed == ["C2"] and v["C2"].margin == pytest.approx(-1.0)
    # C3: a lower bandwidth than the sensors' summed rates at a hover point
    tight = load_map({**MAP, "radio": {"bandwidth": 5}})
    v = verify(replay(plan_to_items(_plan(tight, HOVER, TIMES), tight), tight), tight)
    assert "C3" in v.failed and v["C3"].margin < 0


def test_c5_overlap_matches_the_planner_within_circle_resolution(m):
    # straight through the circle (600, 1400, r 90) and the no-fly zone
    hover = [[600, 1300], [600, 1500], [300, 800]]
    plan = _plan(m, hover, [10.0, 10.0, 10.0])
    assert plan.breakdown["l_vio"] > 0
    v = verify(replay(plan_to_items(plan, m), m), m)
    assert "C5" in v.failed
    assert -v["C5"].margin == pytest.approx(plan.breakdown["l_vio"], rel=1e-4)
    assert "circle 0" in v["C5"].detail and "no-fly-zone 0" in v["C5"].detail


def test_rtl_return_leg_is_checked_for_collisions():
    data = {**MAP, "start": [0, 1400], "end": [1200, 1400],
            "sensors": [{"id": "a", "x": 900, "y": 1200}]}  # fmt: skip
    mm = load_map(data)
    plan = _plan(mm, [[900, 1200]], [30.0])
    assert verify(replay(plan_to_items(plan, mm), mm), mm).passed
    v = verify(replay(plan_to_items(plan, mm, finish="rtl"), mm), mm)
    assert v.failed == ["C5", "CLEAR"] and "RTL" in v["C5"].detail


def test_ends_check(m):
    items = plan_to_items(_plan(m, HOVER, TIMES), m)
    lat, lon = enu_to_latlon(1000.0, 1800.0, m)
    out = [*items[:-2], replace(items[-2], x=float(lat), y=float(lon)),
           replace(items[-1], x=float(lat), y=float(lon))]  # fmt: skip
    v = verify(replay(out, m), m)
    assert "ENDS" in v.failed and v["ENDS"].margin == pytest.approx(ENDS_TOL - 900.0)
    assert "m from start" in v["ENDS"].detail and "900.000 m from end" in v["ENDS"].detail
    # a sortie's start and end are its depots' pads: the detail says so (a re-review read
    # "take-off 2475.882 m from start" on a sortie that leaves a depot)
    named = verify(replay(out, m), m, end_names=("its pad at 'home'", "its pad at 'north'"))
    assert named["ENDS"].margin == v["ENDS"].margin
    assert "from its pad at 'home'" in named["ENDS"].detail
    assert "900.000 m from its pad at 'north'" in named["ENDS"].detail


def test_sim_does_not_import_the_optimiser():
    """The sim is a second opinion: from planner_core it may use the map loader and the
    import-free defaults table (the overlap tolerance it shares with the planner) only."""
    paths = [*(ROOT / "sim").glob("*.py"), ROOT / "lamde_mission" / "items.py",
             ROOT / "lamde_mission" / "geo.py"]  # fmt: skip
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                if name == "planner_core" or name.startswith("planner_core."):
                    allowed = ("planner_core.model.mapio", "planner_core.defaults")
                    assert name in allowed, f"{path.name} imports {name}"


# ----------------------------------------------------------------------------- suite


@pytest.fixture(scope="module")
def suite_maps():
    files = sorted(SUITE.glob("T*.json"))
    if files:
        return {p.stem: load_map(p) for p in files}
    from planner_core.suite import suite_maps as generate  # the files are not written yet

    return {name: load_map(d) for name, d in generate().items()}


def test_suite_witnesses_agree_with_the_model_and_pass(suite_maps, tmp_path):
    assert len(suite_maps) == 16
    for k, (name, mm) in enumerate(sorted(suite_maps.items())):
        w = mm.spec.witness
        assert w is not None, name
        plan = _plan(mm, w.hover_points, w.hover_times)
        items = plan_to_items(plan, mm)
        tol = 1e-6
        if k in (0, 15):  # through the files for the smallest and the largest map
            for suffix in (".plan", ".waypoints"):
                path = tmp_path / f"{name}{suffix}"
                items, _ = read_mission(write_mission(path, plan, mm, autopilot="px4"))
            tol = 1e-4  # the file holds the storable plan: points on the 1e-7 degree grid
        tl = replay(items, mm)
        _agrees(tl, plan.breakdown, tol)
        v = verify(tl, mm)
        assert v.passed, f"{name}:\n{v.table()}"
        # the same mission with one hover time cut fails C4
        cut = list(items)
        i = next(i for i, it in enumerate(cut) if it.command == CMD.LOITER_TIME)
        cut[i] = replace(cut[i], param1=0.0)
        v = verify(replay(cut, mm), mm)
        assert "C4" in v.failed, f"{name}:\n{v.table()}"
