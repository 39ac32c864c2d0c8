"""Each sortie's take-off time on the plan's clock (a field crew's reviewer: after the first
sortie nothing said when a vehicle relaunches, though SEPARATION and LINKS hold only at the
times the plan was judged at): fleet.json's `takeoff_s` / `landing_s`, `plan`'s and `verify`'s
lines, and `upload --fleet --sortie K`."""

from __future__ import annotations

import json

import pytest

from lamde_mission.cli import main
from lamde_mission.formats.fleet import read_fleet_dir


@pytest.fixture(scope="module")
def two_uavs(tmp_path_factory):
    """fleet-demo flown by 2 UAVs on a 300 s battery: 3 sorties, vehicle 1 flies two (a swap)."""
    from tests.fleet_helpers import plan_fleet_demo

    return plan_fleet_demo(tmp_path_factory.mktemp("takeoff"), endurance_s=300.0)


def test_fleet_json_gives_each_sortie_its_take_off_and_landing(two_uavs, capsys) -> None:
    path, out = two_uavs
    doc = json.loads((out / "fleet.json").read_text())
    swap = json.loads(path.read_text())["fleet"]["swap_s"]
    sorties = 0
    for v in doc["vehicles"]:
        clock = v["launch_s"]  # by hand: launch, then sorties back to back with a swap between
        for s in v["sorties"]:
            assert s["takeoff_s"] == pytest.approx(clock, abs=1e-9)
            assert s["landing_s"] == pytest.approx(clock + s["duration_s"], abs=1e-9)
            clock += s["duration_s"] + swap
            sorties += 1
        assert v["makespan_s"] == pytest.approx(v["sorties"][-1]["landing_s"], abs=1e-9)
    assert sorties >= 3 and len(doc["vehicles"]) == 2  # a swap on a vehicle: its clock goes on
    read = read_fleet_dir(out)
    assert [s.takeoff_s for v in read.vehicles for s in v.sorties] == [
        s["takeoff_s"] for v in doc["vehicles"] for s in v["sorties"]]
    # verify says the same times, in its lines and its JSON
    assert main(["verify", str(path), str(out), "--json"]) == 0
    said = json.loads(capsys.readouterr().out)
    assert [s["takeoff_s"] for s in said["sorties"]] == [
        s["takeoff_s"] for v in doc["vehicles"] for s in v["sorties"]]
    assert main(["verify", str(path), str(out)]) == 0
    text = capsys.readouterr().out
    for v in doc["vehicles"]:
        for s in v["sorties"]:
            assert f"{s['file']}: " in text
            line = next(ln for ln in text.splitlines() if ln.startswith(f"{s['file']}: "))
            assert f"take-off +{s['takeoff_s']:.0f} s, " in line


def test_a_fleet_json_take_off_out_of_range_is_one_line(two_uavs, tmp_path) -> None:
    from lamde_mission.formats.fleet import FleetDirError

    _, out = two_uavs
    import shutil

    bad = tmp_path / "bad"
    shutil.copytree(out, bad)
    doc = json.loads((bad / "fleet.json").read_text())
    doc["vehicles"][0]["sorties"][0]["takeoff_s"] = -5
    (bad / "fleet.json").write_text(json.dumps(doc))
    with pytest.raises(FleetDirError, match=r"vehicles\[0\]\.sorties\[0\]\.takeoff_s: expected "
                       r"seconds in \[0, 1e\+08\], got -5"):
        read_fleet_dir(bad)


