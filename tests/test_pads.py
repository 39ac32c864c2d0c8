"""Each vehicle's own pad at each depot (planner_core.model.pads; issue 33's fleets): the
layout, the planner's allowance for flying from a pad, and what the files say."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from planner_core.fleet.model import FleetPlan, FleetSettings, Sortie
from planner_core.fleet.search import on_pads
from planner_core.model.mapio import load_map
from planner_core.model.pads import MAX_RINGS, PAD_MARGIN_M, pad_layout, pad_ranks
from tests.conftest import ROOT

DEMO = ROOT / "examples" / "maps" / "fleet-demo.json"


def _every_pair_apart(pads: np.ndarray) -> float:
    flat = pads.reshape(-1, 2)
    d = np.hypot(*(flat[:, None, :] - flat[None, :, :]).transpose(2, 0, 1))
    return float(d[~np.eye(len(flat), dtype=bool)].min())


@pytest.mark.parametrize("vehicles", [1, 2, 3, 7, 20])
def test_pads_keep_the_spacing_and_vehicle_1_keeps_the_depot(vehicles):
    rng = np.random.default_rng(vehicles)
    depots = rng.uniform(0, 2000, size=(3, 2))
    depots[1] = depots[0] + [50.0, 0.0]  # two depots close together share their ground
    pads = pad_layout(depots, vehicles, 35.0, lambda site, p: np.ones(len(p), bool))
    assert pads.shape == (vehicles, 3, 2)
    assert np.array_equal(pads[0], depots)
    if vehicles > 1:
        extra = pads[1:].reshape(-1, 2)
        gaps = np.hypot(*(extra[:, None, :] - np.vstack([depots, extra])[None]).transpose(2, 0, 1))
        gaps[np.arange(len(extra)), len(depots) + np.arange(len(extra))] = np.inf
        assert gaps.min() >= 35.0 - 1e-9
    again = pad_layout(depots, vehicles, 35.0, lambda site, p: np.ones(len(p), bool))
    assert np.array_equal(pads, again)


def _pad_layout_reference(depots: np.ndarray, vehicles: int, spacing: float, free) -> np.ndarray:
    """`pad_layout` without listed pads, written as its rule reads: each depot in turn takes
    the first lattice spots its test frees that lie at least `spacing` from every depot and
    every pad taken before, one pair at a time."""
    from planner_core.model.pads import _lattice

    out = np.repeat(depots[None], vehicles, axis=0).astype(float)
    taken = [tuple(p) for p in depots]
    for d, site in enumerate(depots):
        cand = site + _lattice(MAX_RINGS) * spacing
        ok = free(site, cand)
        k = 1
        for c, fine in zip(cand, ok, strict=True):
            if k == vehicles:
                break
            if fine and all(float(np.hypot(c[0] - t[0], c[1] - t[1])) >= spacing - 1e-9
                            for t in taken):
                out[k, d] = c
                taken.append(tuple(c))
                k += 1
    return out


def test_pads_of_crowded_depots_are_those_the_rule_gives_pair_by_pair():
    """Depots a few spacings apart share their ground: each pad is the first free lattice spot
    clear of every pad taken before (the vectorised distance test, against the rule written
    pair by pair); a depot's test that frees only its east half is kept."""
    rng = np.random.default_rng(7)
    depots = 500.0 + rng.uniform(0, 300, size=(12, 2))
    depots = depots[np.argsort(depots[:, 0])]
    keep = [0]
    for i in range(1, len(depots)):  # depots at least the spacing apart (else refused)
        if np.hypot(*(depots[keep] - depots[i]).T).min() >= 40.0:
            keep.append(i)
    depots = depots[keep]

    def free(site, p):
        return p[:, 0] >= site[0] - 1e-9 if site[1] < 650.0 else np.ones(len(p), bool)

    got = pad_layout(depots, 30, 35.0, free)
    assert np.array_equal(got, _pad_layout_reference(depots, 30, 35.0, free))
    assert _every_pair_apart(got) >= 35.0 - 1e-9


def test_pads_skip_what_the_test_refuses_and_say_when_there_is_no_room():
    depot = np.array([[1000.0, 1000.0]])
    # refuse everything west of the depot (a building there)
    pads = pad_layout(depot, 5, 35.0, lambda site, p: p[:, 0] >= site[0])
    assert np.all(pads[1:, 0, 0] >= 1000.0)
    with pytest.raises(ValueError, match=r"depot 'yard' has room for 1 of the 3 vehicles' pads "
                                         r"\(35 m apart"):
        pad_layout(depot, 3, 35.0, lambda site, p: np.zeros(len(p), bool), names=("yard",))
    # open ground: the lattice's rings hold far more than the 100 vehicles a map may fly
    assert len(pad_layout(depot, 100, 35.0, lambda s, p: np.ones(len(p), bool))) == 100
    assert MAX_RINGS * 35.0 > 6 * 35.0


