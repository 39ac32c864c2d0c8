"""Sortie directories as `verify MAP DIR/`, `upload DIR/ --fleet` and `show MAP DIR/` read them:
faults a replay of each sortie alone does not see (a vehicle taking off where it did not land,
more vehicles than the map flies, stray mission files, another map), and fleet.json's figures.

The directories are real plans made fast: the demo's sensors joined into one tour, split into
battery-sized sorties and LP-timed (`planner_core.fleet`, no pipeline run), written by
`write_sortie_dir` on examples/maps/fleet-demo.json (with 1 and with 2 UAVs).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from lamde_mission.cli import main
from lamde_mission.formats import read_mission
from lamde_mission.vehicle.mock_fleet import MockFleet
from planner_core.model.mapio import load_map
from tests.fleet_helpers import fleet_demo_map as _demo_map
from tests.fleet_helpers import quick_fleet_plan as _fleet_plan
from tests.vehicle_helpers import free_udp_port
from tests.vehicle_helpers import no_leftover_mock_threads as _no_leftover_mock_threads  # noqa: F401 (autouse)

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "examples" / "maps" / "fleet-demo.json"


@pytest.fixture(scope="module")
def dirs(tmp_path_factory):
    """{uavs: (map path, sortie directory)} for 1 and 2 UAVs, each written and passing."""
    from lamde_mission.sorties import write_sortie_dir

    tmp = tmp_path_factory.mktemp("sortie-dirs")
    out = {}
    for uavs in (1, 2):
        map_path = _demo_map(tmp, uavs)
        m, plan = _fleet_plan(map_path)
        check, written = write_sortie_dir(plan, m, tmp / f"uavs{uavs}")
        assert written and check.passed, check.failed()
        out[uavs] = (map_path, tmp / f"uavs{uavs}")
    return out


def _copy(src: Path, tmp: Path) -> Path:
    dst = tmp / src.name
    shutil.copytree(src, dst)
    return dst


def _verify(capsys, *argv: str | Path) -> tuple[int, str, str]:
    rc = main(["verify", *map(str, argv)])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _swapped(src: Path, tmp: Path) -> Path:
    """A copy of `src` with sorties 1 and 2 of vehicle 1 swapped (fleet.json and the files):
    each sortie alone still passes, but vehicle 1 lands at 'north' and takes off at 'home'."""
    d = _copy(src, tmp)
    doc = json.loads((d / "fleet.json").read_text())
    ss = doc["vehicles"][0]["sorties"]
    assert (ss[0]["depot_start"], ss[0]["depot_end"], ss[1]["depot_end"]) == \
        ("home", "north", "north")
    ss[0], ss[1] = ss[1], ss[0]
    for k, s in enumerate(ss[:2], start=1):
        s["sortie"], s["file"] = k, f"mission-v1-s{k}.plan"
    (d / "mission-v1-s1.plan").rename(d / "swap.tmp")
    (d / "mission-v1-s2.plan").rename(d / "mission-v1-s1.plan")
    (d / "swap.tmp").rename(d / "mission-v1-s2.plan")
    (d / "fleet.json").write_text(json.dumps(doc))
    return d


def test_verify_fails_a_vehicle_taking_off_where_it_did_not_land(dirs, tmp_path, capsys):
    map_path, src = dirs[1]
    rc, out, _ = _verify(capsys, map_path, src)
    assert rc == 0 and "all constraints hold" in out, out
    assert "fleet CHAIN each sortie takes off where its vehicle stands: PASS" in out
    d = _swapped(src, tmp_path)
    rc, out, _ = _verify(capsys, map_path, d)
    assert rc == 1, out
    line = ("vehicle 1 sortie 2 takes off at 'home' but its sortie 1 landed at 'north', "
            "2476 m away")  # hypot(1800, 1700)
    assert f"fleet CHAIN each sortie takes off where its vehicle stands: FAIL; {line}" in out
    assert f"result: FAILED fleet CHAIN: {line}" in out
    rc, out, _ = _verify(capsys, map_path, d, "--json")
    rep = json.loads(out)
    assert rc == 1 and not rep["passed"]
    (chain,) = [v for v in rep["fleet"] if v["name"] == "CHAIN"]
    assert not chain["passed"] and chain["margin"] == pytest.approx(-np.hypot(1800, 1700))
    # a sortie's ENDS names its depots' pads, not the sortie map's "start" and "end"
    ends = [v["detail"] for s in rep["sorties"] for v in s["verdicts"] if v["name"] == "ENDS"]
    assert ends and all("m from its pad at '" in e and "from start" not in e for e in ends), ends


def test_verify_of_one_sortie_file_says_it_is_one_sortie(dirs, tmp_path, capsys):
    """`verify MAP DIR/mission-v1-s2.plan` failed ENDS and C4 with no hint that the file is one
    sortie judged against the whole map's start, end and data: a line after the result now says
    so and names `verify MAP DIR/` (JSON: `sortie_of`); the verdicts are those of the same file
    outside a sortie directory, which gets no such line. A file fleet.json lists under another
    name is one sortie too."""
    map_path, src = dirs[1]
    d = _copy(src, tmp_path)
    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(d / "mission-v1-s2.plan", alone / "second.plan")
    rc, out, _ = _verify(capsys, map_path, d / "mission-v1-s2.plan")
    rc_alone, out_alone, _ = _verify(capsys, map_path, alone / "second.plan")
    assert rc == rc_alone == 1 and "FAILED" in out and "ENDS" in out, out
    lines, lines_alone = out.splitlines(), out_alone.splitlines()
    assert lines[1:-1] == lines_alone[1:]  # the verdicts and figures unchanged
    assert lines[-2].startswith("result: FAILED ")
    assert lines[-1] == (
        f"note: {d}/mission-v1-s2.plan is one sortie of the sortie directory {d}/, judged here "
        "against the whole map's start, end and data; for the sortie's own depots and the data "
        f"over all sorties run `lamde-mission verify {map_path} {d}/`")
    rc, out, _ = _verify(capsys, map_path, d / "mission-v1-s2.plan", "--json")
    rep = json.loads(out)
    assert rep.pop("sortie_of") == {"directory": str(d),
                                    "verify": f"lamde-mission verify {map_path} {d}/"}
    _, out_alone, _ = _verify(capsys, map_path, alone / "second.plan", "--json")
    assert rc == 1 and rep == json.loads(out_alone)
    # listed by fleet.json under another name (a hand-made directory)
    doc = json.loads((d / "fleet.json").read_text())
    doc["vehicles"][0]["sorties"][1]["file"] = "second.plan"
    (d / "fleet.json").write_text(json.dumps(doc))
    (d / "mission-v1-s2.plan").rename(d / "second.plan")
    rc, out, _ = _verify(capsys, map_path, d / "second.plan")
    assert rc == 1 and out.splitlines()[-1].startswith(
        f"note: {d}/second.plan is one sortie of the sortie directory {d}/"), out
    (d / "fleet.json").unlink()  # a file neither listed nor so named: no line
    rc, out, _ = _verify(capsys, map_path, d / "second.plan")
    assert rc == 1 and out.splitlines()[-1].startswith("result: FAILED "), out
    # named as a sortie, but no fleet.json beside it (a reviewer: the note named `verify MAP
    # ./`, which fails, "fleet.json: no such file"): a note that names no directory
    shutil.copy(alone / "second.plan", alone / "mission-v2-s1.plan")
    rc, out, _ = _verify(capsys, map_path, alone / "mission-v2-s1.plan")
    assert rc == 1 and out.splitlines()[-1] == (
        f"note: {alone}/mission-v2-s1.plan is named as one sortie of a sortie directory, "
        "judged here against the whole map's start, end and data; a sortie is verified with "
        "its directory (`lamde-mission verify MAP DIR/`, DIR holding fleet.json), which is not "
        "beside this file"), out
    rc, out, _ = _verify(capsys, map_path, alone / "mission-v2-s1.plan", "--json")
    assert "sortie_of" not in json.loads(out)


def test_verify_fails_more_vehicles_than_the_map_flies(dirs, tmp_path, capsys):
    map_path, d = dirs[2]
    rc, out, _ = _verify(capsys, map_path, d)
    assert rc == 0 and "all constraints hold" in out, out
    one = _demo_map(tmp_path, 1)  # the same map, fleet.uavs 1
    rc, out, _ = _verify(capsys, one, d)
    assert rc == 1, out
    assert "fleet UAVS vehicles <= fleet.uavs: FAIL; fleet.json plans 2 vehicles, the map's " \
        "fleet.uavs is 1" in out
    assert "FAILED fleet UAVS: fleet.json plans 2 vehicles, the map's fleet.uavs is 1" in out


def test_a_map_without_a_fleet_flies_one_vehicle() -> None:
    from lamde_mission.sorties import _uavs_verdict

    doc = json.loads(DEMO.read_text())
    doc.pop("fleet")
    m = load_map(doc)
    assert not _uavs_verdict(m, 2).passed and _uavs_verdict(m, 1).passed
    assert _uavs_verdict(m, 2).detail == "fleet.json plans 2 vehicles, the map's fleet.uavs is 1"


def test_a_first_sortie_leaves_a_depot_a_vehicle_starts_from() -> None:
    # without fleet.depots a vehicle starts at the map's start ('home'); 'end' is a landing site
    from lamde_mission.sorties import _chain_verdict

    doc = json.loads(DEMO.read_text())
    doc["fleet"].pop("depots")
    m = load_map(doc)
    ok = _chain_verdict(m, [(1, 1, "a", "home", "end", []), (1, 2, "b", "end", "end", [])])
    assert ok.passed, ok.detail
    bad = _chain_verdict(m, [(1, 1, "a", "end", "end", [])])
    assert not bad.passed
    assert bad.detail == ("vehicle 1 sortie 1 takes off at 'end', not a depot a vehicle starts "
                          "from (home; 2476 m away)")


def test_verify_names_mission_files_fleet_json_does_not_list(dirs, tmp_path, capsys):
    # a stale sortie of an earlier plan copied in: verify replayed only what fleet.json lists
    map_path, src = dirs[1]
    d = _copy(src, tmp_path)
    rc, out, _ = _verify(capsys, map_path, d)
    assert rc == 0 and "fleet FILES no mission file fleet.json does not list: PASS" in out
    n = len(json.loads((d / "fleet.json").read_text())["vehicles"][0]["sorties"])
    stale = [f"mission-v1-s{n + 1}.plan", "mission-v2-s1.plan"]
    for name in stale:
        shutil.copy(d / "mission-v1-s1.plan", d / name)
    (d / "notes.txt").write_text("not a mission")
    rc, out, _ = _verify(capsys, map_path, d)
    assert rc == 1, out
    line = (f"{', '.join(stale)} in {d.name}/ but not listed in fleet.json (stale: an operator "
            "loading the files by name would fly it; remove it)")
    assert f"FAILED fleet FILES: {line}" in out
    assert "notes.txt" not in out


def test_verify_notes_a_fleet_json_of_another_map(dirs, tmp_path, capsys):
    map_path, d = dirs[1]
    other = _demo_map(tmp_path, 1, name="elsewhere")
    rc, out, err = _verify(capsys, other, d)
    assert rc == 0, out
    assert err.strip() == f"note: {d}: planned on map 'fleet-demo', verified on 'elsewhere'"
    rc, out, err = _verify(capsys, other, d, "--json")
    assert json.loads(out)["notes"] == [f"{d}: planned on map 'fleet-demo', verified on "
                                        "'elsewhere'"]
    rc, out, err = _verify(capsys, map_path, d)
    assert rc == 0 and err == ""


def test_verify_notes_a_directory_planned_with_a_battery_on_a_map_without_one(dirs, tmp_path,
                                                                              capsys):
    """A newcomer: a directory planned with a battery, verified against the same map without
    one, passed with no word that fleet.json's energies no longer apply (ENERGY is not judged
    there). A note now, on stderr and in --json's notes; the verdict is unchanged."""
    from lamde_mission.formats.fleet import read_fleet_dir

    map_path, d = dirs[1]
    doc = json.loads(map_path.read_text())
    del doc["uav"]["endurance_s"], doc["uav"]["battery"]  # no battery at all
    bare = tmp_path / "no-battery.json"
    bare.write_text(json.dumps(doc))
    planned = [s for v in read_fleet_dir(d).vehicles for s in v.sorties]
    assert all(s.energy_wh is not None for s in planned)
    first = planned[0]
    which = (f"{first.path.name}: {first.energy_wh:.2f} Wh" if len(planned) == 1 else
             f"{len(planned)} sorties, e.g. {first.path.name}: {first.energy_wh:.2f} Wh")
    note = (f"{d}: planned with a battery (its energies: {which}), verified on map "
            "'fleet-demo', which has none: ENERGY is not judged, and fleet.json's energies and "
            "reserves no longer apply (verify on the map with its uav.battery or "
            "uav.endurance_s to judge them)")
    rc, out, err = _verify(capsys, bare, d)
    assert rc == 0, out
    assert err.strip() == f"note: {note}"
    assert "ENERGY" not in out
    figures = next(ln for ln in out.splitlines() if ln.startswith("fleet FIGURES"))
    assert "PASS" in figures and ("(not its above_reserve_wh, energy_wh, reserve_left_wh: the "
                                  "map has no battery)") in figures, figures
    rc, out, err = _verify(capsys, bare, d, "--json")
    assert json.loads(out)["notes"] == [note]
    rc, out, err = _verify(capsys, map_path, d)  # the map it was planned on: no note
    assert rc == 0 and err == ""


