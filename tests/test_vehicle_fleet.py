"""Fleets (issue 33): the multi-vehicle mock, `upload DIR/ --fleet` through both uploaders on
one shared link and on one link per vehicle, its one-line errors, and `show MAP DIR/`.

Sortie directories are made by hand (`tests.fleet_helpers`: the existing .plan writer on
hand-made routes). Mocks send 10 HEARTBEATs a second and the API's survey listens 0.3 s, so
that a three-vehicle upload takes well under a second; the CLI keeps its 1.2 s survey.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest
from matplotlib.text import Text

from lamde_mission.cli import main
from lamde_mission.formats import read_mission
from lamde_mission.formats.fleet import FleetDirError, read_fleet_dir, sortie_file_name
from lamde_mission.vehicle.fleet import FleetMission, FleetSetupError, upload_fleet
from lamde_mission.vehicle.mock_fleet import MockFleet, fleet_system_ids, vehicle_connections
from lamde_mission.vehicle.transfer import NoVehicleError
from lamde_mission.vehicle.upload import upload_mission
from lamde_mission.vehicle.wire import compare_items, wire_mission
from tests.fleet_helpers import DEMO_MAP, ROOT, write_fleet_dir
from tests.vehicle_helpers import RawGcs, free_udp_port, hand_mission
from tests.vehicle_helpers import no_leftover_mock_threads as _no_leftover_mock_threads  # noqa: F401 (autouse)

VIAS = ("mavsdk", "pymavlink")
HZ = 10.0  # mock HEARTBEAT rate in these tests


def _missions(n: int) -> list[FleetMission]:
    """n different missions (vehicle k: k + 2 hovers), so a mix-up shows in the read-back."""
    return [FleetMission(k + 1, hand_mission(k + 2), [], source=f"m{k + 1}") for k in range(n)]


def _holds(vehicle, mission) -> bool:
    from lamde_mission.items import MISSION_TYPE

    return not compare_items(wire_mission(mission, MISSION_TYPE.MISSION), vehicle.wire_items())


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    """Three vehicles on small-demo: vehicle 1 flies two sorties (a swap at 'home'), vehicle 2
    leaves and lands at 'north', vehicle 3 one sortie from 'home'."""
    return write_fleet_dir(
        tmp_path_factory.mktemp("fleet") / "sorties",
        [[["S1", "S2"], ["S3"]], [["S4"]], [["S3", "S2"]]],
        depots={"home": (100.0, 100.0), "north": (1900.0, 1800.0)},
        sortie_depots=[[("home", "home"), ("home", "home")], [("north", "north")],
                       [("home", "home")]],
    )  # fmt: skip


@pytest.fixture(scope="module")
def fleet_map(tmp_path_factory):
    """small-demo with `fleet_dir`'s depots ('home', 'north') and three vehicles: the map
    `fleet_dir` is drawn on (a depot the map lacks is refused, as verify refuses it)."""
    doc = json.loads(DEMO_MAP.read_text())
    doc["fleet"] = {"uavs": 3, "depots": [{"name": "home", "x": 100.0, "y": 100.0},
                                          {"name": "north", "x": 1900.0, "y": 1800.0}]}
    path = tmp_path_factory.mktemp("fleet-map") / "small-demo.json"
    path.write_text(json.dumps(doc))
    return path


# ----------------------------------------------------------------------------- the mock


def test_one_link_carries_three_system_ids_from_one_address():
    port = free_udp_port()
    with RawGcs(port) as gcs, MockFleet(f"udpout:127.0.0.1:{port}", vehicles=3,
                                        heartbeat_hz=HZ) as fleet:  # fmt: skip
        seen: dict[int, set] = {}
        until = time.monotonic() + 1.0
        while time.monotonic() < until and len(seen) < 3:
            hb = gcs.wait("HEARTBEAT", 0.5)
            if hb is not None:
                seen.setdefault(hb.get_srcSystem(), set()).add(gcs.peer)
    assert sorted(seen) == [1, 2, 3] == fleet.system_ids
    assert len(set.union(*seen.values())) == 1  # one socket: one source address


def test_each_vehicle_answers_only_what_is_addressed_to_it():
    from pymavlink.dialects.v20 import common as m

    port = free_udp_port()
    with RawGcs(port) as gcs, MockFleet(f"udpout:127.0.0.1:{port}", system_ids=[4, 7],
                                        heartbeat_hz=HZ) as fleet:  # fmt: skip
        assert gcs.wait("HEARTBEAT", 1.0) is not None
        fleet.vehicle(7).set_items(hand_mission(1))
        gcs.drain()
        gcs.send(m.MAVLink_mission_request_list_message(7, 1, 0))
        count = gcs.wait("MISSION_COUNT", 1.0)
        assert count is not None and count.get_srcSystem() == 7 and count.count == 5
        assert gcs.wait("MISSION_COUNT", 0.3) is None  # system 4 kept quiet
        gcs.send(m.MAVLink_mission_request_list_message(4, 1, 0))
        count = gcs.wait("MISSION_COUNT", 1.0)
        assert count.get_srcSystem() == 4 and count.count == 0


def test_one_link_per_vehicle_on_consecutive_ports():
    base = free_udp_port()
    conns = vehicle_connections(f"udpout:127.0.0.1:{base}", 3)
    assert conns == [f"udpout:127.0.0.1:{base + k}" for k in range(3)]
    with MockFleet(conns[:2], heartbeat_hz=HZ) as fleet:
        assert not fleet.shared and fleet.connections() == conns[:2]
        assert [v.system_id for v in fleet.vehicles] == [1, 2]


@pytest.mark.parametrize(
    ("vehicles", "ids", "shown"),
    [(0, None, "at least 1"), (2, [1, 2, 3], "2 vehicles but 3 system ids"),
     (None, [1, 1], "given twice"), (None, [255], "255"), (None, [0], "0 is not")],
)  # fmt: skip
def test_bad_fleet_ids(vehicles, ids, shown):
    with pytest.raises(ValueError, match=shown):
        fleet_system_ids(vehicles, ids)


# ----------------------------------------------------------------------------- upload_fleet


@pytest.mark.parametrize("via", VIAS)
@pytest.mark.slow  # measured 1.4 s on a loaded machine (default suite <= 5 min)
def test_fleet_upload_on_one_shared_link(via):
    port = free_udp_port()
    missions = _missions(3)
    with MockFleet(f"udpout:127.0.0.1:{port}", system_ids=[5, 3, 9], heartbeat_hz=HZ) as fleet:
        report = upload_fleet(missions, connect=[f"udpin://127.0.0.1:{port}"], via=via,
                              timeout=5, window=0.3)  # fmt: skip
        assert report.ok, report.lines()
        # no --sysid: vehicles in ascending system id
        assert [(r.vehicle, r.system_id) for r in report.results] == [(1, 3), (2, 5), (3, 9)]
        for mission, sid in zip(missions, (3, 5, 9), strict=True):
            assert _holds(fleet.vehicle(sid), mission.mission)
    assert report.summary().startswith("fleet: 3 of 3 vehicles hold their mission")


@pytest.mark.parametrize("via", VIAS)
@pytest.mark.slow  # measured 1.8 s on a loaded machine (default suite <= 5 min)
def test_fleet_upload_one_link_per_vehicle_with_sysids(via):
    ports = [free_udp_port() for _ in range(3)]
    missions = _missions(3)
    with MockFleet([f"udpout:127.0.0.1:{p}" for p in ports], system_ids=[1, 2, 3],
                   heartbeat_hz=HZ) as fleet:  # fmt: skip
        report = upload_fleet(
            missions,
            connect=[f"udpin://127.0.0.1:{p}" for p in ports],
            system_ids=[1, 2, 3],
            via=via,
            timeout=5,
            window=0.3,
        )
        assert report.ok, report.lines()
        for mission, v in zip(missions, fleet.vehicles, strict=True):
            assert _holds(v, mission.mission)


@pytest.mark.parametrize("via", VIAS)
def test_fleet_upload_to_vehicles_that_listen(via):
    """Mocks on udpin answer whoever wrote last: the survey's ground-station HEARTBEAT is what
    makes them talk (as the single upload's does)."""
    port = free_udp_port()
    missions = _missions(3)
    with MockFleet(f"udpin:127.0.0.1:{port}", vehicles=3, heartbeat_hz=HZ) as fleet:
        report = upload_fleet(missions, connect=[f"udpout://127.0.0.1:{port}"], via=via,
                              timeout=5, window=0.3)  # fmt: skip
        assert report.ok, report.lines()
        for mission, v in zip(missions, fleet.vehicles, strict=True):
            assert _holds(v, mission.mission)


def test_sysid_order_maps_vehicles_to_ids():
    port = free_udp_port()
    missions = _missions(3)
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=3, heartbeat_hz=HZ) as fleet:
        report = upload_fleet(
            missions,
            connect=[f"udpin://127.0.0.1:{port}"],
            system_ids=[3, 1, 2],
            via="pymavlink",
            timeout=5,
            window=0.3,
        )
        assert report.ok
        for mission, sid in zip(missions, (3, 1, 2), strict=True):
            assert _holds(fleet.vehicle(sid), mission.mission)


