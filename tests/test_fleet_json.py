"""fleet.json as the crew reads it, edited by hand (a newcomer's review): what it states must be
what the missions fly, or upload, verify and show say so.

1. `upload DIR/ --fleet` without `--map` printed fleet.json's take-off times as the schedule that
   keeps the vehicles apart, and sent, though fleet.json's own launch_s, durations and swap_s
   gave another time; with two vehicles' `file` swapped it told the crew to set each on a pad
   2.5 km from its depot. Now it holds fleet.json to itself and its missions
   (`FleetDir.disagreements`): exit 1, nothing sent, one line naming the field.
2. `verify MAP DIR/` said "all constraints hold" with energy_wh, duration_s or sensors edited:
   FIGURES holds them to the replays.
3. An unknown field ("colour") was read silently: refused as the map reader refuses one.
4. One mission file listed by two vehicles: exit 1 with a note about pads; now bad input.
5. `show` drew a depot the map lacks, which verify refuses: both refuse it, one check.

The directories are real plans made fast (`tests.fleet_helpers.quick_fleet_plan`) on
examples/maps/fleet-demo.json with 2 UAVs, written by `write_sortie_dir`: vehicle 1 flies one
sortie from 'home', vehicle 2 five from 'north', both launched at 0.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from lamde_mission.cli import main
from lamde_mission.formats.fleet import FleetDirError, read_fleet_dir
from lamde_mission.vehicle.mock_fleet import MockFleet
from tests.fleet_helpers import fleet_demo_map, quick_fleet_plan
from tests.vehicle_helpers import free_udp_port
from tests.vehicle_helpers import no_leftover_mock_threads as _no_leftover_mock_threads  # noqa: F401 (autouse)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """(map path, sortie directory) of fleet-demo flown by 2 UAVs, written and passing."""
    from lamde_mission.sorties import write_sortie_dir

    tmp = tmp_path_factory.mktemp("fleet-json")
    map_path = fleet_demo_map(tmp, 2)
    m, plan = quick_fleet_plan(map_path)
    check, written = write_sortie_dir(plan, m, tmp / "sorties")
    assert written and check.passed, check.failed()
    return map_path, tmp / "sorties"


def _edited(src: Path, tmp: Path, edit, name: str = "edited") -> Path:
    """A copy of the sortie directory `src` whose fleet.json `edit(doc)` changed."""
    d = tmp / name
    shutil.copytree(src, d)
    doc = json.loads((d / "fleet.json").read_text())
    edit(doc)
    (d / "fleet.json").write_text(json.dumps(doc, indent=2))
    return d


def _sortie(doc: dict, vehicle: int, sortie: int) -> dict:
    return doc["vehicles"][vehicle - 1]["sorties"][sortie - 1]


def _run(capsys, *argv) -> tuple[int, str, str]:
    rc = main([*map(str, argv)])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _swap_files(doc: dict) -> None:
    a, b = _sortie(doc, 1, 1), _sortie(doc, 2, 1)
    a["file"], b["file"] = b["file"], a["file"]


# ------------------------------------------------------ 1. upload holds fleet.json to itself


def test_a_plans_fleet_json_agrees_with_itself_and_its_missions(planned) -> None:
    _, d = planned
    fleet = read_fleet_dir(d)
    assert fleet.disagreements() == [] and fleet.disagreement() is None
    assert [v.launch_given for v in fleet.vehicles] == [True, True]


def _one(doc: dict, **fields) -> None:
    _sortie(doc, 2, 2).update(fields)


@pytest.mark.parametrize(("edit", "field", "words"), [
    (lambda d: _one(d, takeoff_s=100.0), "vehicles[1].sorties[1].takeoff_s: 100 s",
     "but fleet.json's own clock gives 398.2 s (sortie 1's take-off 0.0 s + duration_s "),
    (lambda d: _sortie(d, 2, 1).update(takeoff_s=100.0), "vehicles[1].sorties[0].takeoff_s: "
     "100 s", "but fleet.json's own clock gives 0.0 s (vehicle 2's launch_s 0 s)"),
    (lambda d: d["vehicles"][1].update(launch_s=170.0), "vehicles[1].sorties[0].takeoff_s: 0 s",
     "but fleet.json's own clock gives 170.0 s (vehicle 2's launch_s 170 s)"),
    (lambda d: _one(d, landing_s=1.0), "vehicles[1].sorties[1].landing_s: 1 s",
     "but its take-off 398.2 s + duration_s 283.154 s is 681.3 s"),
    (lambda d: _one(d, duration_s=1.0), "vehicles[1].sorties[1].landing_s: 681.307 s",
     "duration_s 1 s is 399.2 s"),
    (lambda d: d["vehicles"][1].update(makespan_s=1.0), "vehicles[1].makespan_s: 1 s",
     "but its last sortie lands at 1812.5 s"),
    (lambda d: d.update(total_s=1.0), "total_s: 1 s", "sum to 2037.2 s"),
    (lambda d: d.update(swaps=0), "swaps: 0", "the vehicles fly 4 sorties after their first"),
    (lambda d: _one(d, energy_wh=1.0), "vehicles[1].sorties[1].energy_wh: 1 Wh",
     "the other sorties give 18.253 and 14.602 Wh"),
    (lambda d: _one(d, energy_wh=None), "vehicles[1].sorties[1].energy_wh: null (planned "
     "without a battery)", "but reserve_left_wh is"),
    (lambda d: _one(d, reserve_left_wh=9.0), "vehicles[1].sorties[1].reserve_left_wh: 9 Wh",
     "the battery is"),
    (lambda d: _sortie(d, 2, 2)["takeoff_at"].update(lat=23.06), "vehicles[1].sorties[1]."
     "takeoff_at: lat 23.0600000, lon 113.4160414", "m from where its file "
     "'mission-v2-s2.plan' takes off (lat 23.0655525, lon 113.4160414)"),
    (lambda d: _sortie(d, 2, 2)["landing_at"].update(east_m=35.0), "vehicles[1].sorties[1]."
     "landing_at: 35 m east, 0 m north of 'north'", "but its file 'mission-v2-s2.plan' lands "
     "at 'north' itself, 35.0 m from there"),
    (lambda d: _sortie(d, 2, 2)["takeoff_at"].update(x=1935.0), "vehicles[1].sorties[1]."
     "takeoff_at: x 1935, y 1800 m is 35.00 m east", "not east_m 0, north_m 0"),
    (lambda d: d["depots"]["north"].update(lat=23.06), "vehicles[1].sorties[0].takeoff_at: 0 m "
     "east, 0 m north of 'north'", "takes off 615 m N of it, 614.9 m from there"),
    (_swap_files, "vehicles[0].sorties[0].takeoff_at: lat 23.0502030, lon 113.3984758, 2475.9 "
     "m from where its file 'mission-v2-s1.plan' takes off", "(lat 23.0655525, lon "
     "113.4160414)"),
])  # fmt: skip
def test_fleet_json_at_odds_with_itself_names_the_field(planned, tmp_path, edit, field,
                                                        words) -> None:
    _, src = planned
    d = _edited(src, tmp_path, edit)
    off = read_fleet_dir(d).disagreements()
    assert off, "no disagreement found"
    assert off[0].startswith(f"{d / 'fleet.json'}: {field}"), off[0]
    assert words in off[0] and "\n" not in off[0], off[0]


@pytest.mark.parametrize("edit", [lambda d: _sortie(d, 2, 1).update(takeoff_s=100.0),
                                  _swap_files])  # fmt: skip
def test_upload_without_map_refuses_a_fleet_json_at_odds_with_itself(planned, tmp_path, capsys,
                                                                     edit) -> None:
    """The reviewer's two edits, sent to two mock vehicles that would take them: refused, exit
    1, one line naming the field, nothing sent; --force sends with a warning."""
    _, src = planned
    d = _edited(src, tmp_path, edit)
    line = read_fleet_dir(d).disagreement()
    assert line is not None
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0,
                   params={"MPC_XY_VEL_MAX": 20.0}) as fleet:  # fmt: skip
        rc, out, err = _run(capsys, "upload", d, "--fleet", *conn)
        assert rc == 1 and out == "", out
        assert err == (f"lamde-mission upload: {line}; nothing sent (the crew goes by "
                       "fleet.json: upload prints its take-off times and pads; `lamde-mission "
                       "verify MAP DIR/` holds it to the replays; --force sends it anyway)\n")
        assert all(sum(v.stats.uploads.values()) == 0 for v in fleet.vehicles)
        rc, out, err = _run(capsys, "upload", d, "--fleet", *conn, "--force")
        assert rc == 0, out + err
        assert f"warning: {line}; sent anyway (--force)" in err


# ------------------------------------------- 2. verify holds fleet.json's figures to the replays


def test_verify_passes_figures_that_are_the_replays(planned, capsys) -> None:
    map_path, d = planned
    rc, out, _ = _run(capsys, "verify", map_path, d)
    assert rc == 0, out
    assert ("fleet FIGURES fleet.json's durations, energies and sensors are the replays': PASS; "
            "the ") in out and " figures fleet.json gives are the replays'" in out


@pytest.mark.parametrize(("edit", "said"), [
    (lambda d: _one(d, energy_wh=1.0), "vehicle 2 sortie 2 energy_wh 1 Wh in fleet.json, "
     "replayed 13.438 Wh"),
    (lambda d: _one(d, duration_s=1.0), "vehicle 2 sortie 2 duration_s 1 s in fleet.json, "
     "replayed 283.154 s"),
    (lambda d: _one(d, sensors=["S1"]), "vehicle 2 sortie 2 sensors in fleet.json leave out "
     "'S2', 'S3', 'S4', which the replay collects from"),
    (lambda d: _sortie(d, 2, 1).update(sensors=["S9"]), "vehicle 2 sortie 1 sensors in "
     "fleet.json list 'S9', which the replay collects nothing from"),
    (lambda d: _one(d, energy_wh=None, reserve_left_wh=None, above_reserve_wh=None),
     "vehicle 2 sortie 2 energy_wh null in fleet.json, replayed 13.438 Wh"),
    (lambda d: _one(d, above_reserve_wh=20.0), "vehicle 2 sortie 2 above_reserve_wh 20 Wh in "
     "fleet.json, replayed 1.165 Wh"),
    (lambda d: d.update(f_total=1.0), "f_total 1 s in fleet.json, replayed 835.973 s"),
    (lambda d: d.update(timing_tolerance_s=300.0), "timing_tolerance_s 300 s in fleet.json, "
     "replayed 120.000 s"),
])  # fmt: skip
def test_verify_fails_figures_that_are_not_the_replays(planned, tmp_path, capsys, edit,
                                                       said) -> None:
    map_path, src = planned
    d = _edited(src, tmp_path, edit)
    rc, out, _ = _run(capsys, "verify", map_path, d)
    assert rc == 1, out
    line = next(ln for ln in out.splitlines() if ln.startswith("fleet FIGURES"))
    assert line.startswith("fleet FIGURES fleet.json's durations, energies and sensors are the "
                           f"replays': FAIL; {said}"), line
    assert line.endswith(": the crew reads fleet.json's figures, the vehicles fly the missions")
    rc, js, _ = _run(capsys, "verify", map_path, d, "--json")
    (fig,) = [v for v in json.loads(js)["fleet"] if v["name"] == "FIGURES"]
    assert rc == 1 and not fig["passed"] and fig["margin"] <= -1


# ------------------------------------------------------------ 3, 4. bad input: exit 2, one line


@pytest.mark.parametrize(("edit", "shown"), [
    (lambda d: d.update(colour="red"), "colour: unknown field"),
    (lambda d: d.update(swap_time=120), "swap_time: unknown field (did you mean 'swap_s'?)"),
    (lambda d: d["vehicles"][0].update(launch=0), "vehicles[0].launch: unknown field (did you "
     "mean 'launch_s'?)"),
    (lambda d: _sortie(d, 1, 1).update(colour="red"), "vehicles[0].sorties[0].colour: unknown "
     "field"),
    (lambda d: _sortie(d, 1, 1).update(energy=1.0), "vehicles[0].sorties[0].energy: unknown "
     "field (did you mean 'energy_wh'?)"),
    (lambda d: _sortie(d, 1, 1)["takeoff_at"].update(height=10), "vehicles[0].sorties[0]."
     "takeoff_at.height: unknown field"),
    (lambda d: d["depots"]["home"].update(east_m=0.0), "depots.home.east_m: unknown field"),
    (lambda d: _sortie(d, 2, 1).update(file="mission-v1-s1.plan"), "vehicles[1].sorties[0]."
     "file: 'mission-v1-s1.plan' is vehicle 1 sortie 1's mission too: each sortie flies a "
     "file of its own"),
    (lambda d: _sortie(d, 2, 1).update(depot_start="south"), "vehicles[1].sorties[0]."
     "depot_start: 'south', a depot fleet.json's depots do not give (home, north)"),
])  # fmt: skip
def test_a_bad_fleet_json_is_bad_input_for_verify_show_and_upload(planned, tmp_path, capsys,
                                                                  edit, shown) -> None:
    map_path, src = planned
    d = _edited(src, tmp_path, edit)
    line = f"{d / 'fleet.json'}: {shown}"
    with pytest.raises(FleetDirError) as exc:
        read_fleet_dir(d)
    assert str(exc.value) == line
    port = free_udp_port()
    for argv in (["verify", map_path, d], ["show", map_path, d, "-o", tmp_path / "x.png"],
                 ["upload", d, "--fleet", "--connect", f"udpin://127.0.0.1:{port}",
                  "--timeout", "0.5"]):  # fmt: skip
        rc, out, err = _run(capsys, *argv)
        assert (rc, out, err) == (2, "", f"lamde-mission {argv[0]}: {line}\n")
    assert not (tmp_path / "x.png").exists()


def test_one_file_under_two_names_is_listed_twice(planned, tmp_path) -> None:
    _, src = planned
    d = _edited(src, tmp_path, lambda doc: _sortie(doc, 2, 1).update(file="again.plan"))
    (d / "again.plan").symlink_to(d / "mission-v1-s1.plan")
    with pytest.raises(FleetDirError, match=r"vehicles\[1\]\.sorties\[0\]\.file: 'again\.plan' "
                       r"is vehicle 1 sortie 1's mission too \(as 'mission-v1-s1\.plan', the "
                       r"same file\)"):
        read_fleet_dir(d)


def test_the_reader_knows_every_field_the_writer_writes(planned) -> None:
    """The field lists the reader refuses others by are the writer's (`summary_dict`): a field
    added to one and not the other fails here, not on a crew's upload."""
    from lamde_mission.formats import fleet as F

    _, d = planned
    doc = json.loads((d / "fleet.json").read_text())
    assert set(doc) == set(F.FLEET_FIELDS)
    assert {k for v in doc["vehicles"] for k in v} == set(F.VEHICLE_FIELDS)
    ss = [s for v in doc["vehicles"] for s in v["sorties"]]
    assert {k for s in ss for k in s} == set(F.SORTIE_FIELDS)
    assert {k for s in ss for w in ("takeoff_at", "landing_at") for k in s[w]} == \
        set(F.PLACE_FIELDS)
    assert {k for dp in doc["depots"].values() for k in dp} == set(F.DEPOT_FIELDS)