def test_verify_on_a_map_without_the_directorys_depots_names_the_map_it_was_planned_on(
        dirs, tmp_path, capsys):  # fmt: skip
    """`verify small-demo.json DIR/` (DIR planned on fleet-demo) said only "depot: unknown
    depot 'north' (the map's are home, end)", naming neither fleet.json nor the sortie nor the
    map it was planned on; `upload DIR/ --fleet --map` the same. Still exit 2, one line."""
    _, d = dirs[1]
    small = ROOT / "examples" / "maps" / "small-demo.json"
    line = (f"{d / 'fleet.json'}: vehicle 1 sortie 1 (mission-v1-s1.plan) lands at depot "
            "'north', which map 'small-demo' does not have (its depots: home, end); the "
            "directory was planned on map 'fleet-demo', not 'small-demo'")
    rc, out, err = _verify(capsys, small, d)
    assert rc == 2 and out == "" and err == f"lamde-mission verify: {line}\n"
    port = free_udp_port()
    rc = main(["upload", str(d), "--fleet", "--map", str(small), "--connect",
               f"udpin://127.0.0.1:{port}", "--timeout", "0.5"])  # fmt: skip
    assert rc == 2 and capsys.readouterr().err == f"lamde-mission upload: {line}\n"
    # the same name, another map (depots edited): no "planned on" part
    doc = json.loads(DEMO.read_text())
    doc["fleet"]["depots"] = [dp for dp in doc["fleet"]["depots"] if dp["name"] != "north"]
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(doc))
    rc, out, err = _verify(capsys, edited, d)
    assert rc == 2 and err.startswith(f"lamde-mission verify: {d / 'fleet.json'}: vehicle 1 ")
    assert "which map 'fleet-demo' does not have" in err and "planned on" not in err