@pytest.mark.parametrize(
    ("n", "connect", "ids", "shown"),
    [(2, 1, None, "2 missions but 3 vehicles answer"),
     (3, 1, [1, 2, 7], "vehicle 3: no HEARTBEAT from system 7"),
     (3, 2, None, "2 connections for 3 vehicles"),
     (3, 1, [1, 2], "2 system ids for 3 vehicles"),
     (3, 1, [1, 2, 2], "system id 2 given twice")],
)  # fmt: skip
def test_fleet_mismatch_sends_nothing(n, connect, ids, shown):
    port = free_udp_port()
    # one link each on its own port (one URL listed twice is refused up front: below)
    conns = [f"udpin://127.0.0.1:{p}" for p in [port, *(free_udp_port() for _ in
                                                         range(connect - 1))]]  # fmt: skip
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=3, heartbeat_hz=HZ) as fleet:
        with pytest.raises(FleetSetupError, match=shown):
            upload_fleet(_missions(n), connect=conns, system_ids=ids, via="pymavlink",
                         timeout=0.6, window=0.3)  # fmt: skip
        assert all(sum(v.stats.uploads.values()) == 0 for v in fleet.vehicles)


def test_two_autopilots_with_one_id_stop_the_survey(fleet_dir, capsys):
    """Systems 1, 2 on one socket and a second system 2 from another address: exit 1 (the
    link failed, not the command: upload's one rule) naming both addresses, nothing uploaded
    to anyone."""
    from lamde_mission.vehicle.mock import MockVehicle

    port = free_udp_port()
    with (
        MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=HZ) as fleet,
        MockVehicle(f"udpout:127.0.0.1:{port}", system_id=2, heartbeat_hz=HZ) as impostor,
    ):
        link = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "2"]
        rc = main(["upload", str(fleet_dir), "--fleet", "--sysid", "1,2,3", *link])
        err = capsys.readouterr().err
        assert rc == 1 and "two autopilots claim system 2 component 1" in err
        assert f"127.0.0.1:{impostor.address[1]}" in err
        assert all(sum(v.stats.uploads.values()) == 0 for v in [*fleet.vehicles, impostor])


