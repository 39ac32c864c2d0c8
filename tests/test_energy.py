"""Issue 33, energy: the map's battery / power / fleet fields and the planner's energy model
(planner_core.model.energy) against the formula written out by hand and fine quadrature."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest
from scipy.integrate import quad

from planner_core import MapError, load_map
from planner_core.model import energy as E
from planner_core.model.formulas import flight_time
from tests.conftest import MAPS, run_cli

# Zeng, Xu, Zhang (2019) Table I, written out here on purpose (not read from the module)
P0, PI, U_TIP, V0, D0, RHO, S, A = 79.86, 88.63, 120.0, 4.03, 0.6, 1.225, 0.05, 0.503


def p_hand(v: float) -> float:
    """Zeng et al. 2019 Eq. (12), exactly as printed."""
    return (P0 * (1 + 3 * v**2 / U_TIP**2)
            + PI * math.sqrt(math.sqrt(1 + v**4 / (4 * V0**4)) - v**2 / (2 * V0**2))
            + 0.5 * D0 * RHO * S * A * v**3)  # fmt: skip


def _problems(data: dict) -> list[str]:
    with pytest.raises(MapError) as info:
        load_map(data)
    return info.value.problems


# ----------------------------------------------------------------------------- the map fields


def test_map_without_the_fields_is_unchanged(hand_map: dict) -> None:
    m = load_map(MAPS / "tiny.json")
    d = m.to_dict()
    assert "fleet" not in d and "goal" not in d["objective"]
    assert not {"battery", "endurance_s", "power"} & set(d["uav"])
    s = m.summary()
    assert not {"battery", "power", "fleet", "goal"} & set(s)
    assert not {"battery", "endurance_s", "power"} & set(s["uav"])
    assert not m.has_battery and not m.has_fleet and m.usable_energy_wh is None
    assert m.uavs == 1 and m.swap_s == 300.0 and m.goal == "total"
    assert [(dp.name, dp.x, dp.y) for dp in m.depots] == [("home", *m.spec.start)]
    assert m.power.hover_w == pytest.approx(P0 + PI, abs=1e-12)
    # the planning map (obstacles inflated) of a map without them dumps without them too
    pd = m.planning_map().to_dict()
    assert "fleet" not in pd and not {"battery", "endurance_s", "power"} & set(pd["uav"])
    assert "goal" not in pd["objective"]


def test_battery_and_fleet_read_and_round_trip(hand_map: dict) -> None:
    hand_map["uav"]["battery"] = {"energy_wh": 100.0}
    hand_map["fleet"] = {
        "uavs": 3,
        "depots": [{"name": "north", "x": 500, "y": 900}, {"name": "south", "x": 500, "y": 100}],
    }
    hand_map["objective"] = {"goal": "makespan"}
    m = load_map(hand_map)
    assert m.has_battery and m.has_fleet and m.goal == "makespan" and m.uavs == 3
    assert m.battery_wh == 100.0 and m.battery_reserve == 0.2
    assert m.usable_energy_wh == pytest.approx(80.0, rel=1e-15)
    np.testing.assert_array_equal(m.depot_xy, [[500, 900], [500, 100]])
    again = load_map(json.loads(json.dumps(m.to_dict())))
    assert again.to_dict() == m.to_dict() and again.usable_energy_wh == m.usable_energy_wh
    s = m.summary()
    assert s["battery"]["usable_wh"] == pytest.approx(80.0) and s["fleet"]["uavs"] == 3
    # endurance instead of energy: endurance_s x P(0), the reserve from uav.battery
    del hand_map["uav"]["battery"]
    hand_map["uav"]["endurance_s"] = 1500.0
    m = load_map(hand_map)
    assert m.battery_wh == pytest.approx(1500.0 * (P0 + PI) / 3600.0, rel=1e-14)
    assert m.usable_energy_wh == pytest.approx(0.8 * 1500.0 * (P0 + PI) / 3600.0, rel=1e-14)
    hand_map["uav"]["battery"] = {"reserve": 0.3}
    assert load_map(hand_map).usable_energy_wh == pytest.approx(
        0.7 * 1500.0 * (P0 + PI) / 3600.0, rel=1e-14
    )
    # the power model's parameters come from the map
    hand_map["uav"]["power"] = {"blade_profile_w": 100.0, "induced_w": 50.0}
    assert load_map(hand_map).power.hover_w == 150.0


def test_the_battery_formulas_invert_each_other() -> None:
    # plan's advice wrote the inverses out by hand (battery x 3600 / hover_w, usable /
    # (1 - reserve)); they now sit next to the forward formulas and undo them
    p = E.PowerParams(p0=100.0, pi=50.0, u_tip=U_TIP, v0=V0, d0=D0, rho=RHO, s=S, area=A)
    assert float(E.hover_endurance_s(10.0, p)) == pytest.approx(240.0, rel=1e-15)
    for s in (0.0, 1.0, 306.0, 1500.0):
        assert float(E.hover_endurance_s(E.battery_energy_wh(None, s, p), p)) == pytest.approx(
            s, rel=1e-14, abs=1e-12)
    assert E.battery_for_usable_wh(80.0, 0.2) == pytest.approx(100.0, rel=1e-15)
    for r in (0.0, 0.2, 0.9):
        assert E.usable_energy_wh(E.battery_for_usable_wh(9.36, r), r) == pytest.approx(
            9.36, rel=1e-14)


def test_energy_fields_name_the_problem(hand_map: dict) -> None:
    both = copy.deepcopy(hand_map)
    both["uav"]["battery"] = {"energy_wh": 90.0}
    both["uav"]["endurance_s"] = 1200.0
    assert _problems(both) == [
        "uav.endurance_s: the battery is given twice "
        "(uav.battery.energy_wh and uav.endurance_s): give one of them"
    ]
    none = copy.deepcopy(hand_map)
    none["uav"]["battery"] = {"reserve": 0.1}
    assert _problems(none)[0].startswith("uav.battery.energy_wh: required field is missing")
    bad = copy.deepcopy(hand_map)
    bad["uav"]["battery"] = {"energy_wh": -1.0, "reserve": 0.95}
    bad["uav"]["power"] = {"air_density": 0}
    bad["fleet"] = {"uavs": 0, "swap_s": -5}
    bad["objective"] = {"goal": "fastest"}
    lines = _problems(bad)
    for field in (
        "uav.battery.energy_wh",
        "uav.battery.reserve",
        "uav.power.air_density",
        "fleet.uavs",
        "fleet.swap_s",
        "objective.goal",
    ):
        assert sum(line.startswith(f"{field}: ") for line in lines) == 1, (field, lines)
    assert len(lines) == 6 and all("\n" not in line for line in lines)
    empty = copy.deepcopy(hand_map)
    empty["fleet"] = {"depots": []}
    assert _problems(empty)[0].startswith("fleet.depots: give at least one depot")


def test_depots_are_checked(hand_map: dict) -> None:
    hand_map["obstacles"] = {
        "circles": [{"x": 600, "y": 600, "radius": 50}],
        "no_fly_zones": [
            {"vertices": [[800, 800], [900, 800], [900, 900], [800, 900]], "name": "airfield"}
        ],
    }
    hand_map["fleet"] = {
        "depots": [
            {"name": "a", "x": 100, "y": 100},
            {"name": "a", "x": 200, "y": 100},
            {"name": "out", "x": 1200, "y": 100},
        ]
    }
    assert _problems(hand_map) == [
        "fleet.depots[1].name: duplicate depot name 'a'",
        "fleet.depots[2]: depot 'out' at (1200, 100) is outside the area [0, 1000] x [0, 1000]",
    ]
    # positions against the obstacles (checked once the map's other fields are sound)
    hand_map["fleet"] = {
        "depots": [
            {"name": "ok", "x": 100, "y": 100},
            {"name": "bldg", "x": 610, "y": 600},
            {"name": "nfz", "x": 850, "y": 850},
            {"name": "edge", "x": 650.002, "y": 600},
        ]
    }
    lines = _problems(hand_map)
    assert len(lines) == 3, lines
    assert lines[0].startswith(
        "fleet.depots[1]: depot 'bldg' at (610, 600) lies inside circle 0: no sortie can"
    )
    assert lines[1].startswith(
        "fleet.depots[2]: depot 'nfz' at (850, 850) lies inside no-fly-zone 0 'airfield': no "
    )
    assert lines[2].startswith("fleet.depots[3]: depot 'edge'")
    assert "mm from the edge of circle 0, closer than 1 cm" in lines[2]


def test_depot_near_an_obstacle_stays_outside_its_inflation(hand_map: dict) -> None:
    """The clearance stops short of a depot (as of the start and end), so the planning map,
    whose obstacles are inflated, still takes off there."""
    hand_map["obstacles"] = {"circles": [{"x": 600, "y": 600, "radius": 50}]}
    hand_map["safety"] = {"clearance": 10.0}
    hand_map["fleet"] = {"depots": [{"name": "near", "x": 655, "y": 600}]}
    m = load_map(hand_map)
    assert m.obstacle_clearances[0] == pytest.approx(5.0 - 0.05)
    pm = m.planning_map()
    assert [d.name for d in pm.depots] == ["near"]


def test_separation_is_a_fleet_field_read_and_checked(hand_map: dict, tmp_path, capsys
                                                     ) -> None:
    """fleet.separation_m (m, default 30): read by `Map.separation_m`, given back by `to_dict`
    only when the file gives it (a fleet without it dumps as before), and a bad value is one
    line naming the field, exit 2 in the command line."""
    from lamde_mission.cli import main

    assert load_map(hand_map).separation_m == 30.0  # no fleet
    hand_map["fleet"] = {"uavs": 2}
    m = load_map(hand_map)
    assert m.separation_m == 30.0 and "separation_m" not in m.to_dict()["fleet"]
    assert "separation_m" not in m.planning_map().to_dict()["fleet"]
    hand_map["fleet"]["separation_m"] = 50
    m = load_map(hand_map)
    assert m.separation_m == 50.0 and m.to_dict()["fleet"]["separation_m"] == 50.0
    assert load_map(json.loads(json.dumps(m.to_dict()))).separation_m == 50.0
    assert m.planning_map().separation_m == 50.0 and m.summary()["fleet"]["separation_m"] == 50.0
    good = tmp_path / "good.json"
    good.write_text(json.dumps(hand_map))
    assert main(["check", str(good)]) == 0
    assert "separation 50 m" in capsys.readouterr().out
    for bad in (-5, 0, 1001, "far", True, None):
        hand_map["fleet"]["separation_m"] = bad
        lines = _problems(hand_map)
        assert len(lines) == 1 and lines[0].startswith("fleet.separation_m: "), (bad, lines)
        path = tmp_path / "bad.json"
        path.write_text(json.dumps(hand_map))
        assert main(["check", str(path)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "fleet.separation_m: " in err[0], (bad, err)


def test_schema_lists_the_fields(tmp_path) -> None:
    r = run_cli("schema")
    assert r.returncode == 0, r.stderr
    defs = json.loads(r.stdout)["$defs"]
    assert {"energy_wh", "reserve"} <= set(defs["Battery"]["properties"])
    assert {"battery", "endurance_s", "power"} <= set(defs["Uav"]["properties"])
    assert defs["Power"]["properties"]["induced_w"]["default"] == PI
    assert {"uavs", "depots", "swap_s", "separation_m"} <= set(defs["Fleet"]["properties"])
    assert defs["Fleet"]["properties"]["separation_m"]["default"] == 30.0
    assert defs["Objective"]["properties"]["goal"]["default"] == "total"


# ----------------------------------------------------------------------------- the energy model


def test_power_and_hover_by_hand() -> None:
    assert E.hover_power_w() == pytest.approx(168.49, abs=1e-12)
    for v in (0.0, 1.0, 4.03, 10.0, 20.0, 35.0):
        assert float(E.power_w(v)) == pytest.approx(p_hand(v), rel=1e-13), v
    # 10 min of hover: 168.49 W x 600 s / 3600 = 28.081666... Wh
    assert float(E.hover_energy_wh(600.0)) == pytest.approx(168.49 * 600 / 3600, rel=1e-14)
    np.testing.assert_allclose(E.hover_energy_wh([0.0, 60.0, -5.0]),
                               [0.0, 168.49 / 60, 0.0], rtol=1e-14)  # fmt: skip


def _fine_profile_energy_wh(d: float, v_max: float, a: float) -> float:
    """Composite Simpson of P(v(t)) over the rest-to-rest profile, 1 ms steps, the ramps'
    ends on even nodes (the integrand's kinks), v(t) = min(a t, v_peak, a (T - t))."""
    vp = min(v_max, math.sqrt(a * d))
    t_ramp = vp / a
    total = float(flight_time(d, v_max, a))
    n = 2 * math.ceil(total / 0.002)
    t = np.linspace(0.0, total, n + 1)
    # put the kinks on nodes: snap them by splitting the integral at them
    pieces = (
        [0.0, t_ramp, total - t_ramp, total] if total > 2 * t_ramp + 1e-12 else [0.0, t_ramp, total]
    )
    out = 0.0
    for lo, hi in zip(pieces[:-1], pieces[1:], strict=False):
        k = 2 * max(math.ceil((hi - lo) / 0.002), 1)
        t = np.linspace(lo, hi, k + 1)
        v = np.minimum(np.minimum(a * t, vp), a * (total - t))
        p = np.array([p_hand(x) for x in v])
        h = (hi - lo) / k
        out += h / 3 * (p[0] + p[-1] + 4 * p[1:-1:2].sum() + 2 * p[2:-1:2].sum())
    return out / 3600.0


def test_trapezoid_leg_by_hand() -> None:
    """1 km at v_max 20 m/s, a 4 m/s^2: 5 s up (100 m over both ramps), 900 m = 45 s of
    cruise, 5 s down; E = 2 int_0^5 P(4 t) dt + 45 P(20)."""
    d, v, a = 1000.0, 20.0, 4.0
    ramp = quad(lambda t: p_hand(a * t), 0.0, v / a, epsabs=0, epsrel=1e-13)[0]
    by_hand = (2 * ramp + 45.0 * p_hand(v)) / 3600.0
    got = float(E.leg_energy_wh(d, v, a))
    assert got == pytest.approx(by_hand, rel=1e-10)
    assert got == pytest.approx(_fine_profile_energy_wh(d, v, a), rel=1e-8)
    # 55 s at 126-178 W (P(20) = 178.3 W): 2.63 Wh
    assert got == pytest.approx(2.6296, abs=1e-4)


def test_triangle_leg_by_hand() -> None:
    """50 m < v_max^2 / a = 100 m: a triangle peaking at sqrt(4 x 50) = 14.14 m/s after
    sqrt(50 / 4) = 3.54 s; E = 2 int_0^3.54 P(4 t) dt."""
    d, v, a = 50.0, 20.0, 4.0
    th = math.sqrt(d / a)
    assert 2 * th == pytest.approx(float(flight_time(d, v, a)), rel=1e-15)
    by_hand = 2 * quad(lambda t: p_hand(a * t), 0.0, th, epsabs=0, epsrel=1e-13)[0] / 3600.0
    got = float(E.leg_energy_wh(d, v, a))
    assert got == pytest.approx(by_hand, rel=1e-10)
    assert got == pytest.approx(_fine_profile_energy_wh(d, v, a), rel=1e-8)
    assert float(E.leg_energy_wh(0.0, v, a)) == 0.0 and float(E.leg_energy_wh(-3.0, v, a)) == 0


@pytest.mark.parametrize(
    ("v_max", "a", "v0"),
    [(20.0, 4.0, 4.03), (60.0, 1.0, 4.03), (15.0, 8.0, 0.7), (100.0, 2.0, 30.0)],
)
def test_leg_energy_against_fine_quadrature(v_max: float, a: float, v0: float) -> None:
    power = E.PowerParams(P0, PI, U_TIP, v0, D0, RHO, S, A)
    for d in (0.3, 40.0, v_max * v_max / a, 2500.0):
        vp = min(v_max, math.sqrt(a * d))
        cruise = max(d - v_max * v_max / a, 0.0) / v_max
        ramp = quad(lambda u: float(E.power_w(u, power)), 0.0, vp, epsabs=0,
                    epsrel=1e-13, limit=200)[0] / a  # fmt: skip
        ref = (2 * ramp + cruise * float(E.power_w(v_max, power))) / 3600.0
        assert float(E.leg_energy_wh(d, v_max, a, power)) == pytest.approx(ref, rel=1e-9), d


def test_vectorised_equals_scalar() -> None:
    d = np.array([[0.0, 3.0, 50.0], [99.999, 100.0, 100.001], [1000.0, 7321.5, -1.0]])
    vec = E.leg_energy_wh(d, 20.0, 4.0)
    assert vec.shape == d.shape
    for idx in np.ndindex(d.shape):
        assert vec[idx] == float(E.leg_energy_wh(float(d[idx]), 20.0, 4.0)), idx
    v = np.linspace(0, 40, 17).reshape(17, 1)
    np.testing.assert_array_equal(E.power_w(v)[:, 0], [float(E.power_w(x)) for x in v[:, 0]])
    # continuous where the triangle becomes a trapezoid (d = v_max^2 / a = 100 m): the
    # triangle's two ramps to sqrt(a d) = v_max are the trapezoid's with no cruise
    assert vec[1, 1] == pytest.approx(2 * float(E.ramp_energy_j(20.0, 4.0)) / 3600, rel=1e-14)
    assert vec[1, 0] < vec[1, 1] < vec[1, 2]


def test_sortie_energy_is_linear_in_hover_times(hand_map: dict) -> None:
    m = load_map(hand_map)
    u = m.spec.uav
    path = np.array([[0.0, 0.0], [300.0, 0.0], [300.0, 250.0], [0.0, 0.0]])
    legs = [300.0, 250.0, math.hypot(300.0, 250.0)]
    flight = float(E.leg_energy_wh(legs, u.max_speed, u.acceleration).sum())
    # vertical, by hand: 100 m up at 2.5 m/s with 4 m/s^2 is 100 / 2.5 + 2.5 / 4 = 40.625 s,
    # 100 m down at 1 m/s is 100.25 s (the climb and descent speeds' defaults), at P(0)
    assert (u.climb_speed, u.descent_speed) == (2.5, 1.0)
    assert E.vertical_time_s(u.altitude, 2.5, 1.0, u.acceleration) == pytest.approx(140.875)
    vertical = 140.875 * (P0 + PI) / 3600.0
    assert E.vertical_energy_wh(u.altitude, 2.5, 1.0, u.acceleration) == pytest.approx(
        vertical, rel=1e-14
    )
    # a triangle profile below v^2 / a: 0.1 m at 2.5 m/s peaks at sqrt(0.4) m/s, 2 sqrt(0.025) s
    assert E.vertical_time_s(0.1, 2.5, 2.5, 4.0) == pytest.approx(4.0 * math.sqrt(0.025))
    e0 = E.sortie_energy_wh(path, [0.0, 0.0], u, m.power)
    assert e0 == pytest.approx(flight + vertical, rel=1e-14)
    e1 = E.sortie_energy_wh(path, [50.0, 70.0], u, m.power)
    assert e1 - e0 == pytest.approx((P0 + PI) * 120.0 / 3600.0, rel=1e-12)
    assert E.sortie_energy_wh(path, [0.0, 50.0, 70.0, 0.0], u, m.power) == e1
    with pytest.raises(ValueError, match="hover_s"):
        E.sortie_energy_wh(path, [1.0], u, m.power)
    with pytest.raises(ValueError, match="path_xy"):
        E.sortie_energy_wh(path[:1], [], u, m.power)


def test_endurance_refuses_a_string_and_a_boolean(hand_map: dict) -> None:
    for bad, kind in (("1500", "a string"), (True, "a boolean")):
        hand_map["uav"]["endurance_s"] = bad
        (line,) = _problems(hand_map)
        assert line.startswith("uav.endurance_s: must be a JSON number") and kind in line