def test_show_notes_a_fleet_json_of_another_map(dirs, tmp_path, capsys):
    # the same note as verify's (one helper: FleetDir.map_note)
    _, d = dirs[1]
    other = _demo_map(tmp_path, 1, name="elsewhere")
    assert main(["show", str(other), str(d), "-o", str(tmp_path / "x.png")]) == 0
    err = capsys.readouterr().err
    assert err.strip() == f"note: {d}: planned on map 'fleet-demo', drawn on 'elsewhere'"


def test_upload_fleet_with_map_replays_the_directory_first(dirs, tmp_path, capsys):
    # it was refused, naming `verify DIR/ --map MAP`, a command verify does not take
    map_path, src = dirs[2]
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    one = _demo_map(tmp_path, 1)  # fleet.uavs 1: the 2-vehicle plan fails UAVS
    # vehicles set to fly the plan's 20 m/s (PX4's default MPC_XY_VEL_MAX, 12, fails ENERGY:
    # tests/test_speed_limit.py)
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0,
                   params={"MPC_XY_VEL_MAX": 20.0}) as fleet:  # fmt: skip
        rc = main(["upload", str(src), "--fleet", *conn, "--map", str(one)])
        cap = capsys.readouterr()
        assert rc == 1, cap.out + cap.err
        assert all(sum(v.stats.uploads.values()) == 0 for v in fleet.vehicles)
        assert cap.err.strip() == (
            f"lamde-mission upload: {src}: the simulator rejects it on {one}: fleet UAVS: "
            "fleet.json plans 2 vehicles, the map's fleet.uavs is 1; nothing sent "
            f"(`lamde-mission verify {one} {src}` shows every verdict; --force sends it "
            "anyway)")
        rc = main(["upload", str(src), "--fleet", *conn, "--map", str(one), "--force"])
        cap = capsys.readouterr()
        assert rc == 0, cap.out + cap.err
        assert f"warning: {src}: the simulator rejects it on {one} (fleet UAVS: " in cap.err
        assert "sent anyway (--force)" in cap.err
        rc = main(["upload", str(src), "--fleet", *conn, "--map", str(map_path)])
        cap = capsys.readouterr()
        assert rc == 0, cap.out + cap.err
        assert (f"simulator: all constraints hold on {map_path} for the "
                f"{sum(1 for _ in src.glob('*.plan'))} sorties of {src}") in cap.out
        for k, v in enumerate(fleet.vehicles, start=1):
            mission, _fence = read_mission(src / f"mission-v{k}-s1.plan")
            assert len(v.items()) == len(mission)
    # a broken chain, a stray file: the same checks as verify's (no vehicle needed)
    d = _swapped(dirs[1][1], tmp_path)
    rc = main(["upload", str(d), "--fleet", *conn, "--map", str(dirs[1][0])])
    err = capsys.readouterr().err
    assert rc == 1 and "fleet CHAIN: vehicle 1 sortie 2 takes off at 'home'" in err, err


