"""The vehicle's own speed limit at upload (a field crew's reviewer: PX4 flies a mission's
DO_CHANGE_SPEED at most at MPC_XY_VEL_MAX, 12 m/s by default, so a sortie planned at 20 m/s
with 0.3 Wh above the reserve drew 62.7 of 56.2 usable Wh, and upload said nothing). upload
reads the parameter after connecting, before sending: with --map the simulator's verdicts at
the limit, refused (exit 1, nothing sent) when one fails; without --map a sortie planned with a
battery is refused (its energy at the limit is unchecked), anything else gets a warning."""

from __future__ import annotations

import pytest

from lamde_mission.cli import main
from lamde_mission.vehicle.mock import MOCK_PARAMS, MockVehicle
from lamde_mission.vehicle.mock_fleet import MockFleet
from sim import replay, verify
from tests.conftest import MAPS
from tests.vehicle_helpers import free_udp_port
from tests.vehicle_helpers import no_leftover_mock_threads as _leftover  # noqa: F401 (autouse)

DEMO = MAPS / "small-demo.json"
DEMO_FLEET = MAPS / "fleet-demo.json"


@pytest.fixture(scope="module")
def demo_plan(tmp_path_factory):
    out = tmp_path_factory.mktemp("speed") / "demo.plan"
    assert main(["plan", str(DEMO), "-o", str(out), "--budget", "600", "--quiet"]) == 0
    return out


def test_the_sims_speed_limit_slows_every_leg_with_a_note(demo_plan) -> None:
    from lamde_mission.formats import read_mission
    from planner_core.model.mapio import load_map

    m = load_map(DEMO)
    items, _ = read_mission(demo_plan)
    fast, slow = replay(items, m), replay(items, m, speed_limit=12.0)
    assert fast.totals.speed == 20.0 and slow.totals.t_fly > fast.totals.t_fly
    assert replay(items, m, speed_limit=25.0).totals.t_fly == fast.totals.t_fly  # above: none
    assert "mission speed 20 m/s exceeds the vehicle's speed limit 12 m/s; flown at the limit" \
        in slow.notes
    # the same legs at 12 m/s by the mission's own DO_CHANGE_SPEED: the same flight
    from dataclasses import replace

    from lamde_mission.items import CMD

    asked12 = [replace(it, param2=12.0) if it.command == CMD.DO_CHANGE_SPEED else it
               for it in items]
    assert replay(asked12, m).totals.t_fly == pytest.approx(slow.totals.t_fly, abs=1e-9)
    with pytest.raises(ValueError, match="speed_limit must be a positive speed"):
        replay(items, m, speed_limit=0.0)


@pytest.mark.parametrize("via", ["pymavlink", pytest.param("mavsdk", marks=pytest.mark.slow)])
def test_upload_reads_px4s_limit_and_says_what_it_changes(demo_plan, capsys, via) -> None:
    from lamde_mission.formats import read_mission
    from planner_core.model.mapio import load_map

    assert MOCK_PARAMS["px4"] == {"MPC_XY_VEL_MAX": 12.0}
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", via, "--timeout", "10"]
    m = load_map(DEMO)
    items, _ = read_mission(demo_plan)
    slow, fast = replay(items, m, speed_limit=12.0), replay(items, m)
    assert verify(slow, m).passed  # no battery: only the time changes
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0) as v:
        assert main(["upload", str(demo_plan), *conn, "--map", str(DEMO)]) == 0
        cap = capsys.readouterr()
        assert (f"note: {demo_plan}: the vehicle's MPC_XY_VEL_MAX is 12 m/s, below the 20 m/s "
                "the mission asks (DO_CHANGE_SPEED), so it flies at 12 m/s: t_fly "
                f"{slow.totals.t_fly:.0f} s instead of {fast.totals.t_fly:.0f} s; every check "
                f"holds at that speed on {DEMO}") in cap.out
        assert "the vehicle's speed limit: MPC_XY_VEL_MAX 12 m/s" in cap.out
        assert len(v.items()) > 0
        assert main(["upload", str(demo_plan), *conn]) == 0  # no map: a warning
        assert (f"warning: {demo_plan}: the vehicle's MPC_XY_VEL_MAX is 12 m/s, below the 20 "
                "m/s the mission asks (DO_CHANGE_SPEED), so it flies at 12 m/s; its flight "
                "time and energy were planned at 20 m/s (--map checks it at 12 m/s; set "
                "MPC_XY_VEL_MAX to 20 or more, or plan the map with uav.max_speed 12)"
                ) in capsys.readouterr().err
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0,
                     params={"MPC_XY_VEL_MAX": 20.0}):  # fmt: skip
        assert main(["upload", str(demo_plan), *conn, "--map", str(DEMO)]) == 0
        cap = capsys.readouterr()
        assert "MPC_XY_VEL_MAX is" not in cap.out + cap.err
        assert "the vehicle's speed limit: MPC_XY_VEL_MAX 20 m/s" in cap.out
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0, autopilot="ardupilot"):
        assert main(["upload", str(demo_plan), *conn, "--map", str(DEMO)]) == 0
        assert "the vehicle's speed limit" not in capsys.readouterr().out  # nothing caps it