def test_single_upload_picks_a_vehicle_by_system_id(fleet_dir, capsys):
    port = free_udp_port()
    one = fleet_dir / "mission-v2-s1.plan"
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=3, heartbeat_hz=HZ) as fleet:
        rc = main(["upload", str(one), "--sysid", "2", "--connect", f"udpin://127.0.0.1:{port}",
                   "--via", "pymavlink", "--timeout", "5"])  # fmt: skip
        assert rc == 0 and "connected to system 2" in capsys.readouterr().out
        assert _holds(fleet.vehicle(2), read_mission(one)[0])
        assert [len(v.items()) for v in (fleet.vehicle(1), fleet.vehicle(3))] == [0, 0]
        with pytest.raises(NoVehicleError, match=r"system id 8 .*\(heard only systems 1, 2, 3\)"):
            upload_mission(hand_mission(2), [], connect=f"udpin://127.0.0.1:{port}",
                           via="pymavlink", timeout=0.5, system_id=8,
                           heartbeat_watch=0.3)  # fmt: skip


# ----------------------------------------------------------------------------- the CLI


# the MAVSDK case measured 1.8 s (+1.1 s setup): slow (issue 35); upload_fleet through MAVSDK
# is tested in the default suite above
@pytest.mark.parametrize("via", [pytest.param("mavsdk", marks=pytest.mark.slow), "pymavlink"])
def test_cli_upload_fleet_dir(via, fleet_dir, capsys):
    port = free_udp_port()
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=3, heartbeat_hz=HZ) as fleet:
        rc = main(["upload", str(fleet_dir), "--fleet", "--connect",
                   f"udpin://127.0.0.1:{port}", "--via", via, "--timeout", "5"])  # fmt: skip
        out = capsys.readouterr().out
        assert rc == 0, out
        for k, v in enumerate(fleet.vehicles, start=1):  # each vehicle: its first sortie
            mission, _fence = read_mission(fleet_dir / sortie_file_name(k, 1))
            assert _holds(v, mission)
    assert "fleet: 3 of 3 vehicles hold their mission" in out
    assert "vehicle 2 (system 2" in out and "mission-v2-s1.plan" in out
    # a hand-made fleet.json without take-off times: the first sortie's is the launch_s (0)
    assert ("take off (sortie 1, s after vehicle 1's first take-off): vehicle 1 at +0 s, "
            "vehicle 2 at +0 s, vehicle 3 at +0 s;") in out