@pytest.mark.parametrize("uavs", [1, 2])
def test_fleet_json_figures_are_all_the_replays(dirs, uavs, capsys):
    # f_total was the planner's unrounded objective beside the sim's durations and energies
    # (the demo: 251.097 in fleet.json, 80.303 + 51.355 + 120 = 251.658 replayed)
    map_path, d = dirs[uavs]
    summary = json.loads((d / "fleet.json").read_text())
    rc, out, _ = _verify(capsys, map_path, d, "--json")
    rep = json.loads(out)
    swap_s = json.loads(map_path.read_text())["fleet"]["swap_s"]
    replayed = sum(s["f"] for s in rep["sorties"]) + swap_s * rep["swaps"]
    assert summary["swaps"] == rep["swaps"] >= 1
    assert summary["f_total"] == pytest.approx(replayed, rel=1e-12)
    assert rep["f_total"] == pytest.approx(replayed, rel=1e-12)
    assert summary["total_s"] == pytest.approx(rep["total_s"], rel=1e-12)
    durations = [s["duration_s"] for v in summary["vehicles"] for s in v["sorties"]]
    assert durations == pytest.approx([s["duration_s"] for s in rep["sorties"]], rel=1e-12)


def test_fleet_json_names_the_plans_objective(tmp_path):
    # write_sortie_dir(result.plan, m, d), as docs/sorties.md shows it, wrote "total" for a
    # plan made for the makespan
    from lamde_mission.sorties import write_sortie_dir

    m, plan = _fleet_plan(_demo_map(tmp_path, 2), "makespan")
    assert plan.settings.goal == "makespan"
    check, written = write_sortie_dir(plan, m, tmp_path / "d")
    assert written, check.failed()
    assert json.loads((tmp_path / "d" / "fleet.json").read_text())["objective"] == "makespan"
    with pytest.raises(ValueError, match="goal: 'total', but the plan was made for 'makespan'"):
        write_sortie_dir(plan, m, tmp_path / "e", goal="total")
    assert not (tmp_path / "e").exists()


