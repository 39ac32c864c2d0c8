"""The vehicle's own speed limit at upload (a field crew's reviewer: PX4 flies a mission's
DO_CHANGE_SPEED at most at MPC_XY_VEL_MAX, 12 m/s by default, so a sortie planned at 20 m/s
with 0.3 Wh above the reserve drew 62.7 of 56.2 usable Wh, and upload said nothing). upload
reads the parameter after connecting, before sending: a warning without --map; with --map the
simulator's verdicts at the limit, refused (exit 1, nothing sent) when one fails."""

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
        assert "speed limit" not in capsys.readouterr().out  # nothing caps it there


def test_a_fleet_is_judged_once_with_every_vehicle_at_its_limit_before_sending(tmp_path,
                                                                              capsys) -> None:
    """Every vehicle's limit is read before anything is sent, and the directory judged once
    with each vehicle at its own limit (a reviewer: judged one vehicle at a time, vehicle 1
    was refused against a vehicle 2 at 20 m/s it would never fly, and vehicle 2 was sent)."""
    from tests.fleet_helpers import plan_fleet_demo

    path, out = plan_fleet_demo(tmp_path)
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
    # without --map it is sent with a warning that says what the slower flight puts at risk:
    # the reviewer's vehicles at 12 m/s came 28.7 m close, and it spoke of energy only
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0):
        assert main(["upload", str(out), "--fleet", *conn]) == 0
        err = capsys.readouterr().err
        assert ("their flight times and energy, and the vehicles' separation and take-off "
                "times, were planned at 20 m/s (--map checks the fleet at the limits") in err


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
