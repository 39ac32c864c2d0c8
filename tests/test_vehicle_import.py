"""MAVSDK's own QGroundControl importer accepts every .plan we write and reads the same items.

The plans: the suite maps' witness plans (examples/maps/suite/T*.json, where present),
small-demo's witness, and a hand-made map with every obstacle kind. MAVSDK's importer needs a
connected vehicle (it asks the autopilot type), so one MAVSDK client stays connected to the mock
for the module.

Our fence follows QGroundControl's and MAVSDK's conventions (polygon vertices before circles,
autocontinue 0), so the items must be equal as they are; only the `current` flag of the upload
wire form (item 0 current) is set on ours before comparing.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from lamde_mission.formats import read_mission, write_mission
from lamde_mission.vehicle.mock import MockVehicle
from lamde_mission.vehicle.wire import WireItem, compare_items, wire_mission
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from tests.conftest import MAPS, SUITE
from tests.vehicle_helpers import free_udp_port

HAND = {
    "name": "every-obstacle",
    "origin": {"lat": -35.3632, "lon": 149.1652, "alt": 584.0},
    "area": {"width": 3000, "height": 2000},
    "start": [100, 50],
    "end": [2900, 1900],
    "sensors": [{"id": "s1", "x": 500, "y": 400}, {"id": "s2", "x": 2500, "y": 1500}],
    "obstacles": {
        "circles": [{"x": 2000, "y": 300, "radius": 80}, {"x": 600, "y": 900, "radius": 45.5}],
        "rectangles": [{"x": 800, "y": 1500, "length": 160, "width": 90, "angle_deg": 120}],
        "no_fly_zones": [{"vertices": [[1800, 1200], [2100, 1150], [2200, 1400], [1900, 1500]]}],
    },
    "uav": {"altitude": 90, "max_speed": 18},
}


def _witness_maps() -> list[Path]:
    found = sorted(SUITE.glob("T*.json")) if SUITE.is_dir() else []
    demo = MAPS / "small-demo.json"
    return found + ([demo] if demo.exists() else [])


def _plan_of(m) -> SimpleNamespace:
    w = m.spec.witness
    if w is None:
        return SimpleNamespace(hover_points=np.array([[500.0, 420.0], [2480.0, 1500.0]]),
                               hover_times=np.array([40.0, 55.5]))  # fmt: skip
    p = Problem(m)
    b = p.breakdown(p.encode(np.array(w.hover_points), np.array(w.hover_times)))
    return SimpleNamespace(hover_points=np.array(b["hover_points"]),
                           hover_times=np.array(b["hover_times"]))  # fmt: skip


def _cases() -> list:
    return [pytest.param(p, id=p.stem) for p in _witness_maps()] + [pytest.param(HAND, id="hand")]


@pytest.fixture(scope="module")
def mavsdk_client():
    from lamde_mission.vehicle.upload import MavsdkClient

    port = free_udp_port()
    with MockVehicle(f"udpout:127.0.0.1:{port}", heartbeat_hz=4.0), \
            MavsdkClient(f"udpin://127.0.0.1:{port}") as client:  # fmt: skip
        client.connect(10.0)
        yield client


def _as_uploaded(fence: list[WireItem]) -> list[WireItem]:
    """Our fence as it goes on the wire: item 0 marked current, nothing else changed."""
    return [replace(w, current=int(k == 0)) for k, w in enumerate(fence)]


@pytest.mark.parametrize("map_source", _cases())
@pytest.mark.slow  # measured 5 s over 18 cases (issue 35: default suite <= 5 min)
def test_mavsdk_importer_reads_our_plan_as_we_do(map_source, mavsdk_client, tmp_path):
    m = load_map(map_source)
    path = write_mission(tmp_path / "mission.plan", _plan_of(m), m)
    mission, fence = read_mission(path)
    assert fence, "every test map has obstacles"
    got_mission, got_fence, got_rally = mavsdk_client.import_qgc_plan(path)
    ours = wire_mission(mission)
    assert compare_items(ours, got_mission) == []
    assert [w.current for w in got_mission] == [w.current for w in ours]  # item 0 current
    assert compare_items(_as_uploaded(wire_mission(fence)), got_fence, "fence") == []
    assert [w.autocontinue for w in got_fence] == [0] * len(got_fence)
    assert got_rally == []


def test_mavsdk_importer_refuses_a_broken_plan(mavsdk_client, tmp_path):
    from lamde_mission.vehicle.transfer import MissionRejectedError

    bad = tmp_path / "bad.plan"
    bad.write_text('{"fileType": "Plan", "version": 1}')
    with pytest.raises(MissionRejectedError, match="FAILED_TO_PARSE_QGC_PLAN"):
        mavsdk_client.import_qgc_plan(bad)