def _demo(uavs: int, **fleet) -> dict:
    doc = json.loads(DEMO.read_text())
    doc["fleet"]["uavs"] = uavs
    doc["fleet"].update(fleet)
    return doc


def test_map_pads_are_clear_of_obstacles_and_follow_the_separation():
    doc = _demo(4, separation_m=40.0)
    # a building just east of depot 'home' (at 100, 100): no pad inside it or behind it
    doc["obstacles"]["rectangles"] = [*doc["obstacles"].get("rectangles", []),
                                      {"x": 160.0, "y": 100.0, "length": 40.0, "width": 200.0,
                                       "angle_deg": 0.0}]
    m = load_map(doc)
    pads = m.vehicle_pads
    names, sites, _ = m.sortie_sites
    assert pads.shape == (4, len(names), 2) and np.array_equal(pads[0], sites)
    assert _every_pair_apart(pads) >= 40.0 + PAD_MARGIN_M - 1e-9
    pm = m.planning_map()
    from planner_core.model.geometry import overlap_lengths, points_inside

    for d in range(len(names)):
        p = pads[1:, d]
        assert not points_inside(p, pm.obstacles).any()
        assert np.all(overlap_lengths(np.broadcast_to(sites[d], p.shape), p, pm.obstacles) <= 1e-9)
    assert np.all(pads[1:, 0, 0] < 140.0)  # nothing east, beyond the building's face


def test_one_vehicle_plans_from_the_depot_with_nothing_kept_back():
    st = FleetSettings.from_map(load_map(_demo(1)))
    assert st.pads is None and st.pad_wh == 0.0
    st3 = FleetSettings.from_map(load_map(_demo(3)))
    reach = 35.0  # pads 2 and 3 at the separation + 5 m from the depot
    assert st3.pad_wh == pytest.approx(2.0 * (float(st3.leg_energies(np.array(reach)))
                                              + st3._kept_wh(1)))
    assert st3.budget_wh(4) == pytest.approx(st.budget_wh(4) - st3.pad_wh)