def test_show_draws_the_depots_no_sortie_uses(dirs, tmp_path, capsys):
    # only the depots sorties took off or landed at were drawn: 'east' was missing
    from matplotlib.text import Text

    from lamde_mission.commands.show import fleet_views
    from lamde_mission.plot import fleet_figure

    _, d = dirs[1]
    doc = json.loads(DEMO.read_text())
    doc["fleet"]["depots"].append({"name": "east", "x": 1900.0, "y": 150.0})
    path = tmp_path / "with-east.json"
    path.write_text(json.dumps(doc))
    m = load_map(path)
    fig = fleet_figure(m, fleet_views(d, m))
    texts = [t.get_text() for t in fig.findobj(Text) if t.get_text()]
    assert "east" in texts and "home" in texts and "north" in texts
    assert "depot no sortie uses: east" in texts
    idle = [line for line in fig.axes[0].get_lines() if line.get_marker() == "h"
            and line.get_markerfacecolor() == "0.93"]
    assert [tuple(line.get_xydata()[0]) for line in idle] == [(1900.0, 150.0)]
    texts = [t.get_text() for t in fleet_figure(load_map(DEMO), fleet_views(d, m)).findobj(Text)]
    assert not any("no sortie uses" in t for t in texts)  # every depot of the demo is used
    assert main(["show", str(path), str(d), "-o", str(tmp_path / "x.png")]) == 0
    assert (tmp_path / "x.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plan_and_verify_print_what_is_left_above_the_reserve(dirs, capsys):
    # "reserve left" was battery - energy: the reserve itself included, read as slack
    from lamde_mission.commands.plan import _sortie_lines
    from lamde_mission.sorties import verify_sortie_dir

    map_path, d = dirs[1]
    m = load_map(map_path)
    summary = json.loads((d / "fleet.json").read_text())
    first = summary["vehicles"][0]["sorties"][0]
    slack = m.usable_energy_wh - first["energy_wh"]
    assert first["above_reserve_wh"] == pytest.approx(slack, rel=1e-12)
    assert first["reserve_left_wh"] == pytest.approx(m.battery_wh - first["energy_wh"])
    rc, out, _ = _verify(capsys, map_path, d)
    (line,) = [x for x in out.splitlines() if x.startswith(first["file"])]
    assert (f"{slack:.3f} Wh left above the reserve ({m.battery_wh - first['energy_wh']:.3f} "
            "Wh in the battery)") in line, line
    assert "reserve left" not in out
    lines = _sortie_lines(verify_sortie_dir(m, d), m)
    assert f"{slack:6.2f} Wh left above the reserve" in lines[0], lines[0]
    assert not any("reserve left" in x for x in lines)


def test_plan_and_verify_count_in_the_singular_for_one(dirs, capsys):
    # "4 sorties on 1 vehicle(s)", "1 battery swaps" were printed (one helper now:
    # planner_core.textio.counted, tests/test_outputs.py)
    from lamde_mission.commands.plan import _sortie_lines
    from lamde_mission.sorties import verify_sortie_dir

    map_path, d = dirs[1]
    m = load_map(map_path)
    check = verify_sortie_dir(m, d)
    n, swaps = len(check.sorties), check.swaps
    assert len(check.vehicles()) == 1 and n > 1 and swaps == n - 1
    rc, out, _ = _verify(capsys, map_path, d)
    assert rc == 0 and f"sortie directory {d} on map 'fleet-demo': {n} sorties on 1 vehicle\n" \
        in out, out
    assert f"with {swaps} battery swap{'s' if swaps > 1 else ''}; f summed" in out
    assert "(s)" not in out
    lines = "\n".join(_sortie_lines(check, m))
    assert f"  vehicle 1: {n} sorties, makespan " in lines and "1 sensors" not in lines


def test_the_docs_say_what_plan_fleet_returns_and_what_is_left() -> None:
    # README said plan_fleet "returns the plan": it returns a FleetResult, its .plan the plan;
    # "reserve left" (battery - energy) read as slack
    import lamde_mission

    assert "A `planner_core.fleet.FleetResult`: `plan` (the `FleetPlan`" in " ".join(
        lamde_mission.plan_fleet.__doc__.split())
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert ("`lamde_mission.plan_fleet(map)` returns a `FleetResult` whose `.plan` is the "
            "plan") in readme
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        assert "reserve left" not in " ".join(page.read_text().split()), page


def _one_depot_map(tmp: Path, separation: float | None, tolerance: float | None = 0.0) -> Path:
    """The fleet demo with 2 UAVs and no `fleet.depots` (both take off at the map's start),
    with `fleet.separation_m` when given, and `fleet.launch_tolerance_s` (0: launches clear
    at their planned times only, as before the tolerance; None: the default)."""
    doc = json.loads(DEMO.read_text())
    doc["fleet"]["uavs"] = 2
    del doc["fleet"]["depots"]
    if separation is not None:
        doc["fleet"]["separation_m"] = separation
    if tolerance is not None:
        doc["fleet"]["launch_tolerance_s"] = tolerance
    path = tmp / f"one-depot-{separation}-{tolerance}.json"
    path.write_text(json.dumps(doc))
    return path


def test_plan_staggers_the_launches_to_the_maps_separation(tmp_path, capsys):
    """fleet.separation_m: two UAVs of one depot, written by `write_sortie_dir` (what `plan
    -o DIR/` calls). Each vehicle takes off from and lands at its own pad, the separation +
    5 m from the depot (vehicle 1's is the depot): 35 m at the default 30 m, 55 m under a
    map's 50 m rule, and both keep the map's rule in the air (it kept 30 m whatever the map
    said); `verify` fails the 30 m directory on the 50 m map (exit 1)."""
    from lamde_mission.sorties import write_sortie_dir
    from planner_core.model.pads import pad_ranks

    checks = {}
    for sep in (None, 50.0):
        m, plan = _fleet_plan(_one_depot_map(tmp_path, sep))
        check, written = write_sortie_dir(plan, m, tmp_path / f"d{sep}")
        assert written, check.failed()
        checks[sep] = check
        names, sites, _ = m.sortie_sites
        rank = pad_ranks((s.vehicle, d) for s in check.sorties
                         for d in (s.depot_start, s.depot_end))
        for s in check.sorties:
            far = [float(np.hypot(*(xy - sites[names.index(d)])))
                   for xy, d in ((s.takeoff_xy, s.depot_start), (s.landing_xy, s.depot_end))]
            want = [0.0 if rank[(s.vehicle, d)] == 0 else (sep or 30.0) + 5.0
                    for d in (s.depot_start, s.depot_end)]
            assert far == pytest.approx(want, abs=0.05), (s.file, far)
        assert max(rank.values()) == 1  # the two share a depot
    sep30 = next(v for v in checks[None].fleet if v.name == "SEPARATION")
    sep50 = next(v for v in checks[50.0].fleet if v.name == "SEPARATION")
    assert sep30.passed and sep30.margin >= 0.0, sep30.detail
    assert sep50.passed and sep50.margin >= 0.0, sep50.detail
    assert sep50.title == "vehicles >= 50 m apart"
    launches = [v["launch_s"] for v in
                json.loads((tmp_path / "d50.0" / "fleet.json").read_text())["vehicles"]]
    assert launches == list(checks[50.0].launches)
    rc, out, _ = _verify(capsys, _one_depot_map(tmp_path, None), tmp_path / "dNone")
    assert rc == 0 and "fleet SEPARATION vehicles >= 30 m apart: PASS" in out
    rc, out, _ = _verify(capsys, _one_depot_map(tmp_path, 50.0), tmp_path / "dNone")
    assert rc == 1 and "fleet SEPARATION vehicles >= 50 m apart: FAIL" in out


def test_a_write_removes_the_folders_killed_writes_left_and_keeps_a_live_ones(tmp_path):
    """A `plan -o d/` killed (SIGKILL) before its rename left `.d.lamde-pending-PID` beside
    `d/` for ever (and one killed between its two renames `.d.lamde-old-PID`): the next write
    to `d/` removes those whose process is gone, never one of a process still running (a write
    in progress), nor another target's."""
    import subprocess
    import sys

    from lamde_mission.sorties import write_sortie_dir

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    dead_pid = int(dead.stdout)  # exited and reaped
    live = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"],
                            stdin=subprocess.PIPE)  # runs until its stdin closes
    try:
        left = {}
        for kind in ("pending", "old"):
            for who, pid in (("dead", dead_pid), ("live", live.pid)):
                f = tmp_path / f".d.lamde-{kind}-{pid}"
                f.mkdir()
                (f / "mission-v1-s1.plan").write_text("half a mission")
                left[kind, who] = f
        other = tmp_path / f".e.lamde-pending-{dead_pid}"  # another target's
        other.mkdir()
        m, plan = _fleet_plan(_demo_map(tmp_path, 1))
        check, written = write_sortie_dir(plan, m, tmp_path / "d")
        assert written, check.failed()
        assert live.poll() is None  # still running: its folders are a write in progress
        assert (tmp_path / "d" / "fleet.json").is_file()
        assert not left["pending", "dead"].exists() and not left["old", "dead"].exists()
        assert left["pending", "live"].is_dir() and left["old", "live"].is_dir()
        assert other.is_dir()
    finally:
        live.communicate()