@pytest.fixture(scope="module")
def fleet2(tmp_path_factory):
    """(map, sortie directory): fleet-demo (a battery) flown by 2 UAVs at 20 m/s."""
    from tests.fleet_helpers import plan_fleet_demo

    return plan_fleet_demo(tmp_path_factory.mktemp("fleet2"))


def test_a_fleet_is_judged_once_with_every_vehicle_at_its_limit_before_sending(fleet2,
                                                                              capsys) -> None:
    """Every vehicle's limit is read before anything is sent, and the directory judged once
    with each vehicle at its own limit (a reviewer: judged one vehicle at a time, vehicle 1
    was refused against a vehicle 2 at 20 m/s it would never fly, and vehicle 2 was sent)."""
    path, out = fleet2
    from lamde_mission.sorties import verify_sortie_dir
    from planner_core.model.mapio import load_map

    assert verify_sortie_dir(load_map(path), out).passed
    slow = verify_sortie_dir(load_map(path), out, {1: 12.0, 2: 12.0})
    assert not slow.passed  # both at 12 m/s: later over their sensors, TIMING loses its 30 s
    failed = "; ".join(slow.failed())
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0) as fleet:
        rc = main(["upload", str(out), "--fleet", *conn, "--map", str(path)])
        cap = capsys.readouterr()
        assert rc == 1
        # what --map judged first says so: at the planned speeds, the limits judged next (it
        # read "all constraints hold", then the refusal, as a contradiction)
        n = len(list(out.glob("mission-v*-s*.plan")))
        assert (f"simulator: all constraints hold on {path} for the {n} sorties of {out} at "
                "their planned speeds (as `verify MAP DIR/` judges them; a vehicle whose speed "
                "limit is lower is judged again at its limit before anything is sent)\n"
                ) in cap.out
        assert cap.err.strip() == (
            f"lamde-mission upload: {out}: vehicle 1 MPC_XY_VEL_MAX 12 m/s, vehicle 2 "
            "MPC_XY_VEL_MAX 12 m/s, below the 20 m/s the sorties ask (DO_CHANGE_SPEED), so "
            f"they fly at their limits, and at those speeds the simulator rejects the fleet on "
            f"{path}: {failed}; nothing sent to any vehicle (set the limit to 20 or more, or "
            "plan the map with uav.max_speed 12; --force sends it anyway)")
        assert all(sum(v.stats.uploads.values()) == 0 for v in fleet.vehicles)
        rc = main(["upload", str(out), "--fleet", *conn, "--map", str(path), "--force"])
        cap = capsys.readouterr()
        assert rc == 0, cap.out + cap.err
        assert "sent anyway (--force)" in cap.err
        assert cap.out.count("the vehicle's speed limit: MPC_XY_VEL_MAX 12 m/s") == 2
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0,
                   params={"MPC_XY_VEL_MAX": 20.0}):  # fmt: skip
        assert main(["upload", str(out), "--fleet", *conn, "--map", str(path)]) == 0
        assert "below the" not in capsys.readouterr().err
    # without --map: test_without_a_map_a_battery_sortie_below_its_speed_is_refused


def _sent(fleet: MockFleet) -> list[int]:
    """How many uploads each mock vehicle of `fleet` received."""
    return [sum(v.stats.uploads.values()) for v in fleet.vehicles]