# ----------------------------------------------- 5. a depot the map lacks: one check, all refuse


def test_show_refuses_a_depot_the_map_lacks_as_verify_does(planned, tmp_path, capsys) -> None:
    _, d = planned
    doc = json.loads(fleet_demo_map(tmp_path, 2).read_text())
    doc["fleet"]["depots"] = [dp for dp in doc["fleet"]["depots"] if dp["name"] != "north"]
    lacking = tmp_path / "no-north.json"
    lacking.write_text(json.dumps(doc))
    line = (f"{d / 'fleet.json'}: vehicle 2 sortie 1 (mission-v2-s1.plan) takes off at depot "
            "'north', which map 'fleet-demo' does not have (its depots: home)")
    for argv in (["verify", lacking, d], ["show", lacking, d, "-o", tmp_path / "x.png"]):
        rc, out, err = _run(capsys, *argv)
        assert (rc, out, err) == (2, "", f"lamde-mission {argv[0]}: {line}\n")
    assert not (tmp_path / "x.png").exists()


def test_show_notes_a_fleet_json_at_odds_with_itself(planned, tmp_path, capsys) -> None:
    map_path, src = planned
    d = _edited(src, tmp_path, lambda doc: _sortie(doc, 2, 1).update(takeoff_s=100.0))
    rc, _, err = _run(capsys, "show", map_path, d, "-o", tmp_path / "x.png")
    assert rc == 0
    assert err == f"note: {read_fleet_dir(d).disagreement()}; `verify MAP DIR/` fails it\n"