class _Walls:
    """A stand-in for `Links`: every leg is clear except those that touch a pad and do not go
    to or from its depot (so a sortie must fly pad -> depot corner -> points)."""

    def __init__(self, st: FleetSettings) -> None:
        self.pads = st.pads[1:].reshape(-1, 2)
        self.depots = np.asarray(st.depots)

    def clear(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        out = []
        for x, y in zip(np.asarray(a), np.asarray(b), strict=True):
            touch = any(np.allclose(x, p) or np.allclose(y, p) for p in self.pads)
            depot = any(np.allclose(x, d) or np.allclose(y, d) for d in self.depots)
            out.append(not touch or depot)
        return np.array(out)


def test_on_pads_takes_the_depot_corner_when_the_straight_leg_is_blocked_and_fits_the_battery():
    m = load_map(_demo(2))
    st = FleetSettings.from_map(m)
    rng = np.random.default_rng(5)
    vehicles = []
    for _v in range(2):
        pts = rng.uniform(150, 400, size=(3, 2))
        s = Sortie(0, 0, pts, np.zeros(3))
        spare = st.budget_wh(3) - s.energy(st)
        assert spare > 0
        # hover to the last Wh the search allows: the pads' allowance must pay for the rest
        t = spare * 3600.0 / st.hover_w / 3
        vehicles.append([Sortie(0, 0, pts, np.full(3, t))])
    plan = FleetPlan(st, vehicles)
    straight = on_pads(plan, type("Open", (), {"clear": lambda self, a, b: np.ones(len(a),
                                                                                   bool)})())
    walled = on_pads(plan, _Walls(st))
    for flown in (straight, walled):
        assert flown.settings.pad_wh == 0.0 and flown.energy_ok()
        for v, (before, after) in enumerate(zip(plan.sorties, flown.sorties, strict=True)):
            path = after.path(flown.settings)
            assert np.array_equal(path[0], st.pads[v, 0]) and np.array_equal(path[-1],
                                                                              st.pads[v, 0])
            assert after.t_hover == pytest.approx(before.t_hover)
    v1, v2 = walled.sorties
    assert len(v1.points) == 3  # vehicle 1 stands on the depot: nothing to go round
    assert len(v2.points) == 5 and np.array_equal(v2.points[0], st.depots[0])
    assert np.array_equal(v2.points[-1], st.depots[0]) and v2.times[[0, -1]].tolist() == [0, 0]
    assert len(straight.sorties[1].points) == 3


def test_a_fleet_directory_gives_each_vehicle_its_pads_in_the_files(tmp_path, capsys):
    from lamde_mission.cli import main
    from lamde_mission.formats import read_mission

    path = tmp_path / "three.json"
    path.write_text(json.dumps(_demo(3)))
    out = tmp_path / "d"
    assert main(["plan", str(path), "-o", f"{out}/"]) == 0
    said = capsys.readouterr().out
    doc = json.loads((out / "fleet.json").read_text())
    m = load_map(path)
    names, sites, _ = m.sortie_sites
    assert len(doc["vehicles"]) >= 2
    rank = pad_ranks((veh["vehicle"], d) for veh in doc["vehicles"] for s in veh["sorties"]
                     for d in (s["depot_start"], s["depot_end"]))
    for veh in doc["vehicles"]:
        v = veh["vehicle"]
        for s in veh["sorties"]:
            ends = ((s["takeoff_at"], s["depot_start"]), (s["landing_at"], s["depot_end"]))
            for at, depot in ends:
                pad = m.vehicle_pads[rank[(v, depot)], names.index(depot)]
                assert [at["x"], at["y"]] == pytest.approx(pad.tolist(), abs=0.02)
            items, _fence = read_mission(out / s["file"])
            land = [it for it in items if it.command == 21][-1]
            assert (land.x, land.y) == pytest.approx((s["landing_at"]["lat"],
                                                      s["landing_at"]["lon"]), abs=2e-7)
            if rank[(v, s["depot_start"])] > 0:
                assert f"{s['file']:<18} {s['depot_start']}, pad 35 m " in said


def test_check_and_plan_refuse_a_depot_without_room_for_the_pads(tmp_path, capsys):
    from lamde_mission.cli import main

    path = tmp_path / "far-apart.json"
    path.write_text(json.dumps(_demo(4, separation_m=1000.0)))  # 1,005 m between pads
    line = ("fleet: depot 'home' has room for 3 of the 4 vehicles' pads (1005 m apart: "
            "fleet.separation_m + 5 m; every depot holds a pad for each vehicle)")
    assert main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    assert f"CANNOT  {line}" in out and "lower fleet.separation_m" in out
    assert main(["plan", str(path), "-o", f"{tmp_path / 'd'}/"]) == 1
    err = capsys.readouterr().err
    assert line in err and err.strip().endswith("nothing written")
    assert not (tmp_path / "d").exists()


def test_upload_names_each_vehicles_pad_for_the_crew(tmp_path, capsys):
    """Two vehicles of one depot: upload says where to set each, paced from the depot, with the
    position its mission takes off from (what the vehicle is sent), not fleet.json's."""
    from lamde_mission.cli import main
    from lamde_mission.commands.upload import _print_takeoffs
    from lamde_mission.sorties import write_sortie_dir
    from tests.test_sorties_dir import _fleet_plan, _one_depot_map

    path = _one_depot_map(tmp_path, None, None)  # 2 UAVs, both from the map's start
    m, plan = _fleet_plan(path)
    d = tmp_path / "d"
    check, written = write_sortie_dir(plan, m, d)
    assert written, check.failed()
    fleet = json.loads((d / "fleet.json").read_text())
    assert len(fleet["vehicles"]) == 2
    capsys.readouterr()
    _print_takeoffs(str(d), 1)
    said = capsys.readouterr().out.splitlines()[-1]
    at = [v["sorties"][0]["takeoff_at"] for v in fleet["vehicles"]]
    assert said == (
        "set each vehicle on its own pad (sortie 1): vehicle 1 on 'home' itself (lat "
        f"{at[0]['lat']:.7f}, lon {at[0]['lon']:.7f}), vehicle 2 on 35 m E of 'home' (lat "
        f"{at[1]['lat']:.7f}, lon {at[1]['lon']:.7f})")
    assert at[1]["east_m"] == pytest.approx(35.0, abs=0.02) and at[1]["north_m"] == \
        pytest.approx(0.0, abs=0.02)
    # a hand-edited fleet.json (both told to stand on vehicle 1's spot) changes nothing said,
    # and verify's PLACES fails it
    fleet["vehicles"][1]["sorties"][0]["takeoff_at"] = dict(at[0])
    (d / "fleet.json").write_text(json.dumps(fleet))
    _print_takeoffs(str(d), 1)
    assert capsys.readouterr().out.splitlines()[-1] == said
    assert main(["verify", str(path), str(d)]) == 1
    out = capsys.readouterr().out
    assert ("fleet PLACES fleet.json's take-off and landing places are the missions': FAIL; "
            "vehicle 2 sortie 1 takes off ") in out
    assert "35.0 m from where its mission takes off" in out
    # the paced words (east_m, north_m) and the depots fleet.json names are held too
    fleet["vehicles"][1]["sorties"][0]["takeoff_at"] = dict(at[1], east_m=-35.0)
    (d / "fleet.json").write_text(json.dumps(fleet))
    assert main(["verify", str(path), str(d)]) == 1
    assert "vehicle 2 sortie 1 takes off -35 m east, 0 m north of 'home' in fleet.json, 70.0 m" \
        in capsys.readouterr().out
    fleet["vehicles"][1]["sorties"][0]["takeoff_at"] = dict(at[1])
    fleet["depots"]["ghost"] = dict(fleet["depots"]["home"])
    (d / "fleet.json").write_text(json.dumps(fleet))
    assert main(["verify", str(path), str(d)]) == 1
    assert "depot 'ghost' in fleet.json is not one of the map's" in capsys.readouterr().out
    assert '"north_m": -0.0' not in (d / "fleet.json").read_text()


def test_show_marks_each_vehicles_pad(tmp_path):
    """show/--plot: a pad beside its depot is a small square in its vehicle's colour labelled
    'v2 pad' (the reviewer found it hidden under the swap star, its legend grey as a building)."""
    from matplotlib.text import Text

    from lamde_mission.commands.show import fleet_views
    from lamde_mission.plot import fleet_figure
    from lamde_mission.sorties import write_sortie_dir
    from tests.test_sorties_dir import _fleet_plan, _one_depot_map

    m, plan = _fleet_plan(_one_depot_map(tmp_path, None, None))
    check, written = write_sortie_dir(plan, m, tmp_path / "d")
    assert written, check.failed()
    fig = fleet_figure(m, fleet_views(tmp_path / "d", m))
    texts = [t.get_text() for t in fig.findobj(Text)]
    assert "v2 pad" in texts and "v1 pad" not in texts
    assert "vN pad: vehicle N's own pad" in texts


def test_a_depot_may_list_its_pads_as_the_crew_has_them():
    doc = _demo(3)
    doc["fleet"]["depots"][0]["pads"] = [[100.0, 150.0]]  # 50 m N of 'home' (100, 100)
    m = load_map(doc)
    assert m.vehicle_pads[:, 0].tolist() == [[100.0, 100.0], [100.0, 150.0], [135.0, 100.0]]
    for pads, said in (([[100.0, 120.0]], "lies 20.0 m from depot 'home', nearer than 35 m "
                                          "(fleet.separation_m + 5 m)"),
                       # beyond the two the 3 vehicles use, still held to the rules
                       ([[100.0, 150.0], [150.0, 100.0], [100.0, 170.0]],
                        "lies 20.0 m from pad 2 at (100, 150) of depot 'home'")):
        doc["fleet"]["depots"][0]["pads"] = pads
        k = len(pads) - 1
        with pytest.raises(ValueError, match=rf"^fleet\.depots\[0\]\.pads\[{k}\]: pad {k + 2} "
                                             r"of depot 'home' at \(.*\) " + re.escape(said)):
            load_map(doc).pads_for(3)
    # one vehicle uses no pad, but a listed one that breaks the rules is still named
    one = _demo(1)
    one["fleet"]["depots"][0]["pads"] = [[100.0, 150.0], [100.0, 170.0]]
    with pytest.raises(ValueError, match=r"pads\[1\].*lies 20\.0 m from pad 2 at"):
        load_map(one).pads_for(1)


@pytest.mark.parametrize("uavs", [1, 3])
def test_a_listed_pad_outside_the_area_or_inside_an_obstacle_is_bad_input(uavs, tmp_path):
    """A position the file gives outside the area is bad input wherever it appears (exit 2,
    one line naming the field), as a depot's own is: a reviewer's pad outside the area with one
    UAV (which uses no pad) made check say CANNOT and plan refuse (exit 1), while the same
    mistake on the depot was exit 2. Inside an obstacle or no-fly zone likewise."""
    from lamde_mission.cli import main
    from planner_core.model.mapio import MapError

    doc = _demo(uavs)
    doc["fleet"]["depots"][1]["pads"] = [[1900.0, 1850.0], [2100.0, 1800.0]]
    with pytest.raises(MapError) as err:
        load_map(doc)
    assert err.value.problems == [
        "fleet.depots[1].pads[1]: the pad of depot 'north' at (2100, 1800) is outside the area "
        "[0, 2000] x [0, 2000]"]
    path = tmp_path / "pad.json"
    path.write_text(json.dumps(doc))
    assert main(["check", str(path)]) == 2
    # the no-fly zone of fleet-demo covers (1600, 500)
    doc["fleet"]["depots"][1]["pads"] = [[1600.0, 500.0]]
    with pytest.raises(MapError) as err:
        load_map(doc)
    assert err.value.problems == [
        "fleet.depots[1].pads[0]: the pad of depot 'north' at (1600, 500) lies inside "
        "no-fly-zone 0: no vehicle can stand there"]


def test_two_depots_nearer_than_the_pads_spacing_are_named():
    """A reviewer's gate 20 m from the yard: check said OK and plan failed SEPARATION (a
    vehicle standing on one depot, another landing on the other) without a reason."""
    doc = _demo(2)
    doc["fleet"]["depots"].append({"name": "gate", "x": 100.0, "y": 120.0})
    with pytest.raises(ValueError, match=r"^fleet: depots 'home' and 'gate' are 20\.0 m apart, "
                                         r"nearer than 35 m \(fleet\.separation_m \+ 5 m\)"):
        load_map(doc).pads_for(2)
    assert load_map(dict(doc, fleet=dict(doc["fleet"], uavs=1))).vehicle_pads.shape[0] == 1


def test_check_lists_the_pads(tmp_path, capsys):
    from lamde_mission.cli import main

    doc = _demo(3)
    doc["fleet"]["depots"][0]["pads"] = [[100.0, 150.0]]
    path = tmp_path / "pads.json"
    path.write_text(json.dumps(doc))
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert ("  pads            beside each depot, taken by the vehicles that use it in number "
            "order (pad 1, the first, is the depot): home: pad 2 50 m N; pad 3 35 m E | north: "
            "pad 2 35 m E; pad 3 35 m N\n") in out
    assert main(["check", str(path), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["fleet"]["pads"]
    assert got["home"] == [{"pad": 2, "x": 100.0, "y": 150.0, "east_m": 0.0, "north_m": 50.0},
                           {"pad": 3, "x": 135.0, "y": 100.0, "east_m": 35.0, "north_m": 0.0}]
    path.write_text(json.dumps(_demo(1)))
    assert main(["check", str(path)]) == 0
    assert "pads " not in capsys.readouterr().out


def test_check_names_the_first_depots_and_pads_of_a_large_fleet(tmp_path, capsys):
    """A reviewer's 91 depots and 100 UAVs made check's fleet and pads lines thousands of
    characters long (and the pads took 80 s): the lines name the first `SHOWN_SITES` depots
    and `SHOWN_PADS` pads of each, then how many more; `--json` keeps every pad."""
    from lamde_mission.cli import main
    from lamde_mission.commands.check import SHOWN_PADS, SHOWN_SITES

    doc = _demo(12)
    doc["fleet"]["depots"] = [{"name": f"d{i}", "x": 100.0 + 220.0 * i, "y": 1850.0}
                              for i in range(SHOWN_SITES + 2)]  # fmt: skip
    path = tmp_path / "many.json"
    path.write_text(json.dumps(doc))
    assert main(["check", str(path)]) == 0
    lines = {ln[:18].strip(): ln for ln in capsys.readouterr().out.splitlines()}
    assert f"d{SHOWN_SITES - 1} (1200, 1850) and 2 more, swap" in lines["fleet"]
    assert "d7 (" not in lines["fleet"]
    pads = lines["pads"]
    assert pads.count(f"; and {12 - 1 - SHOWN_PADS} more") == SHOWN_SITES
    assert pads.endswith(" | and 2 more depots' (`check --json` lists every pad)")
    assert main(["check", str(path), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["fleet"]["pads"]
    assert len(got) == SHOWN_SITES + 2 and all(len(ps) == 11 for ps in got.values())


def test_pads_are_numbered_from_1_wherever_a_person_reads_them(capsys):
    """A newcomer: docs/sorties.md said "pad 0 is the depot itself" and, on the same page,
    that listed pads are "pads 2, 3, ..."; `check` and the schema say "pad 1 ... is the
    depot". One numbering for people (the code's indices start at 0): pad 1 is the depot,
    the pads a depot lists are 2, 3, ..., in the docs, `check`, the schema and the errors."""
    from lamde_mission.cli import main
    from tests.conftest import ROOT

    page = (ROOT / "docs" / "sorties.md").read_text(encoding="utf-8")
    assert "pad 1 is the depot itself, pads 2, 3, ..." in page
    assert "(pads 2 and 3, after the depot's pad 1;" in " ".join(page.split())
    assert not re.search(r"\bpads? 0\b", page)
    assert main(["schema"]) == 0
    schema = capsys.readouterr().out
    assert "the depot's pads 2, 3, ... as the crew has them (pad 1 is the depot itself)" in schema
    assert not re.search(r"\bpads? 0\b", schema)
    doc = _demo(3)
    doc["fleet"]["depots"][0]["pads"] = [[100.0, 150.0], [100.0, 160.0]]
    with pytest.raises(ValueError, match=r"^fleet\.depots\[0\]\.pads\[1\]: pad 3 of depot "
                                         r"'home' at \(100, 160\) lies 10\.0 m from pad 2 at "):
        load_map(doc).pads_for(3)


def test_check_notes_a_separation_above_the_flight_altitude(tmp_path, capsys):
    """A reviewer's 120 m separation at 100 m altitude: check said OK and plan failed
    SEPARATION against a vehicle on the ground. check now says why it may."""
    from lamde_mission.cli import main

    path = tmp_path / "high.json"
    path.write_text(json.dumps(_demo(3, separation_m=120.0)))
    assert main(["check", str(path)]) == 0
    assert ("  note    fleet.separation_m 120 m is more than the flight altitude (uav.altitude "
            "100 m): a vehicle flying within 66 m of another standing on its pad comes nearer "
            "than that") in capsys.readouterr().out
    path.write_text(json.dumps(_demo(3, separation_m=100.0)))
    assert main(["check", str(path)]) == 0
    assert "SEPARATION" not in capsys.readouterr().out


def test_upload_refuses_vehicles_that_share_a_spot(tmp_path, capsys):
    """A directory planned before pads (two vehicles take off and land on one depot point):
    upload --fleet, even without --map, refuses it (exit 1, nothing sent) unless --force; with
    --map and a fleet.json without depots it paces the pads from the map's depots."""
    from lamde_mission.cli import main
    from lamde_mission.commands.upload import _print_takeoffs
    from lamde_mission.vehicle.mock_fleet import MockFleet
    from tests.fleet_helpers import write_fleet_dir
    from tests.vehicle_helpers import free_udp_port

    doc = _demo(2)
    doc["fleet"]["depots"] = doc["fleet"]["depots"][:1]
    path = tmp_path / "one.json"
    path.write_text(json.dumps(doc))
    # (both at the depot itself: the map's depot, so that show draws it; a depot the map
    # lacks is refused, as verify refuses it, `sorties.check_sortie_depots`)
    same = write_fleet_dir(tmp_path / "same", [[["S1"]], [["S2"]]], map_path=path,
                           own_pads=False)
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0,
                   params={"MPC_XY_VEL_MAX": 20.0}) as fleet:
        assert main(["upload", str(same), "--fleet", *conn]) == 1
        err = capsys.readouterr().err
        assert "vehicles 1 and 2 both take off or land at lat" in err
        assert err.strip().endswith("nothing sent (--force sends it anyway)")
        assert all(sum(v.stats.uploads.values()) == 0 for v in fleet.vehicles)
    # show draws it, with a note saying the same
    assert main(["show", str(path), str(same), "-o", str(tmp_path / "same.png")]) == 0
    assert "vehicles 1 and 2 both take off or land at lat" in capsys.readouterr().err
    # each on its own pad (as plan writes them), a fleet.json that gives no depots: the words
    # come from the map's depots (--map), else the depot's name alone
    own = write_fleet_dir(tmp_path / "own", [[["S1"]], [["S2"]]], map_path=path)
    assert "depots" not in json.loads((own / "fleet.json").read_text())
    _print_takeoffs(str(own), 1, str(path))
    said = capsys.readouterr().out
    assert "vehicle 1 on 'home' itself (lat" in said
    assert "vehicle 2 on 35 m E of 'home' (lat" in said
    _print_takeoffs(str(own), 1)
    assert "vehicle 2 on 'home' (lat" in capsys.readouterr().out