def test_without_a_map_a_battery_sortie_below_its_speed_is_refused(fleet2, capsys) -> None:
    """A reviewer: `upload DIR/ --fleet` without --map sent a sortie planned at 20 m/s with
    0.27 Wh above the reserve to a PX4 vehicle at MPC_XY_VEL_MAX 12 (15.49 of 14.60 usable Wh
    at 12 m/s, as --map finds), exit 0, with a warning that never said energy was exceeded.
    fleet.json gives the sorties' energies but not the map's energy model: refused, nothing
    sent to any vehicle, naming the vehicle, its limit, the planned speed and energy and the
    fixes; --force sends it with a warning; a vehicle at or above 20 m/s is not named."""
    from lamde_mission.formats.fleet import read_fleet_dir

    path, out = fleet2
    fleet_json = read_fleet_dir(out)
    figures = {v.vehicle: v.sorties[0] for v in fleet_json.vehicles}
    assert all(s.energy_wh is not None and s.above_reserve_wh is not None
               for s in figures.values())  # fmt: skip

    def said(v: int) -> str:
        s = figures[v]
        return (f"vehicle {v}'s mission-v{v}-s1.plan: {s.energy_wh:.2f} Wh planned at 20 m/s, "
                f"{s.above_reserve_wh:.2f} Wh above the reserve")

    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0) as fleet:
        assert main(["upload", str(out), "--fleet", *conn]) == 1
        cap = capsys.readouterr()
        assert cap.err.strip() == (
            f"lamde-mission upload: {out}: vehicle 1 MPC_XY_VEL_MAX 12 m/s, vehicle 2 "
            "MPC_XY_VEL_MAX 12 m/s, below the 20 m/s the sorties ask (DO_CHANGE_SPEED), so "
            "they fly at their limits, and their energy at those speeds is unchecked "
            f"({said(1)}; {said(2)}; the sortie directory does not hold the map's energy "
            "model): nothing sent to any vehicle (--map MAP re-checks every sortie at the "
            "vehicles' limits; or set the limit to 20 or more, or plan the map with "
            "uav.max_speed 12; --force sends it anyway)")
        assert "hold their mission" not in cap.out and _sent(fleet) == [0, 0]
        # one vehicle at 20 m/s: only the other is named, and still nothing is sent
        fleet.vehicles[0].params["MPC_XY_VEL_MAX"] = 20.0
        assert main(["upload", str(out), "--fleet", *conn]) == 1
        err = capsys.readouterr().err
        assert f"{out}: vehicle 2 MPC_XY_VEL_MAX 12 m/s, below the 20 m/s" in err
        assert "vehicle 1 MPC" not in err and f"({said(2)}; the sortie" in err
        assert _sent(fleet) == [0, 0]
        fleet.vehicles[0].params["MPC_XY_VEL_MAX"] = 12.0
        # --force: sent, with the same words as a warning
        assert main(["upload", str(out), "--fleet", *conn, "--force"]) == 0
        cap = capsys.readouterr()
        assert (f"warning: {out}: vehicle 1 MPC_XY_VEL_MAX 12 m/s, vehicle 2 MPC_XY_VEL_MAX 12 "
                "m/s, below the 20 m/s the sorties ask (DO_CHANGE_SPEED), so they fly at their "
                f"limits, and their energy at those speeds is unchecked ({said(1)}; {said(2)}; "
                "the sortie directory does not hold the map's energy model); sent anyway "
                "(--force; --map MAP checks every sortie at the vehicles' limits)\n") in cap.err
        assert "fleet: 2 of 2 vehicles hold their mission, read back identical" in cap.out
        assert all(n > 0 for n in _sent(fleet))
    for limit in (20.0, 25.0):  # at or above the planned speed: nothing to say
        with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0,
                       params={"MPC_XY_VEL_MAX": limit}) as fleet:  # fmt: skip
            assert main(["upload", str(out), "--fleet", *conn]) == 0
            cap = capsys.readouterr()
            assert "below the" not in cap.err and "unchecked" not in cap.err
            assert "fleet: 2 of 2 vehicles hold their mission" in cap.out


def test_a_battery_sortie_uploaded_alone_below_its_speed_is_refused(fleet2, capsys) -> None:
    """`upload DIR/mission-v1-s1.plan` (the single-file path) of a sortie planned with a
    battery: the same refusal without --map, --force sends it; a standalone mission (no
    sortie directory, so no battery known) keeps its warning
    (`test_upload_reads_px4s_limit_and_says_what_it_changes`)."""
    from lamde_mission.formats.fleet import read_fleet_dir

    _path, out = fleet2
    s = read_fleet_dir(out).vehicles[0].sorties[0]
    sortie = out / "mission-v1-s1.plan"
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    head = (f"{sortie}: the vehicle's MPC_XY_VEL_MAX is 12 m/s, below the 20 m/s the mission "
            "asks (DO_CHANGE_SPEED), so it flies at 12 m/s, and its energy at that speed is "
            f"unchecked (a sortie of {out}/, {s.energy_wh:.2f} Wh planned at 20 m/s, "
            f"{s.above_reserve_wh:.2f} Wh above the reserve)")
    again = (f"`lamde-mission upload {out}/ --fleet --map MAP` checks every sortie at the "
             "vehicles' limits")
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0) as v:
        assert main(["upload", str(sortie), *conn]) == 1
        err = capsys.readouterr().err
        assert (f"lamde-mission upload: {head}: nothing sent ({again}; or set MPC_XY_VEL_MAX to "
                "20 or more, or plan the map with uav.max_speed 12; --force sends it anyway)"
                ) in err
        assert sum(v.stats.uploads.values()) == 0
        assert main(["upload", str(sortie), *conn, "--force"]) == 0
        err = capsys.readouterr().err
        assert f"warning: {head}; sent anyway (--force; {again})" in err
        assert len(v.items()) > 0