@pytest.mark.slow  # measured 1.7 s; upload_fleet on one link each runs in the default suite
def test_cli_upload_fleet_one_connection_each(fleet_dir, capsys):
    ports = [free_udp_port() for _ in range(3)]
    with MockFleet([f"udpout:127.0.0.1:{p}" for p in ports], system_ids=[11, 12, 13],
                   heartbeat_hz=HZ) as fleet:  # fmt: skip
        rc = main(
            [
                "upload",
                str(fleet_dir),
                "--fleet",
                "--via",
                "pymavlink",
                "--connect",
                ",".join(f"udpin://127.0.0.1:{p}" for p in ports),
                "--timeout",
                "5",
            ]
        )
        out = capsys.readouterr().out
        assert rc == 0, out
        assert [len(v.items()) for v in fleet.vehicles] == [
            len(read_mission(fleet_dir / sortie_file_name(k, 1))[0]) for k in (1, 2, 3)
        ]
    assert "vehicle 3 (system 13" in out


def test_cli_upload_fleet_second_sortie_after_the_swap(fleet_dir, capsys):
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=3, heartbeat_hz=HZ) as fleet:
        rc = main(["upload", str(fleet_dir), "--fleet", "--sortie", "2", *conn])
        out = capsys.readouterr().out
        assert rc == 0, out
        second, _fence = read_mission(fleet_dir / "mission-v1-s2.plan")
        assert _holds(fleet.vehicle(1), second)  # vehicle 1 flies two sorties
        assert [len(v.items()) for v in fleet.vehicles[1:]] == [0, 0]  # the others one
    assert "no sortie 2): no sortie planned, nothing sent" in out
    assert "fleet: 1 of 1 vehicle holds its mission" in out  # "1 of 1 vehicles hold their"
    assert "2 without this sortie, nothing sent" in out
    assert "take off (sortie 2, s after vehicle 1's first take-off): vehicle 1 at a time " \
        "fleet.json does not give;" in out
    rc = main(["upload", str(fleet_dir), "--fleet", "--sortie", "3", *conn])
    assert rc == 2 and "no vehicle flies a sortie 3" in capsys.readouterr().err


def _one_line_exit_2(capsys, argv, status: int = 2) -> str:
    rc = main(argv)
    err = capsys.readouterr().err.strip()
    assert rc == status and len(err.splitlines()) == 1, (rc, err)
    return err


def test_cli_upload_fleet_errors(fleet_dir, tmp_path, capsys):
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "0.5"]
    # a directory without fleet.json
    empty = tmp_path / "empty"
    empty.mkdir()
    assert "fleet.json: no such file" in _one_line_exit_2(
        capsys, ["upload", str(empty), "--fleet", *conn]
    )
    # fleet.json naming a sortie file that is not there
    broken = tmp_path / "broken"
    shutil.copytree(fleet_dir, broken)
    (broken / "mission-v2-s1.plan").unlink()
    assert "mission-v2-s1.plan: no such file (vehicle 2, sortie 1" in _one_line_exit_2(
        capsys, ["upload", str(broken), "--fleet", *conn]
    )
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=HZ) as fleet:
        # fleet.json plans 3 vehicles, 2 answer: the link's answer, exit 1 (was 2)
        err = _one_line_exit_2(capsys, ["upload", str(fleet_dir), "--fleet", *conn], 1)
        assert "3 missions but 2 vehicles answer" in err and "nothing was uploaded" in err
        # a vehicle missing: exit 1, as a single upload's vehicle that does not answer
        err = _one_line_exit_2(capsys, ["upload", str(fleet_dir), "--fleet", *conn,
                                        "--sysid", "1,2,3"], 1)  # fmt: skip
        assert "vehicle 3: no HEARTBEAT from system 3" in err
        assert all(sum(v.stats.uploads.values()) == 0 for v in fleet.vehicles)
    assert "--sysid: 'x' is not" in _one_line_exit_2(
        capsys, ["upload", str(fleet_dir), "--fleet", *conn, "--sysid", "1,x,3"]
    )
    # --map replays the whole directory first (tests/test_sorties_dir.py): small-demo has no
    # depot 'north', so this one is refused naming it
    assert "vehicle 2 sortie 1 (mission-v2-s1.plan) takes off at depot 'north'" in _one_line_exit_2(
        capsys, ["upload", str(fleet_dir), "--fleet", *conn, "--map", str(DEMO_MAP)]
    )
    assert "add --fleet" in _one_line_exit_2(capsys, ["upload", str(fleet_dir), *conn])
    one = str(fleet_dir / "mission-v1-s1.plan")
    assert "2 system ids for one mission" in _one_line_exit_2(
        capsys, ["upload", one, *conn, "--sysid", "1,2"]
    )


