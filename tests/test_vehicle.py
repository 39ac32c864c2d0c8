"""Upload + read-back through MAVSDK and through pymavlink, against the mock vehicle.

Every test takes a fresh UDP port on 127.0.0.1, and every mock/client is closed at its end.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from lamde_mission.cli import main
from lamde_mission.formats import read_mission, write_mission
from lamde_mission.items import MISSION_TYPE
from lamde_mission.vehicle.mock import MockVehicle
from lamde_mission.vehicle.transfer import (
    MissionRejectedError,
    NoVehicleError,
    ReadbackMismatchError,
)
from lamde_mission.vehicle.upload import upload_mission
from lamde_mission.vehicle.wire import compare_items
from planner_core.model.mapio import load_map
from tests.vehicle_helpers import free_udp_port, hand_fence, hand_mission, listen_on, mock_on
from tests.vehicle_helpers import no_leftover_mock_threads as _no_leftover_mock_threads  # noqa: F401 (autouse)

VIAS = ("mavsdk", "pymavlink")

MAP = {
    "name": "vehicle",
    "origin": {"lat": 47.3977, "lon": 8.5456, "alt": 488.0},
    "area": {"width": 2000, "height": 1500},
    "start": [100, 100],
    "end": [1900, 1400],
    "sensors": [{"id": "a", "x": 500, "y": 400}, {"id": "b", "x": 1400, "y": 900}],
    "obstacles": {
        "circles": [{"x": 1000, "y": 700, "radius": 60}],
        "rectangles": [{"x": 300, "y": 1100, "length": 120, "width": 50, "angle_deg": 35}],
        "no_fly_zones": [{"vertices": [[1500, 200], [1700, 250], [1600, 400]]}],
    },
    "uav": {"altitude": 80, "max_speed": 15},
}





@pytest.fixture(scope="module")
def plan_files(tmp_path_factory):
    """A .plan (mission + fence of 3 shapes) and a .waypoints of the same plan."""
    m = load_map(MAP)
    plan = SimpleNamespace(hover_points=np.array([[500, 420], [1400, 880]]),
                           hover_times=np.array([31.5, 47.25]))  # fmt: skip
    d = tmp_path_factory.mktemp("plans")
    return write_mission(d / "demo.plan", plan, m), write_mission(d / "demo.waypoints", plan, m)


# ----------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("via", VIAS)
def test_upload_and_read_back(via, port):
    mission, fence = hand_mission(3), hand_fence()
    with mock_on(port) as v:
        report = upload_mission(mission, fence, connect=listen_on(port), via=via, timeout=10)
        assert compare_items(mission, v.items(MISSION_TYPE.MISSION)) == []
        assert compare_items(fence, v.items(MISSION_TYPE.FENCE), "fence") == []
    assert report.ok and report.attempts == 1 and report.via == via
    assert (report.mission_items, report.fence_items) == (7, 5)
    assert report.vehicle.system_id == 1 and report.vehicle.autopilot == "PX4"
    assert report.connect_s < 2.0 and report.upload_s < 2.0 and report.verify_s < 2.0
    assert "identical" in report.lines()[-1]


def test_autopilot_and_vehicle_type_names_from_a_heartbeat():
    """One vocabulary for both uploaders' connection line (a newcomer review: MAVSDK printed
    "ARDUPILOT, multicopter" where pymavlink printed "ARDUPILOTMEGA, quadrotor")."""
    from pymavlink.dialects.v20 import common as m

    from lamde_mission.storage import dialect_for_autopilot
    from lamde_mission.vehicle.transfer import autopilot_name, vehicle_type_name

    assert autopilot_name(m.MAV_AUTOPILOT_PX4) == "PX4"
    assert autopilot_name(m.MAV_AUTOPILOT_ARDUPILOTMEGA) == "ArduPilot"
    assert autopilot_name(m.MAV_AUTOPILOT_GENERIC) == "generic"
    assert autopilot_name(m.MAV_AUTOPILOT_SLUGS) == "SLUGS"
    assert autopilot_name(m.MAV_AUTOPILOT_INVALID) is None and autopilot_name(200) is None
    # the storage rules still follow from the names
    assert [dialect_for_autopilot(autopilot_name(a)).name for a in (
        m.MAV_AUTOPILOT_PX4, m.MAV_AUTOPILOT_ARDUPILOTMEGA, m.MAV_AUTOPILOT_GENERIC,
        m.MAV_AUTOPILOT_SLUGS)] == ["px4", "ardupilot", "generic", "generic"]  # fmt: skip
    assert vehicle_type_name(m.MAV_TYPE_QUADROTOR) == "quadrotor"
    assert vehicle_type_name(m.MAV_TYPE_FIXED_WING) == "fixed wing"
    assert vehicle_type_name(m.MAV_TYPE_VTOL_TILTROTOR) == "vtol tiltrotor"
    assert vehicle_type_name(m.MAV_TYPE_ENUM_END) is None and vehicle_type_name(250) is None


@pytest.mark.parametrize(("autopilot", "words", "mavsdk_timeout"),
                         [("px4", "PX4, quadrotor", 1.0),
                          ("ardupilot", "ArduPilot, quadrotor", 1.6)])  # fmt: skip
def test_both_clients_name_the_same_vehicle_alike(port, autopilot, words, mavsdk_timeout):
    """The same vehicle, the same `VehicleInfo` and line through either client: MAVSDK's
    client names it from the HEARTBEAT its relay pinned, not MAVSDK's coarse classes."""
    from lamde_mission.vehicle.upload import make_client

    seen = {}
    with mock_on(port, autopilot=autopilot):
        for via in VIAS:
            with make_client(via, listen_on(port)) as client:
                seen[via] = client.connect(5.0)
                if via == "mavsdk":  # MAVSDK's upload message timeout still by autopilot
                    assert client.upload_message_timeout() == mavsdk_timeout
    assert seen["mavsdk"] == seen["pymavlink"]
    assert seen["mavsdk"].describe() == f"system 1, {words}"