def test_without_a_battery_a_slow_fleet_is_warned_and_an_unsaid_battery_refused(
        tmp_path, capsys) -> None:
    """A sortie directory planned for a map without a battery (fleet.json: "energy_wh":
    null) has no energy to overdraw: a warning, sent. A fleet.json that gives no energy_wh
    at all does not say there is no battery: refused as one with a battery."""
    import json

    from tests.fleet_helpers import write_fleet_dir

    out = write_fleet_dir(tmp_path / "sorties", [[["S1", "S2"]], [["S3"]]])
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0) as fleet:
        assert main(["upload", str(out), "--fleet", *conn]) == 0
        err = capsys.readouterr().err
        assert (f"warning: {out}: vehicle 1 MPC_XY_VEL_MAX 12 m/s, vehicle 2 MPC_XY_VEL_MAX 12 "
                "m/s, below the 20 m/s the sorties ask (DO_CHANGE_SPEED), so they fly at their "
                "limits; their flight times, and the vehicles' separation and take-off times, "
                "were planned at 20 m/s (--map MAP checks the fleet at the limits; set the limit "
                "to 20 or more, or plan the map with uav.max_speed 12)") in err
        assert all(n > 0 for n in _sent(fleet))
    doc = json.loads((out / "fleet.json").read_text())
    for v in doc["vehicles"]:
        for s in v["sorties"]:
            del s["energy_wh"]
    (out / "fleet.json").write_text(json.dumps(doc))
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0) as fleet:
        assert main(["upload", str(out), "--fleet", *conn]) == 1
        err = capsys.readouterr().err
        assert ("their energy at those speeds is unchecked (vehicle 1's mission-v1-s1.plan: "
                "fleet.json gives no energy planned at 20 m/s; vehicle 2's mission-v2-s1.plan: "
                "fleet.json gives no energy planned at 20 m/s; the sortie directory") in err
        assert _sent(fleet) == [0, 0]


@pytest.mark.parametrize("limit", [0.0, -5.0, 0.001])
def test_a_speed_limit_no_mission_flies_at_is_refused(demo_plan, capsys, limit) -> None:
    """A vehicle saying MPC_XY_VEL_MAX 0 or -5 made upload exit 2 blaming the file
    ("speed_limit must be a positive speed"), and 0.001 m/s was judged and sent (t_fly of
    29 days). Below the sim's least mission speed it is refused, naming the parameter."""
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0,
                     params={"MPC_XY_VEL_MAX": limit}) as v:  # fmt: skip
        assert main(["upload", str(demo_plan), *conn, "--map", str(DEMO)]) == 1
        err = capsys.readouterr().err
        assert (f"{demo_plan}: the vehicle's MPC_XY_VEL_MAX is {limit:g} m/s, not a speed a "
                "mission can be flown at (at least 0.1 m/s): set MPC_XY_VEL_MAX on the vehicle; "
                "nothing sent") in err
        assert sum(v.stats.uploads.values()) == 0


def test_mock_vehicle_param_option_is_checked(capsys) -> None:
    for bad, said in (("NOEQUALS", "is not NAME=VALUE"), ("A=nan", "is not a number"),
                      ("WAY_TOO_LONG_PARAMETER=1", "is not NAME=VALUE"),
                      ("X=1e39", "is not a number")):
        assert main(["mock-vehicle", "--param", bad]) == 2
        assert said in capsys.readouterr().err