def test_plan_staggers_for_the_maps_launch_tolerance_and_verify_judges_it(tmp_path, capsys):
    """fleet.launch_tolerance_s (a field crew's reviewer: with vehicle 2 launched 50-90 s off
    its time, or a swap of 200 s where 300 were planned, SEPARATION failed down to 0.2 m; the
    stagger took the first clear 10 s step, so any slip broke it). At the default 30 s the
    stagger keeps both vehicles clear for every relative shift within 60 s, verify's TIMING
    says how far each sortie may slip, and fails a directory launched on the edge."""
    from lamde_mission.sorties import write_sortie_dir
    from sim.fleet_time import conflicts

    edge_map, safe_map = _one_depot_map(tmp_path, None), _one_depot_map(tmp_path, None, None)
    m0, plan = _fleet_plan(edge_map)
    edge, _ = write_sortie_dir(plan, m0, tmp_path / "edge")
    m30, plan = _fleet_plan(safe_map)
    safe, _ = write_sortie_dir(plan, m30, tmp_path / "safe")
    assert m30.launch_tolerance_s == 30.0
    t_edge, t_safe = edge.launches[1], safe.launches[1]
    assert t_safe > t_edge and safe.passed and safe.timing_tolerance_s >= 30.0
    timing = next(v for v in safe.fleet if v.name == "TIMING")
    assert timing.passed and timing.margin == safe.timing_tolerance_s - 30.0
    assert edge.timing_tolerance_s < 30.0  # on the edge: 0 s of room at launch tolerance 0
    # by brute force, on the directory's own tracks: no conflict for a relative shift of up
    # to twice the tolerance, and one just beyond (or the search's cap)
    from lamde_mission.sorties import FleetCheck  # noqa: F401 (the type of `safe`)
    from sim.fleet_time import track

    tracks = [track([s.timeline for s in ss], m30.swap_s) for ss in safe.vehicles().values()]
    a, b = tracks[0].at(0.0), tracks[1]
    w = int(safe.timing_tolerance_s)
    def clash(shift: int) -> bool:
        d, _, _, _, n = conflicts(a, b.at(t_safe + shift))
        return d < m30.separation_m or n > 0

    assert not any(clash(shift) for shift in range(-2 * w, 2 * w + 1))
    from sim.fleet_time import TOLERANCE_CAP_S

    if w < TOLERANCE_CAP_S:  # the largest: a shift of 2 w + 1 or 2 w + 2 clashes
        assert any(clash(s) for s in (2 * w + 1, -2 * w - 1, 2 * w + 2, -2 * w - 2))
    # verify judges the edge directory against the 30 s the default asks: TIMING fails
    rc, out, _ = _verify(capsys, safe_map, tmp_path / "edge")
    assert rc == 1 and "fleet TIMING take-offs may be 30 s off: FAIL" in out
    # a failing TIMING says it fails (a re-review read "hold while ... within +-0 s" as a pass)
    line = next(ln for ln in out.splitlines() if ln.startswith("fleet TIMING"))
    assert " hold while " not in line, line
    assert ("fail unless every sortie takes off on its time" in line
            or "hold only while each sortie takes off within" in line), line
    rc, out, _ = _verify(capsys, safe_map, tmp_path / "safe")
    assert rc == 0 and "fleet TIMING take-offs may be 30 s off: PASS" in out
    doc = json.loads((tmp_path / "safe" / "fleet.json").read_text())
    assert doc["timing_tolerance_s"] == safe.timing_tolerance_s