def test_upload_fleet_says_when_each_vehicle_takes_off_for_the_sortie_sent(two_uavs,
                                                                           capsys) -> None:
    from lamde_mission.vehicle.mock_fleet import MockFleet
    from tests.vehicle_helpers import free_udp_port
    from tests.vehicle_helpers import no_leftover_mock_threads as _leftover  # noqa: F401

    _, out = two_uavs
    doc = json.loads((out / "fleet.json").read_text())
    port = free_udp_port()
    conn = ["--connect", f"udpin://127.0.0.1:{port}", "--via", "pymavlink", "--timeout", "5"]
    # vehicles that fly the planned 20 m/s: below it a battery sortie is refused without --map
    # (tests/test_speed_limit.py)
    with MockFleet(f"udpout:127.0.0.1:{port}", vehicles=2, heartbeat_hz=10.0,
                   params={"MPC_XY_VEL_MAX": 20.0}):  # fmt: skip
        for k in (1, 2):
            assert main(["upload", str(out), "--fleet", "--sortie", str(k), *conn]) == 0
            said = [ln for ln in capsys.readouterr().out.splitlines()
                    if ln.startswith("take off")]
            times = ", ".join(f"vehicle {v['vehicle']} at +{v['sorties'][k - 1]['takeoff_s']:.0f} s"
                              for v in doc["vehicles"] if len(v["sorties"]) >= k)
            assert said == [f"take off (sortie {k}, s after vehicle 1's first take-off): "
                            f"{times}; the vehicles keep apart in the air and no sensor sends "
                            "to two at once only when they take off so"]
    assert doc["vehicles"][0]["sorties"][1]["takeoff_s"] > 0  # the swap's relaunch, not 0


def test_verify_fails_take_off_times_that_are_not_the_plans_clock(two_uavs, tmp_path,
                                                                   capsys) -> None:
    """A reviewer: a hand-edited takeoff_s (1100 where the clock says 569) passed verify and
    was printed by upload; a map whose swap_s is not the plan's moved every later take-off
    without a word. TIMES fails both; fleet.json records the swap_s it was planned with."""
    import shutil

    path, out = two_uavs
    doc = json.loads((out / "fleet.json").read_text())
    assert doc["swap_s"] == json.loads(path.read_text())["fleet"]["swap_s"]
    assert main(["verify", str(path), str(out)]) == 0
    n = sum(len(v["sorties"]) for v in doc["vehicles"])
    assert "fleet TIMES fleet.json's take-off times are the verified ones: PASS; the " \
        f"{n} take-off times fleet.json gives are the plan's clock" in capsys.readouterr().out
    edited = tmp_path / "edited"
    shutil.copytree(out, edited)
    clock = doc["vehicles"][0]["sorties"][1]["takeoff_s"]
    doc["vehicles"][0]["sorties"][1]["takeoff_s"] = clock + 500.0
    (edited / "fleet.json").write_text(json.dumps(doc))
    assert main(["verify", str(path), str(edited)]) == 1
    said = capsys.readouterr().out
    assert (f"fleet TIMES fleet.json's take-off times are the verified ones: FAIL; vehicle 1 "
            f"sortie 2 at {clock + 500.0:g} s in fleet.json, {clock:.1f} s on the plan's clock "
            "(launch, sorties, swap_s): upload prints fleet.json's times, the checks hold at "
            "the plan's clock") in said
    # the map's swap_s is not the one planned with: every later take-off moves
    d = json.loads(path.read_text())
    d["fleet"]["swap_s"] = doc["swap_s"] + 60.0
    other = tmp_path / "swap.json"
    other.write_text(json.dumps(d))
    assert main(["verify", str(other), str(out)]) == 1
    said = capsys.readouterr().out
    assert (f"fleet.json was planned with swap_s {doc['swap_s']:g} s, the map says "
            f"{doc['swap_s'] + 60.0:g} s, which moves every later take-off") in said
    # a directory written before take-off times were recorded: nothing to compare
    old = tmp_path / "old"
    shutil.copytree(out, old)
    plain = json.loads((out / "fleet.json").read_text())
    plain.pop("swap_s")
    for v in plain["vehicles"]:
        for s in v["sorties"]:
            s.pop("takeoff_s"), s.pop("landing_s")
    (old / "fleet.json").write_text(json.dumps(plain))
    assert main(["verify", str(path), str(old)]) == 0
    assert "fleet.json gives no take-off times (the launches only)" in capsys.readouterr().out