@pytest.mark.parametrize("via", ["pymavlink", pytest.param("mavsdk", marks=pytest.mark.slow)])
def test_autopilot_px4_on_an_ardupilot_vehicle_says_so_and_reads_no_px4_parameter(
        demo_plan, capsys, via) -> None:
    """--autopilot px4 on a vehicle whose HEARTBEAT says ArduPilot: the upload read PX4's
    MPC_XY_VEL_MAX from it, waited out the parameter timeout and said only that the vehicle
    did not answer. It now says the vehicle is ArduPilot, stores as asked and reads nothing
    (ArduPilot then keeps item 0 as its home: the read-back differs, exit 1, as it should)."""
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", via, "--timeout", "10"]
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0, autopilot="ardupilot"):
        assert main(["upload", str(demo_plan), *conn, "--map", str(DEMO),
                     "--autopilot", "px4"]) == 1  # fmt: skip
    cap = capsys.readouterr()
    said = cap.out + cap.err
    assert ("--autopilot px4, but the vehicle's HEARTBEAT says ardupilot: the mission is "
            "stored and compared as px4 asks") in said
    assert "MPC_XY_VEL_MAX is px4's and the vehicle says it is ardupilot: its speed limit is "\
        "not read" in said
    assert "did not say its MPC_XY_VEL_MAX" not in said
    assert "read-back differs from what was sent" in said


def test_a_vehicles_later_take_offs_move_at_its_limit_and_times_holds(tmp_path) -> None:
    """A reviewer: `upload DIR/ --fleet --map MAP` refused every vehicle of two sorties at
    PX4's default 12 m/s, whatever else held: at the limit sortie 2 takes off later than
    fleet.json's planned-speed time, and TIMES failed. Judged at the vehicles' limits TIMES
    holds and says how far the take-off moves (fleet.json's times are judged at the planned
    speeds); here a battery large enough for 12 m/s, so every check holds."""
    import json

    from lamde_mission.sorties import verify_sortie_dir
    from planner_core.model.mapio import load_map
    from tests.conftest import run_cli

    out = tmp_path / "demo"
    r = run_cli("plan", DEMO_FLEET, "-o", out, "--budget", 600, "--sortie-budget", 300,
                "--rounds", 0, "--quiet")
    assert r.returncode == 0, r.stderr
    fleet = json.loads((out / "fleet.json").read_text())
    assert len(fleet["vehicles"][0]["sorties"]) >= 2
    big = json.loads(DEMO_FLEET.read_text())
    big["uav"]["endurance_s"] = 600.0
    m = load_map(big)
    planned = verify_sortie_dir(m, out)
    # every check holds but FIGURES: fleet.json's reserves are the planned battery's, not this
    # larger one's (judged at the planned speeds only: at a limit the figures move by design)
    assert planned.failed() and all(x.startswith("fleet FIGURES: vehicle 1 sortie 1 "
                                                 "reserve_left_wh ") for x in planned.failed())
    slow = verify_sortie_dir(m, out, {1: 12.0})
    assert slow.passed, slow.failed()
    (times,) = [v for v in slow.fleet if v.name == "TIMES"]
    assert times.passed and "sortie 2 takes off at" in times.detail, times.detail
    assert "(planned speeds)" in times.detail


def test_the_python_upload_fleet_checks_the_limits_by_default_as_the_cli_does(fleet2,
                                                                            capsys) -> None:
    """A newcomer: the Python `upload_fleet` (docs/fleet.md's snippet, fleet_to_mock.py) sent
    sorties planned at 20 m/s with a battery to mocks at MPC_XY_VEL_MAX 12 and said nothing,
    while `upload DIR/ --fleet` refuses them. By default it now reads every limit and applies
    the CLI's check (`speeds.fleet_speed_check`): the same refusal, in the API's words, and
    nothing sent; `speed_check=None` skips it, force=True warns and sends, a map judges."""
    from lamde_mission.vehicle.fleet import first_sortie_missions, upload_fleet
    from lamde_mission.vehicle.speeds import (
        API_HINTS,
        CLI_HINTS,
        SpeedLimitWarning,
        fleet_speed_check,
    )
    from lamde_mission.vehicle.transfer import SpeedLimitError
    from planner_core.model.mapio import load_map

    path, out = fleet2
    missions = first_sortie_missions(out)
    assert [fm.sortie.path for fm in missions] == [out / fm.source for fm in missions]
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    api = {"connect": [f"udpin://127.0.0.1:{port}"], "via": "pymavlink", "timeout": 5,
           "window": 0.3}
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0) as fleet:
        assert main(["upload", str(out), "--fleet", *conn]) == 1
        cli = capsys.readouterr().err.strip().removeprefix("lamde-mission upload: ")
        with pytest.raises(SpeedLimitError) as exc:
            upload_fleet(missions, **api)
        assert _sent(fleet) == [0, 0]
        # one check, two sets of words: the CLI's options, the API's arguments
        said = str(exc.value)
        for cli_words, api_words in zip(CLI_HINTS, API_HINTS, strict=True):
            cli = cli.replace(cli_words, api_words)
        assert said == cli and "fleet_speed_check(..., force=True) sends it anyway" in said
        # with the map: judged at the limits, as `upload DIR/ --fleet --map MAP`
        with pytest.raises(SpeedLimitError, match="the simulator rejects the fleet on demo"):
            upload_fleet(missions, **api, speed_check=fleet_speed_check(
                missions, map=load_map(path), map_label="demo"))
        assert _sent(fleet) == [0, 0]
        with pytest.warns(SpeedLimitWarning, match="energy at those speeds is unchecked"):
            report = upload_fleet(missions, **api,
                                  speed_check=fleet_speed_check(missions, force=True))
        assert report.ok and all(n > 0 for n in _sent(fleet))
        report = upload_fleet(missions, **api, speed_check=None)  # the explicit skip
        assert report.ok
        assert all(r.report.speed_limit is None for r in report.results)  # nothing read
        with pytest.raises(ValueError, match='speed_check must be a function, "planned" or '
                                             "None"):
            upload_fleet(missions, **api, speed_check="default")
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0,
                   params={"MPC_XY_VEL_MAX": 20.0}):  # fmt: skip
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("error")
            report = upload_fleet(missions, **api)
        assert report.ok
        assert [r.report.speed_limit for r in report.results] == [("MPC_XY_VEL_MAX", 20.0)] * 2