@pytest.mark.parametrize("via", VIAS)
def test_fifty_items_round_trip(via, port):
    mission = hand_mission(46)
    assert len(mission) == 50
    with mock_on(port) as v:
        report = upload_mission(mission, [], connect=listen_on(port), via=via, timeout=10)
        got = v.items()
    assert report.ok and report.mission_items == 50
    assert len(got) == 50 and compare_items(mission, got) == []
    # lat/lon came back as int 1e7 degrees: within 1e-7 degree, and NaN yaw stayed NaN
    for a, b in zip(mission, got, strict=True):
        assert abs(a.x - b.x) <= 1e-7 and abs(a.y - b.y) <= 1e-7
    assert math.isnan(got[0].param4) and got[0].current == 1
    assert got[2].param1 == pytest.approx(mission[2].param1, rel=1e-7)  # float32 on the wire


@pytest.mark.parametrize("via", VIAS)
@pytest.mark.slow  # measured 16 s over 2 cases (issue 35: default suite <= 5 min)
def test_vehicle_side_rerequests_keep_an_upload_going(via, port):
    """20% of the mock's messages lost: 2 seeded uploads each, whole-transfer retries allowed."""
    mission, fence = hand_mission(4), hand_fence()
    for seed in (1, 2):
        with mock_on(port, loss=0.2, seed=seed) as v:
            t0 = time.monotonic()
            report = upload_mission(mission, fence, connect=listen_on(port), via=via, timeout=20,
                                    attempts=5)  # fmt: skip
            assert time.monotonic() - t0 < 60
            assert report.ok
            assert compare_items(mission, v.items()) == []
            assert v.stats.dropped > 0
        port = free_udp_port()


@pytest.mark.slow
@pytest.mark.parametrize("via", VIAS)
def test_twenty_seeded_uploads_with_20_percent_loss(via):
    mission, fence = hand_mission(6), hand_fence()
    for seed in range(20):
        port = free_udp_port()
        with mock_on(port, loss=0.2, seed=seed) as v:
            t0 = time.monotonic()
            report = upload_mission(mission, fence, connect=listen_on(port), via=via, timeout=20,
                                    attempts=5)  # fmt: skip
            took = time.monotonic() - t0
            assert report.ok, f"seed {seed}"
            assert took < 60, f"seed {seed}: {took:.1f} s"
            assert compare_items(fence, v.items(MISSION_TYPE.FENCE), "fence") == []