def test_upload_force_warns_of_a_rejected_file_in_one_line_naming_the_map(fleet_dir, capsys):
    """The single file's --force printed one warning per failed check and no map ("warning:
    F: the simulator rejects it (C4 ...); sent anyway"), the sortie directory's one line naming
    the map: both now go through one helper (upload._rejected), refusal and warning alike."""
    from lamde_mission.commands import upload as U

    one = str(fleet_dir / "mission-v1-s1.plan")
    mission, _ = read_mission(one)
    assert U._sim_check(one, str(DEMO_MAP), mission, force=True) is True
    err = capsys.readouterr().err
    assert err.startswith(f"warning: {one}: the simulator rejects it on {DEMO_MAP} (C4 ")
    assert err.endswith("); sent anyway (--force)\n") and err.count("\n") == 1, err
    assert U._sim_check(one, str(DEMO_MAP), mission, force=False) is False
    refused = capsys.readouterr().err
    assert refused.startswith(f"lamde-mission upload: {one}: the simulator rejects it on "
                              f"{DEMO_MAP}: C4 ") and refused.count("\n") == 1


def test_cli_upload_exit_status_single_file_and_fleet_alike(fleet_dir, capsys):
    """upload's one rule (README, docs/fleet.md, `upload --help`): 1 when a check or the link
    fails, 2 for bad input. The single upload refused what the simulator rejects with 2 (the
    fleet: 1), and the fleet exited 2 when no vehicle answered (the single upload: 1)."""
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "0.5",
            "--attempts", "1"]  # fmt: skip
    one = str(fleet_dir / "mission-v1-s1.plan")
    # the simulator rejects it (C4: the sortie serves 2 of small-demo's 4 sensors); no link
    err = _one_line_exit_2(capsys, ["upload", one, *conn, "--map", str(DEMO_MAP)], 1)
    assert err.startswith(f"lamde-mission upload: {one}: the simulator rejects it on ")
    assert "C4" in err and "nothing sent" in err and "--force" in err
    # no vehicle answers: 1 both ways
    err = _one_line_exit_2(capsys, ["upload", one, *conn], 1)
    assert "no vehicle heard" in err
    err = _one_line_exit_2(capsys, ["upload", str(fleet_dir), "--fleet", *conn], 1)
    assert "3 missions but 0 vehicles answer" in err and "nothing was uploaded" in err
    # bad input: 2 both ways
    for target in ([one], [str(fleet_dir), "--fleet"]):
        assert "--attempts must be at least 1" in _one_line_exit_2(
            capsys, ["upload", *target, *conn[:-2], "--attempts", "0"])
    two = f"udpin://127.0.0.1:{port},udpin://127.0.0.1:{free_udp_port()}"
    assert "--connect: 2 connections for 3 vehicles" in _one_line_exit_2(
        capsys, ["upload", str(fleet_dir), "--fleet", *conn[2:], "--connect", two])


def test_cli_upload_fleet_refuses_a_connection_listed_twice(fleet_dir, capsys):
    # it failed late, after the survey, with "Address already in use" (exit 1)
    a, b = free_udp_port(), free_udp_port()
    for connect, shown in (
        (f"udpin://127.0.0.1:{a},udpin://127.0.0.1:{b},udpin://127.0.0.1:{a}",
         f"--connect: udpin://127.0.0.1:{a} listed twice"),
        (f"udpin://0.0.0.0:{a},udpin://127.0.0.1:{b},udpin:127.0.0.1:{a}",
         f"--connect: udpin:127.0.0.1:{a} listed twice (as udpin://0.0.0.0:{a})"),
    ):
        t0 = time.monotonic()
        err = _one_line_exit_2(capsys, ["upload", str(fleet_dir), "--fleet", "--connect",
                                        connect, "--via", "pymavlink", "--timeout", "5"])
        assert err == f"lamde-mission upload: {shown}"
        assert time.monotonic() - t0 < 1.0  # up front: no survey
    # the API refuses it too, before anything is opened
    with pytest.raises(ValueError, match=f"udpin://127.0.0.1:{a} listed twice"):
        upload_fleet(_missions(2), connect=[f"udpin://127.0.0.1:{a}"] * 2, timeout=1)


@pytest.mark.parametrize(
    ("doc", "shown"),
    [({"vehicles": []}, "vehicles: expected a non-empty list"),
     ({"vehicles": [{"vehicle": 2, "sorties": []}]}, "vehicles[0].vehicle: expected 1"),
     ({"vehicles": [{"vehicle": 1, "sorties": [{"sortie": 1, "file": "../x.plan"}]}]},
      "sorties[0].file: expected a file name inside"),
     ({"vehicles": [{"vehicle": 1, "sorties": [{"sortie": 2}]}]}, "sorties[0].sortie"),
     ({"vehicles": [{"vehicle": 1, "sorties": [{"sortie": 1, "duration_s": "long"}]}]},
      "duration_s: expected a finite number")],
)  # fmt: skip
def test_bad_fleet_json_names_the_field(tmp_path, fleet_dir, doc, shown):
    d = tmp_path / "d"
    shutil.copytree(fleet_dir, d)
    (d / "fleet.json").write_text(json.dumps(doc))
    with pytest.raises(FleetDirError) as exc:
        read_fleet_dir(d)
    assert shown in str(exc.value) and "\n" not in str(exc.value)


