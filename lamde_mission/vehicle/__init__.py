"""Talking to vehicles over MAVLink: a mock autopilot and two mission uploaders.

- `MockVehicle` (`mock.py`): a pymavlink autopilot on UDP that stores what it is sent;
  `MockFleet` (`mock_fleet.py`): several, on one link (told apart by system id) or one each.
- `upload_mission` (`upload.py`): mission + geofence up, read back, compared item by item,
  through MAVSDK (`via="mavsdk"`, the only module importing it) or our pymavlink client
  (`via="pymavlink"`, `mavlink_client.py`), the vehicle's speed limit checked against the
  mission's speed first (`speeds.py`, as `upload MISSION`); `upload_fleet` (`fleet.py`): each
  vehicle of a fleet its own mission, addressed by system id, every vehicle heard before any
  upload and its speed limit checked against its sortie's speed (as `upload DIR/ --fleet`).
- `wire.py`: items as MAVLink carries them and the comparison; `transfer.py`: errors, report,
  and the retry loop both uploaders share; `connection.py`: the one connection syntax (UDP,
  TCP, serial), validated, and the byte links of the pymavlink client.

Names load lazily, so importing this package loads neither pymavlink's dialect nor MAVSDK.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "MockVehicle",
    "MockFleet",
    "upload_mission",
    "upload_fleet",
    "FleetSetupError",
    "FleetSurveyError",
    "UploadReport",
    "VehicleError",
    "NoVehicleError",
    "TransferError",
    "MissionRejectedError",
    "ReadbackMismatchError",
]

_WHERE = {
    "MockVehicle": "lamde_mission.vehicle.mock",
    "MockFleet": "lamde_mission.vehicle.mock_fleet",
    "upload_mission": "lamde_mission.vehicle.upload",
    "upload_fleet": "lamde_mission.vehicle.fleet",
    "FleetSetupError": "lamde_mission.vehicle.fleet",
    "FleetSurveyError": "lamde_mission.vehicle.fleet",
    "UploadReport": "lamde_mission.vehicle.transfer",
    "VehicleError": "lamde_mission.vehicle.transfer",
    "NoVehicleError": "lamde_mission.vehicle.transfer",
    "TransferError": "lamde_mission.vehicle.transfer",
    "MissionRejectedError": "lamde_mission.vehicle.transfer",
    "ReadbackMismatchError": "lamde_mission.vehicle.transfer",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        import importlib

        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'lamde_mission.vehicle' has no attribute {name!r}")