def test_verify_dir_says_what_each_sortie_collects_instead_of_a_c4_of_nothing(dirs, capsys):
    """Each sortie was judged on its sortie map, which requires no data: its own C4 named a
    sensor it does not serve ("tightest: sensor 'S4' 0 of 0 Mbit") and MARGIN said "no data
    required" beside "3 sensors served". Now a sortie's rows leave C4 and MARGIN out, a line
    says what it collects from each sensor it serves, and the whole plan's C4 and MARGIN stay;
    the JSON gives `collected_mbit` and no infinite data margins (not JSON)."""
    map_path, src = dirs[1]
    m = load_map(map_path)
    req = dict(zip(m.sensor_ids, m.required_data, strict=True))
    rc, out, _ = _verify(capsys, map_path, src)
    assert rc == 0, out
    assert "  C4 " not in out and "  MARGIN " not in out and "no data required" not in out
    assert "its share only" not in out
    assert "whole plan C4 Q_j >= Q_lambda (all sorties): PASS" in out
    assert "whole plan MARGIN data margin" in out
    rc, js, _ = _verify(capsys, map_path, src, "--json")
    rep = json.loads(js, parse_constant=lambda c: pytest.fail(f"{c} is not JSON"))
    data = [ln.strip() for ln in out.splitlines() if ln.startswith("  data: ")]
    assert len(data) == len(rep["sorties"]) >= 2
    for line, s in zip(data, rep["sorties"], strict=True):
        assert [v["name"] for v in s["verdicts"]] == ["C1", "C2", "C3", "C5", "CLEAR", "ENDS",
                                                      "ALT", "ENERGY"]
        assert list(s["collected_mbit"]) == s["sensors"] and s["data_margins"] == {}
        for sid, q in s["collected_mbit"].items():
            assert f"'{sid}' {q:.6g} Mbit ({100 * q / req[sid]:.3g} % of its " in line, line
        for sid in set(m.sensor_ids) - set(s["sensors"]):
            assert f"'{sid}'" not in line
        assert line.endswith("C4 and MARGIN judge all sorties together (whole plan, below)")