# ----------------------------------------------------------------------------- failures


@pytest.mark.parametrize("via", VIAS)
@pytest.mark.slow  # measured 2.1 s on a loaded machine (default suite <= 5 min)
def test_no_vehicle_times_out_within_the_timeout(via, port):
    t0 = time.monotonic()
    with pytest.raises(NoVehicleError, match="no vehicle heard at .* within 1 s") as info:
        upload_mission(hand_mission(1), [], connect=listen_on(port), via=via, timeout=1.0)
    assert 0.9 <= time.monotonic() - t0 < 3.0
    assert info.value.report is not None and not info.value.report.ok


@pytest.mark.parametrize(
    ("via", "name", "shown"),
    [("pymavlink", "MAV_MISSION_NO_SPACE", "MAV_MISSION_NO_SPACE"),
     ("mavsdk", "TOO_MANY_MISSION_ITEMS", "MAV_MISSION_NO_SPACE")],
)  # fmt: skip
def test_rejecting_vehicle_gives_its_code_by_name(via, name, shown, port):
    with mock_on(port, reject="MAV_MISSION_NO_SPACE") as v:
        with pytest.raises(MissionRejectedError) as info:
            upload_mission(hand_mission(2), [], connect=listen_on(port), via=via, timeout=10)
        assert v.items() == []
    exc = info.value
    assert exc.name == name and shown in str(exc)
    assert exc.report.attempts == 1  # a refusal is not retried


@pytest.mark.parametrize("via", VIAS)
def test_read_back_mismatch_names_item_and_field(via, port):
    def faulty(w):
        return replace(w, param1=w.param1 + 1.0) if w.seq == 3 and w.mission_type == 0 else w

    mismatch = pytest.raises(ReadbackMismatchError, match="mission item 3: param1")
    with mock_on(port, corrupt=faulty), mismatch as info:
        upload_mission(hand_mission(3), hand_fence(), connect=listen_on(port), via=via,
                       timeout=10, attempts=2)  # fmt: skip
    exc = info.value
    assert [(d.what, d.index, d.field) for d in exc.differences] == [("mission", 3, "param1")]
    assert exc.report.attempts == 2 and len(exc.report.errors) == 1


def test_empty_fence_clears_the_vehicles_fence_and_none_leaves_it(port):
    with mock_on(port) as v:
        v.set_items(hand_fence(), MISSION_TYPE.FENCE)
        upload_mission(hand_mission(1), None, connect=listen_on(port), via="pymavlink", timeout=5)
        assert len(v.items(MISSION_TYPE.FENCE)) == 5
        upload_mission(hand_mission(1), [], connect=listen_on(port), via="pymavlink", timeout=5)
        assert v.items(MISSION_TYPE.FENCE) == []


def test_items_mavlink_cannot_carry_are_refused_before_connecting(port):
    bad = [replace(hand_mission(1)[0], param1=1e40)]
    t0 = time.monotonic()
    with pytest.raises(ValueError, match="float32"):
        upload_mission(bad, [], connect=listen_on(port), via="pymavlink", timeout=5)
    assert time.monotonic() - t0 < 1.0


def test_mock_vehicle_as_udpin_and_client_as_udpout(port):
    mission = hand_mission(2)
    with MockVehicle(f"udpin:127.0.0.1:{port}") as v:
        for via in VIAS:
            report = upload_mission(mission, [], connect=f"udpout://127.0.0.1:{port}", via=via,
                                    timeout=10)  # fmt: skip
            assert report.ok and compare_items(mission, v.items()) == []


# ----------------------------------------------------------------------------- the CLI


@pytest.mark.parametrize("via", VIAS)
def test_cli_upload_plan(via, port, plan_files, capsys):
    plan_path, _ = plan_files
    mission, fence = read_mission(plan_path)
    with mock_on(port) as v:
        rc = main(["upload", str(plan_path), "--connect", listen_on(port), "--via", via,
                   "--timeout", "10"])  # fmt: skip
        assert compare_items(mission, v.items()) == []
        assert compare_items(fence, v.items(MISSION_TYPE.FENCE), "fence") == []
    out = capsys.readouterr().out
    assert rc == 0
    assert f"via {via}" in out and "identical" in out
    assert f"uploaded {len(mission)} mission items and {len(fence)} fence items" in out