def test_hand_made_fleet_missions_below_the_limit_are_warned_about(capsys) -> None:
    """Missions made by hand are no sorties of a directory: no planned energy is known, so,
    as a single mission's upload, a warning and sent (not refused)."""
    from lamde_mission.vehicle.fleet import FleetMission, upload_fleet
    from lamde_mission.vehicle.speeds import SpeedLimitWarning
    from tests.vehicle_helpers import hand_mission

    missions = [FleetMission(k + 1, hand_mission(k + 2), [], source=f"m{k + 1}")
                for k in range(2)]  # fmt: skip
    port = free_udp_port()
    with (MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0),
          pytest.warns(SpeedLimitWarning) as got):
        report = upload_fleet(missions, connect=[f"udpin://127.0.0.1:{port}"],
                              via="pymavlink", timeout=5, window=0.3)  # fmt: skip
    assert report.ok
    assert str(got[0].message).startswith(
        "the fleet: vehicle 1 MPC_XY_VEL_MAX 12 m/s, vehicle 2 MPC_XY_VEL_MAX 12 m/s, below the "
        "18 m/s the sorties ask (DO_CHANGE_SPEED)")


def test_the_documented_fleet_recipe_runs_as_written(fleet2, tmp_path) -> None:
    """docs/fleet.md, the README and fleet_to_mock.py gave `mock-vehicle --vehicles 3 &` then
    `upload sorties/ --fleet`: the mock says PX4's default MPC_XY_VEL_MAX, 12 m/s, below the
    sorties' 20 m/s, so every battery map was refused (exit 1). The mock keeps PX4's default
    (it stands for a PX4 vehicle; the refusal is what a real one gets); the recipes set the
    limit the sorties were planned at. Run here as written, on a free port."""
    import re
    import subprocess
    import sys

    from tests.conftest import ROOT

    texts = {name: (ROOT / name).read_text(encoding="utf-8")
             for name in ("docs/fleet.md", "README.md", "examples/fleet_to_mock.py")}
    recipe = "lamde-mission mock-vehicle --vehicles 3 --param MPC_XY_VEL_MAX=20"
    for name, text in texts.items():
        assert recipe in text, name
        assert not re.search(r"lamde-mission mock-vehicle --vehicles 3( *&|`)", text), name
    path, out = fleet2
    port = free_udp_port()
    argv = recipe.split()[1:]
    argv[argv.index("3")] = "2"  # fleet2 plans two UAVs
    proc = subprocess.Popen(
        [sys.executable, "-m", "lamde_mission.cli", *argv, "--connect",
         f"udpout:127.0.0.1:{port}", "--heartbeat-hz", "10"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert "2 vehicles" in proc.stdout.readline()
        rc = main(["upload", str(out), "--fleet", "--connect", f"udpin://127.0.0.1:{port}",
                   "--via", "pymavlink", "--timeout", "10"])  # fmt: skip
        assert rc == 0
    finally:
        proc.kill()
        proc.communicate()


def _api_words(cli: str, folder: object) -> str:
    """The CLI's line of a single mission's speed check in the API's words: each of
    MISSION_CLI_HINTS replaced by its MISSION_API_HINTS (the directory's clause first, as it
    holds "--map")."""
    from lamde_mission.vehicle.speeds import MISSION_API_HINTS, MISSION_CLI_HINTS

    pairs = list(zip(MISSION_CLI_HINTS, MISSION_API_HINTS, strict=True))
    for cli_words, api_words in reversed(pairs):
        cli = cli.replace(cli_words.replace("{dir}", str(folder)),
                          api_words.replace("{dir}", str(folder)))  # fmt: skip
    return cli


def test_the_python_upload_mission_checks_the_limit_by_default_as_the_cli_does(capsys) -> None:
    """The Python `upload_mission` read no speed limit unless given a speed_check, while
    `upload MISSION` checks it: by default it now reads MPC_XY_VEL_MAX and applies the CLI's
    check (`speeds.mission_speed_check`). Bare items have no battery known: below their speed
    a SpeedLimitWarning (on the caller's line) and sent, as the CLI does for a standalone
    .plan; a limit no mission flies at is refused, nothing sent; speed_check=None skips it."""
    import warnings

    from lamde_mission.vehicle import upload_mission
    from lamde_mission.vehicle.speeds import SpeedLimitWarning
    from lamde_mission.vehicle.transfer import SpeedLimitError
    from tests.vehicle_helpers import hand_mission

    mission = hand_mission(2)  # DO_CHANGE_SPEED 18 m/s
    port = free_udp_port()
    api = {"connect": f"udpin://127.0.0.1:{port}", "via": "pymavlink", "timeout": 5}
    with (MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0) as v,
          pytest.warns(SpeedLimitWarning) as got):  # fmt: skip
        report = upload_mission(mission, [], **api)
    assert report.ok and len(v.items()) == len(mission)
    assert report.speed_limit == ("MPC_XY_VEL_MAX", 12.0)
    assert [str(w.message) for w in got] == [
        "the mission: the vehicle's MPC_XY_VEL_MAX is 12 m/s, below the 18 m/s the mission asks "
        "(DO_CHANGE_SPEED), so it flies at 12 m/s; its flight time and energy were planned at "
        "18 m/s (mission_speed_check(..., map=MAP) checks it at 12 m/s; set MPC_XY_VEL_MAX to "
        "18 or more, or plan the map with uav.max_speed 12)"]
    assert got[0].filename == __file__  # the caller's line, not the library's
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0,
                     params={"MPC_XY_VEL_MAX": 0.0}) as v:  # fmt: skip
        with pytest.raises(SpeedLimitError) as exc:
            upload_mission(mission, [], **api)
        assert str(exc.value) == (
            "the mission: the vehicle's MPC_XY_VEL_MAX is 0 m/s, not a speed a mission can be "
            "flown at (at least 0.1 m/s): set MPC_XY_VEL_MAX on the vehicle; nothing sent")
        assert sum(v.stats.uploads.values()) == 0
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            report = upload_mission(mission, [], **api, speed_check=None)  # nothing read
        assert report.ok and report.speed_limit is None and len(v.items()) == len(mission)
        assert not any("speed limit" in line for line in report.lines())
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0,
                     params={"MPC_XY_VEL_MAX": 18.0}):  # fmt: skip
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            report = upload_mission(mission, [], **api)
        assert report.ok and report.speed_limit == ("MPC_XY_VEL_MAX", 18.0)
    with pytest.raises(ValueError, match='speed_check must be a function, "planned" or None'):
        upload_mission(mission, [], **api, speed_check="default")  # before any link is opened
    assert capsys.readouterr().err == ""