def test_fleet_json_lists_at_most_the_sorties_and_vehicles_a_plan_holds(tmp_path, fleet_dir,
                                                                        capsys):
    """fleet.json with 20,000 sorties of one file (1.6 MB: verify took 83 s and printed 260,006
    lines) or 101 vehicles: one line naming the field, exit 2, before any sortie is read; the
    writer refuses a plan it could not read back."""
    from types import SimpleNamespace

    from lamde_mission.formats.fleet import MAX_FLEET_SORTIES, MAX_FLEET_VEHICLES
    from lamde_mission.sorties import write_sortie_dir

    assert (MAX_FLEET_SORTIES, MAX_FLEET_VEHICLES) == (1000, 100)
    d = tmp_path / "d"
    shutil.copytree(fleet_dir, d)
    one = read_fleet_dir(d).vehicles[0].sorties[0].path.name
    many = [{"sortie": j + 1, "file": one} for j in range(20_000)]
    (d / "fleet.json").write_text(json.dumps({"vehicles": [{"vehicle": 1, "sorties": many}]}))
    with pytest.raises(FleetDirError, match=r"vehicles\[\]\.sorties: 20,000 sorties in all, "
                       r"more than 1,000, the most a sortie directory holds$"):
        read_fleet_dir(d)
    assert main(["verify", str(DEMO_MAP), str(d)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "20,000 sorties in all" in err[0], err
    vs = [{"vehicle": k + 1, "sorties": []} for k in range(101)]
    (d / "fleet.json").write_text(json.dumps({"vehicles": vs}))
    with pytest.raises(FleetDirError, match=r"vehicles: 101 vehicles, more than 100"):
        read_fleet_dir(d)
    big = SimpleNamespace(settings=SimpleNamespace(goal="total"), vehicles=[[None] * 1001])
    # "on 1 vehicles": a count names its noun in the singular for 1 (textio.counted)
    with pytest.raises(ValueError, match="1,001 sorties on 1 vehicle, more than a sortie"):
        write_sortie_dir(big, None, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_fleet_dir_reads_back(fleet_dir):
    fleet = read_fleet_dir(fleet_dir)
    assert [len(v.sorties) for v in fleet.vehicles] == [2, 1, 1]
    assert [s.path.name for s in fleet.first_sorties()] == [
        "mission-v1-s1.plan",
        "mission-v2-s1.plan",
        "mission-v3-s1.plan",
    ]
    assert fleet.vehicles[1].sorties[0].depot_start == "north" and fleet.swaps == 1


def _free_consecutive_ports(n: int) -> int:
    """The first of n consecutive UDP ports on 127.0.0.1 that are free right now."""
    import socket

    for _ in range(50):
        base = free_udp_port()
        socks = []
        try:
            for k in range(n):
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                socks.append(s)
                s.bind(("127.0.0.1", base + k))
            return base
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
    raise RuntimeError(f"no {n} consecutive free UDP ports")


def _foreground_sigint() -> None:
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow  # measured 1.8 s (a subprocess); MockFleet itself runs in the default suite
@pytest.mark.parametrize("ports", [False, True])
def test_cli_mock_vehicle_fleet_runs_until_ctrl_c(ports):
    """`--vehicles 3` on one link; `--sysids 1,2,3 --ports` one link each (port + i)."""
    port = free_udp_port() if not ports else _free_consecutive_ports(3)
    how = ["--vehicles", "3"] if not ports else ["--sysids", "1,2,3", "--ports"]
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "lamde_mission.cli", "mock-vehicle", *how,
         "--connect", f"udpout:127.0.0.1:{port}", "--heartbeat-hz", "10"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        preexec_fn=_foreground_sigint,
    )  # fmt: skip
    try:
        first = proc.stdout.readline()
        assert "3 vehicles (systems 1, 2, 3" in first
        links = [port + k for k in range(3)] if ports else [port]
        if ports:  # then one line per link
            for k, p in enumerate(links, start=1):
                assert f"system {k}: sending to 127.0.0.1:{p}" in proc.stdout.readline()
        else:
            assert f"127.0.0.1:{port}" in first
        report = upload_fleet(_missions(3), connect=[f"udpin://127.0.0.1:{p}" for p in links],
                              via="pymavlink", timeout=5, window=0.3)  # fmt: skip
        assert report.ok
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0
    for sid, n in ((1, 6), (2, 7), (3, 8)):
        assert f"system {sid}: mission received: {n} items" in out
        assert f"stopped system {sid}:" in err


@pytest.mark.parametrize(
    ("argv", "shown"),
    [(["--vehicles", "0"], "at least 1"), (["--sysids", "1,1"], "given twice"),
     (["--ports"], "need --vehicles"), (["--vehicles", "2", "--sysids", "1,2,3"], "3 system"),
     (["--vehicles", "2", "--heartbeat-hz", "0"], "--heartbeat-hz")],
)  # fmt: skip
def test_cli_mock_vehicle_fleet_bad_options(argv, shown, capsys):
    assert main(["mock-vehicle", *argv]) == 2
    assert shown in capsys.readouterr().err


# ----------------------------------------------------------------------------- show DIR/


def test_fleet_figure_marks_vehicles_sorties_depots_and_swaps(fleet_dir, fleet_map):
    from lamde_mission.commands.show import fleet_views
    from lamde_mission.plot import fleet_figure
    from planner_core.model.mapio import load_map

    m = load_map(fleet_map)
    views = fleet_views(fleet_dir, m)
    assert [(v.vehicle, v.sortie) for v in views] == [(1, 1), (1, 2), (2, 1), (3, 1)]
    fig = fleet_figure(m, views)
    texts = [t.get_text() for t in fig.findobj(Text) if t.get_text()]
    assert "map 'small-demo': 3 vehicles, 4 sorties, 1 swap" in texts
    assert "v1 swap 1" in texts and "home" in texts and "north" in texts
    assert "vehicle 1: 2 sorties" in texts and "sortie 2" in texts and "battery swap" in texts
    assert "2.1 · " in " ".join(texts)  # vehicle 1's second sortie, first hover point
    # one colour per vehicle: the three route colours differ
    colours = {
        tuple(line.get_color())
        for line in fig.axes[0].get_lines()
        if line.get_linestyle() in ("-", "--") and line.get_linewidth() == 1.6
    }
    assert len(colours) == 3


def test_a_vehicles_sorties_past_four_keep_their_own_line_styles(tmp_path):
    """A newcomer: after sortie 4 the line styles repeated (vehicle 2's sorties 1 and 5 both
    solid) and the legend listed sorties 1-4 only. Eight styles now (`sortie_style`), every
    one a vehicle flies in the legend; past eight, the legend names the sorties sharing a
    style ("sorties 1, 9")."""
    from matplotlib.lines import _get_dash_pattern

    from lamde_mission.commands.show import fleet_views
    from lamde_mission.plot import SORTIE_STYLES, _style_label, fleet_figure, sortie_style
    from planner_core.model.mapio import load_map

    patterns = [_get_dash_pattern(s) for s in SORTIE_STYLES]
    assert len(SORTIE_STYLES) == 8 and len({(o, tuple(d or ())) for o, d in patterns}) == 8
    assert sortie_style(5) != sortie_style(1) and sortie_style(9) == sortie_style(1)
    ids = ["S1", "S2", "S3", "S4"]
    d = write_fleet_dir(tmp_path / "d", [[["S1"]], [[ids[j % 4]] for j in range(10)]])
    m = load_map(DEMO_MAP)
    fig = fleet_figure(m, fleet_views(d, m))
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    sorties = [t for t in legend if t.startswith("sortie")]
    assert sorties == ["sorties 1, 9", "sorties 2, 10", *(f"sortie {j}" for j in range(3, 9))]
    from lamde_mission.plot import _vehicle_colour

    two = [ln for ln in fig.axes[0].get_lines() if ln.get_linewidth() == 1.6
           and tuple(ln.get_color()) == tuple(_vehicle_colour(2))]  # fmt: skip
    drawn = [(o, tuple(p or ())) for o, p in (ln._unscaled_dash_pattern for ln in two)]
    assert len(two) == 10 and len(set(drawn)) == 8  # sorties 1-8 apart, 9 and 10 again
    assert drawn[:8] == [(o, tuple(p or ())) for o, p in patterns]
    assert _style_label(1, 40) == "sorties 1, 9, 17, ..., 33"


def test_cli_show_fleet_dir(fleet_dir, fleet_map, tmp_path, capsys):
    out = tmp_path / "fleet.png"
    assert main(["show", str(fleet_map), str(fleet_dir), "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = tmp_path / "nofleet"
    bad.mkdir()
    rc = main(["show", str(DEMO_MAP), str(bad), "-o", str(tmp_path / "x.png")])
    assert rc == 2 and "fleet.json: no such file" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_a_picture_inside_the_sortie_directory_is_refused_up_front(fleet_dir, fleet_map,
                                                                   tmp_path, capsys):
    """`plan MAP -o dd/ --plot dd/fleet.png --mkdir` wrote both, and the next `plan -o dd/`
    refused dd/ for holding fleet.png; `show MAP DIR/ -o DIR/x.png` did the same. Now both are
    refused before any work: exit 2, one line naming the option, nothing written or made."""
    fleet_map = ROOT / "examples" / "maps" / "fleet-demo.json"
    new = tmp_path / "dd"
    for plot in (new / "fleet.png", new / "pics" / "fleet.png"):
        err = _one_line_exit_2(capsys, ["plan", str(fleet_map), "-o", str(new), "--plot",
                                        str(plot), "--mkdir"])  # fmt: skip
        assert err == (f"lamde-mission plan: --plot: {plot} is inside the sortie directory "
                       f"{new}, which holds nothing but fleet.json and its missions (plan "
                       "replaces it whole, and refuses a folder holding anything else); write "
                       "it beside that folder")
        assert not new.exists()
    earlier = tmp_path / "earlier"
    shutil.copytree(fleet_dir, earlier)
    before = sorted(p.name for p in earlier.iterdir())
    link = tmp_path / "link"
    link.symlink_to(earlier)  # the same folder by another name
    for plot in (earlier / "fleet.png", link / "fleet.png"):
        err = _one_line_exit_2(capsys, ["plan", str(fleet_map), "-o", str(earlier), "--plot",
                                        str(plot)])  # fmt: skip
        assert err.startswith(f"lamde-mission plan: --plot: {plot} is inside the sortie ")
        err = _one_line_exit_2(capsys, ["show", str(DEMO_MAP), str(earlier), "-o", str(plot)])
        assert err.startswith(f"lamde-mission show: -o/--output: {plot} is inside the sortie ")
    err = _one_line_exit_2(capsys, ["show", str(DEMO_MAP), str(earlier), "-o",
                                    str(earlier / "pics" / "x.svg")])  # fmt: skip
    assert "is inside the sortie directory" in err
    assert sorted(p.name for p in earlier.iterdir()) == before
    # beside the folder is fine
    assert main(["show", str(fleet_map), str(earlier), "-o", str(tmp_path / "earlier.png")]) == 0


# ----------------------------------------------------------------------------- the example


@pytest.mark.slow  # measured 18 s (the fleet plan dominates), per case
@pytest.mark.parametrize("argv", [[], ["--via", "mavsdk", "--ports"]])
def test_fleet_to_mock_example_runs(argv):
    r = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "fleet_to_mock.py"), *argv],
        capture_output=True, text=True, timeout=600, cwd=ROOT,
    )  # fmt: skip
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "fleet: 3 of 3 vehicles hold their mission, read back identical" in r.stdout
    for k in (1, 2, 3):
        assert f"equal to mission-v{k}-s1.plan" in r.stdout


@pytest.mark.slow  # measured 5-7 s (a short fleet plan)
def test_cli_plan_plot_draws_the_sortie_directory(tmp_path, capsys):
    fleet_map = ROOT / "examples" / "maps" / "fleet-demo.json"
    out, png = tmp_path / "sorties", tmp_path / "sorties.png"
    rc = main(["plan", str(fleet_map), "-o", str(out), "--plot", str(png), "--budget", "200",
               "--population", "20", "--sortie-budget", "100", "--rounds", "1"])  # fmt: skip
    assert rc == 0 and (out / "fleet.json").is_file()
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {png}" in capsys.readouterr().out
    # the output checks come before any planning: a missing folder, a bad suffix
    for bad, shown in ((tmp_path / "no" / "x.png", "does not exist"), (tmp_path / "x.gif", "PNG")):
        assert main(["plan", str(fleet_map), "-o", str(tmp_path / "d2"), "--plot", str(bad)]) == 2
        assert shown in capsys.readouterr().err
    assert not (tmp_path / "d2").exists()


def test_swaps_at_one_depot_share_one_label(tmp_path):
    """A field crew's reviewer: "v1 swap 1", "v1 swap 2" and "v3 swap 1" at one depot were
    three labels on one spot and overlapped. One label per place now."""
    from lamde_mission.commands.show import fleet_views
    from lamde_mission.plot import _swap_text, fleet_figure
    from planner_core.model.mapio import load_map

    assert _swap_text([(3, 1), (1, 2), (1, 1)]) == "v1 swaps 1, 2; v3 swap 1"
    assert _swap_text([(2, 1)]) == "v2 swap 1"
    d = write_fleet_dir(tmp_path / "d", [[["S1"], ["S2"], ["S3"]], [["S4"], ["S1"]]])
    m = load_map(DEMO_MAP)
    fig = fleet_figure(m, fleet_views(d, m))
    texts = [t.get_text() for t in fig.findobj(Text) if t.get_text()]
    assert "v1 swaps 1, 2; v2 swap 1" in texts
    assert not any(t.startswith("v1 swap 1") or t == "v2 swap 1" for t in texts)