def test_cli_upload_waypoints_uploads_the_same_mission_and_leaves_the_fence(
    port, plan_files, capsys
):
    plan_path, wp_path = plan_files
    mission_plan, _ = read_mission(plan_path)
    with mock_on(port) as v:
        v.set_items(hand_fence(), MISSION_TYPE.FENCE)
        rc = main(["upload", str(wp_path), "--connect", listen_on(port), "--via", "pymavlink",
                   "--timeout", "10"])  # fmt: skip
        got = v.items()
        assert len(v.items(MISSION_TYPE.FENCE)) == 5
    assert rc == 0 and "fence left as it is" in capsys.readouterr().out
    # the home line is not uploaded: item 0 is the TAKEOFF, as from the .plan (NaN yaw -> 0)
    assert [w.command for w in got] == [w.command for w in mission_plan]
    assert compare_items([it.without_nan() for it in mission_plan], got) == []


def test_cli_upload_errors(port, plan_files, tmp_path, capsys):
    plan_path, _ = plan_files
    assert main(["upload", str(tmp_path / "missing.plan")]) == 2
    assert "file not found" in capsys.readouterr().err
    bad = tmp_path / "bad.plan"
    bad.write_text("{not json")
    assert main(["upload", str(bad)]) == 2
    assert main(["upload", str(plan_path), "--attempts", "0"]) == 2
    assert main(["upload", str(plan_path), "--timeout", "-1"]) == 2
    capsys.readouterr()
    # MAVSDK turned 1e10 s into an immediate, false "no vehicle heard ... within 1e+10 s"
    for big in ("1e10", "3601"):
        assert main(["upload", str(plan_path), "--timeout", big]) == 2
        assert "--timeout must be a number of seconds in (0, 3600]" in capsys.readouterr().err
    with pytest.raises(ValueError, match=r"timeout must be a number of seconds in \(0, 3600\]"):
        upload_mission(hand_mission(1), connect=listen_on(port), timeout=1e10)
    # no vehicle: exit 1 within the timeout
    t0 = time.monotonic()
    rc = main(["upload", str(plan_path), "--connect", listen_on(port), "--via", "pymavlink",
               "--timeout", "0.5"])  # fmt: skip
    assert rc == 1 and time.monotonic() - t0 < 2.0
    assert "no vehicle heard" in capsys.readouterr().err
    # a rejecting vehicle: exit 1, the code by name
    with mock_on(port, reject="DENIED"):
        rc = main(["upload", str(plan_path), "--connect", listen_on(port), "--via", "pymavlink",
                   "--timeout", "5"])  # fmt: skip
    assert rc == 1 and "MAV_MISSION_DENIED" in capsys.readouterr().err


def _foreground_sigint() -> None:
    """In the child: SIGINT as a terminal's foreground process has it (default action, not
    blocked), whatever this test process inherited (e.g. a runner or a library that blocks or
    ignores SIGINT for its own children), so the signal below is the user's Ctrl-C."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow  # measured 2.1 s on a loaded machine (default suite <= 5 min)
def test_cli_mock_vehicle_runs_until_ctrl_c(port):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "lamde_mission.cli", "mock-vehicle", "--connect",
         f"udpout:127.0.0.1:{port}", "--loss", "0.1", "--seed", "3"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        preexec_fn=_foreground_sigint,
    )  # fmt: skip
    try:
        first = proc.stdout.readline()
        assert "mock vehicle" in first and f"127.0.0.1:{port}" in first and "loss 0.1" in first
        report = upload_mission(hand_mission(2), hand_fence(), connect=listen_on(port),
                                via="pymavlink", timeout=10, attempts=5)  # fmt: skip
        assert report.ok
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0
    assert "mission received: 6 items" in out and "stopped:" in err


def test_cli_mock_vehicle_bad_options():
    assert main(["mock-vehicle", "--loss", "1.5"]) == 2
    assert main(["mock-vehicle", "--reject", "NOT_A_CODE"]) == 2
    assert main(["mock-vehicle", "--connect", "tcp:1.2.3.4:5"]) == 2