def test_upload_fleets_vehicles_are_not_checked_twice() -> None:
    """`upload_fleet` judges every vehicle's limit at once before sending; each vehicle's
    `upload_mission` then reads none again (no single-mission warning on top of the
    fleet's, and speed_check=None sends to vehicles below the missions' speed silently)."""
    import warnings

    from lamde_mission.vehicle.fleet import FleetMission, upload_fleet
    from tests.vehicle_helpers import hand_mission

    missions = [FleetMission(k + 1, hand_mission(k + 2), [], source=f"m{k + 1}")
                for k in range(2)]  # fmt: skip
    port = free_udp_port()
    with (MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0) as fleet,
          warnings.catch_warnings()):  # fmt: skip
        warnings.simplefilter("error")
        report = upload_fleet(missions, connect=[f"udpin://127.0.0.1:{port}"],
                              via="pymavlink", timeout=5, window=0.3, speed_check=None)
    assert report.ok and all(n > 0 for n in _sent(fleet))
    assert all(r.report.speed_limit is None for r in report.results)


def test_the_apis_refusal_of_a_battery_sortie_is_the_clis_but_for_the_hints(fleet2,
                                                                           capsys) -> None:
    """`mission_speed_check(items, source=FILE)` finds, as `upload FILE` does, that FILE is a
    sortie of a directory planned with a battery: the same refusal, word for word but for the
    hints (the CLI's options, the API's arguments), nothing sent; force=True warns and sends.
    The same items given bare (the default check) have no battery known: a warning, sent."""
    from lamde_mission.formats import read_mission
    from lamde_mission.vehicle import upload_mission
    from lamde_mission.vehicle.speeds import SpeedLimitWarning, mission_speed_check
    from lamde_mission.vehicle.transfer import SpeedLimitError

    _path, out = fleet2
    sortie = out / "mission-v1-s1.plan"
    items, fence = read_mission(sortie)
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    api = {"connect": f"udpin://127.0.0.1:{port}", "via": "pymavlink", "timeout": 5}
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=10.0) as v:
        assert main(["upload", str(sortie), *conn]) == 1
        cli = capsys.readouterr().err.strip().removeprefix("lamde-mission upload: ")
        with pytest.raises(SpeedLimitError) as exc:
            upload_mission(items, fence, **api,
                           speed_check=mission_speed_check(items, source=sortie))
        assert sum(v.stats.uploads.values()) == 0
        said = str(exc.value)
        assert said == _api_words(cli, out) and said != cli
        assert (f"(`sorties.verify_sortie_dir(MAP, '{out}', {{vehicle: limit}})` checks every "
                "sortie at the vehicles' limits; or set MPC_XY_VEL_MAX to 20 or more, or plan "
                "the map with uav.max_speed 12; mission_speed_check(..., force=True) sends it "
                "anyway)") in said
        # force: the CLI's --force warning, in the API's words, and sent
        assert main(["upload", str(sortie), *conn, "--force"]) == 0
        cli = capsys.readouterr().err
        with pytest.warns(SpeedLimitWarning) as got:
            report = upload_mission(items, fence, **api, speed_check=mission_speed_check(
                items, source=sortie, force=True))
        assert report.ok
        warned = str(got[0].message)
        assert f"warning: {warned}\n" in _api_words(cli, out)  # the whole line
        assert "; sent anyway (mission_speed_check(..., force=True); `sorties." in warned
        # bare items: no file, so no battery known: the default check warns and sends
        with pytest.warns(SpeedLimitWarning, match="^the mission: the vehicle's MPC_XY_VEL_MAX "
                                                   "is 12 m/s, below the 20 m/s"):
            assert upload_mission(items, fence, **api).ok
    with pytest.raises(ValueError, match="source: mission-v1-s1.plan is no file"):
        mission_speed_check(items, source="mission-v1-s1.plan")  # FleetMission.source: a name


def test_the_apis_verdicts_on_a_map_are_the_clis(demo_plan, fleet2, capsys) -> None:
    """With a map the check replays the mission at the limit as `upload MISSION --map MAP`
    does: the same note when every check holds, the same refusal (but for the hints) when
    one fails. Here the check is called as `upload_mission` calls it, once the limit is read."""
    from lamde_mission.commands.upload import _mission_speed_check
    from lamde_mission.formats import read_mission
    from lamde_mission.vehicle.speeds import mission_speed_check
    from planner_core.model.mapio import load_map

    items, _ = read_mission(demo_plan)
    notes: list[str] = []
    api = mission_speed_check(items, source=demo_plan, map=load_map(DEMO), map_label=str(DEMO),
                              note=notes.append)  # fmt: skip
    assert api("MPC_XY_VEL_MAX", 12.0) is None
    assert _mission_speed_check(str(demo_plan), items, str(DEMO), force=False)(
        "MPC_XY_VEL_MAX", 12.0) is None
    assert capsys.readouterr().out == f"note: {notes[0]}\n"
    assert "every check holds at that speed on" in notes[0]
    assert api("MPC_XY_VEL_MAX", 20.0) is None and len(notes) == 1  # at its speed: nothing
    # a sortie planned with a battery, replayed alone at 12 m/s on its map: checks fail
    path, out = fleet2
    sortie = out / "mission-v1-s1.plan"
    items, _ = read_mission(sortie)
    cli = _mission_speed_check(str(sortie), items, str(path), force=False)("MPC_XY_VEL_MAX", 12.0)
    said = mission_speed_check(items, source=sortie, map=lambda: load_map(path),
                               map_label=str(path))("MPC_XY_VEL_MAX", 12.0)  # fmt: skip
    assert cli is not None and said is not None
    assert f"at that speed the simulator rejects it on {path}: " in said
    assert said == _api_words(cli, out) and said.endswith(
        "nothing sent (set MPC_XY_VEL_MAX to 20 or more, or plan the map with uav.max_speed 12; "
        "mission_speed_check(..., force=True) sends it anyway)")
