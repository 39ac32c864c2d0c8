"""Upload a mission and its geofence, read them back, compare: `upload_mission`.

This is the only module that imports MAVSDK (`mavsdk` 4.x, the native binding; imported when a
`MavsdkClient` is made, so `via="pymavlink"` never loads it). `MavsdkClient` drives MAVSDK's
MissionRaw plugin (raw MISSION_ITEM_INT lists for the mission, fence and rally points) from a
private asyncio loop and is a `MissionClient` for `transfer.upload_and_verify`;
`MavlinkClient` (pymavlink) is the other.

Conventions (see `wire.py`): items go up numbered 0..n-1 with item 0 marked current; the
read-back is compared item by item after MAVLink's int32/float32 conversions. `.waypoints`
files: the home line (seq 0 of the file) is not uploaded; `read_mission` drops it and the
mission starts at seq 0 with our first item, exactly as the `.plan` of the same plan does, so
both formats upload and read back the same items. For an ArduPilot vehicle (HEARTBEAT autopilot
MAV_AUTOPILOT_ARDUPILOTMEGA, or `autopilot="ardupilot"`) a home placeholder goes up first as
item 0, which ArduPilot overwrites with its home and never flies, and DO_JUMP targets move up
with the items; the read-back is compared under its storage rules.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from lamde_mission.items import MISSION_TYPE, MissionItem
from lamde_mission.vehicle.transfer import (
    MissionRejectedError,
    NoVehicleError,
    TransferError,
    UploadReport,
    VehicleError,
    VehicleInfo,
    upload_and_verify,
)
from lamde_mission.vehicle.wire import WireItem, mission_type_name, parse_endpoint

__all__ = ["MavsdkClient", "upload_mission", "make_client", "VIAS"]

#: the uploaders `upload_mission` can use
VIAS = ("mavsdk", "pymavlink")

#: MissionRaw results that mean "try the transfer again"
_RETRYABLE = {"TIMEOUT", "BUSY", "ERROR", "UNKNOWN", "PROTOCOL_ERROR", "TRANSFER_CANCELLED",
              "NO_SYSTEM"}  # fmt: skip
#: the MISSION_ACK code behind a MissionRaw result, where it is one code
_ACK_OF_RESULT = {
    "TOO_MANY_MISSION_ITEMS": "MAV_MISSION_NO_SPACE",
    "DENIED": "MAV_MISSION_DENIED",
    "INVALID_SEQUENCE": "MAV_MISSION_INVALID_SEQUENCE",
    "PROTOCOL_ERROR": "MAV_MISSION_ERROR",
    "TRANSFER_CANCELLED": "MAV_MISSION_OPERATION_CANCELLED",
    "UNSUPPORTED": "MAV_MISSION_UNSUPPORTED or MAV_MISSION_UNSUPPORTED_FRAME",
    "INVALID_ARGUMENT": "MAV_MISSION_INVALID or MAV_MISSION_INVALID_PARAMn",
}


_log = logging.getLogger("lamde_mission.vehicle.mavsdk")


def _route_mavsdk_log() -> None:
    """Send MAVSDK's own log lines to Python logging ("lamde_mission.vehicle.mavsdk") instead
    of the terminal: its errors as warnings, the rest at debug level (our report says what
    failed)."""
    from mavsdk import LogLevel, log_subscribe

    def handler(level: Any, message: str, file: str | None, line: int) -> bool:
        _log.log(logging.WARNING if level >= LogLevel.ERROR else logging.DEBUG, "%s", message)
        return True  # handled: MAVSDK prints nothing

    log_subscribe(handler)


class MavsdkClient:
    """Mission transfers through MAVSDK's MissionRaw plugin (blocking calls, own event loop)."""

    name = "mavsdk"

    def __init__(self, connect: str = "udpin://0.0.0.0:14540", *, quiet: bool = True) -> None:
        try:
            self.url = parse_endpoint(connect).url()
        except ValueError:
            self.url = connect  # serial://, tcpout://, ...: MAVSDK's business
        from mavsdk.asyncio import ComponentType, Configuration, Mavsdk

        if quiet:
            _route_mavsdk_log()
        cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
        self._sdk: Any = Mavsdk(cfg)
        self._loop = asyncio.new_event_loop()
        self._system: Any = None
        self._raw: Any = None
        self.vehicle: VehicleInfo | None = None

    # ------------------------------------------------------------------ plumbing

    def _run(self, coro: Any, timeout: float) -> Any:
        return self._loop.run_until_complete(asyncio.wait_for(coro, timeout))

    def close(self) -> None:
        """Release MAVSDK (its threads and sockets) and the event loop (idempotent)."""
        if self._sdk is not None:
            sdk, self._sdk = self._sdk, None
            self._raw = None
            self._system = None
            sdk.destroy()
        if not self._loop.is_closed():
            self._loop.run_until_complete(self._loop.shutdown_default_executor())
            self._loop.close()

    def __enter__(self) -> MavsdkClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ connect

    def connect(self, timeout: float) -> VehicleInfo:
        """Listen/connect at the URL and wait up to `timeout` s for an autopilot."""
        from mavsdk.asyncio import MavsdkConnectionError
        from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync

        async def go() -> Any:
            try:
                await self._sdk.add_any_connection(self.url)
            except MavsdkConnectionError as exc:
                raise VehicleError(f"cannot open {self.url}: {exc}") from None
            return await self._sdk.first_autopilot(timeout_s=float(timeout))

        system = self._run(go(), timeout + 5.0)
        if system is None:
            raise NoVehicleError(f"no vehicle heard at {self.url} within {timeout:g} s")
        self._system = system
        self._raw = MissionRawAsync(system)

        async def info() -> VehicleInfo:
            ap, vt = await system.autopilot_type(), await system.vehicle_type()
            return VehicleInfo(
                system_id=int(await system.get_system_id()), component_id=1,
                autopilot=None if ap.name == "UNKNOWN" else ap.name,
                vehicle_type=None if vt.name == "UNKNOWN" else vt.name.lower(),
            )  # fmt: skip

        self.vehicle = self._run(info(), 5.0)
        return self.vehicle

    # ------------------------------------------------------------------ transfers

    def _call(
        self,
        what: str,
        mission_type: int,
        timeout: float,
        fn: Callable[[], Any],
        cancel: Callable[[], Any] | None = None,
    ) -> Any:
        from mavsdk.asyncio.plugins.geofence import GeofenceError
        from mavsdk.asyncio.plugins.mission_raw import MissionRawError

        if self._raw is None:
            raise TransferError("not connected (call connect first)")
        kind = mission_type_name(mission_type)
        try:
            return self._run(fn(), timeout)
        except TimeoutError:
            if cancel is not None:
                with contextlib.suppress(Exception):  # nothing left to cancel
                    self._run(cancel(), 5.0)
            raise TransferError(f"{kind} {what}: no result within {timeout:.3g} s") from None
        except (MissionRawError, GeofenceError) as exc:
            name = exc.result.name
            source = "MissionRaw" if isinstance(exc, MissionRawError) else "Geofence"
            if name == "TIMEOUT":
                raise TransferError(f"{kind} {what} timed out ({source} result TIMEOUT)") from None
            ack = _ACK_OF_RESULT.get(name)
            shown = f"{name} ({source} result{'; ' + ack if ack else ''})"
            raise MissionRejectedError(
                f"the vehicle refused the {kind} {what}: {shown}",
                name=name, mission_type=mission_type, retryable=name in _RETRYABLE,
            ) from None  # fmt: skip

    def upload(self, items: Sequence[WireItem], mission_type: int, timeout: float) -> None:
        """Upload one list through MissionRaw (mission, geofence or rally points)."""
        from mavsdk.asyncio.plugins.mission_raw import MissionItem as RawItem

        raw_items = [RawItem(*w.fields()) for w in items]
        up = {
            MISSION_TYPE.MISSION: self._raw.upload_mission,
            MISSION_TYPE.FENCE: self._raw.upload_geofence,
            MISSION_TYPE.RALLY: self._raw.upload_rally_points,
        }[int(mission_type)]
        self._call(
            "upload", mission_type, timeout, lambda: up(raw_items), self._raw.cancel_mission_upload
        )

    def download(self, mission_type: int, timeout: float) -> list[WireItem]:
        """Read one list back through MissionRaw."""
        down = {
            MISSION_TYPE.MISSION: self._raw.download_mission,
            MISSION_TYPE.FENCE: self._raw.download_geofence,
            MISSION_TYPE.RALLY: self._raw.download_rallypoints,
        }[int(mission_type)]
        got = self._call("download", mission_type, timeout, down, self._raw.cancel_mission_download)
        return [_wire_of(r) for r in got]

    def clear(self, mission_type: int, timeout: float) -> None:
        """Clear the mission (MissionRaw) or the geofence (Geofence plugin) on the vehicle."""
        t = int(mission_type)
        if t == MISSION_TYPE.MISSION:
            self._call("clear", t, timeout, self._raw.clear_mission)
        elif t == MISSION_TYPE.FENCE:
            from mavsdk.asyncio.plugins.geofence import GeofenceAsync

            fence = GeofenceAsync(self._system)
            try:
                self._call("clear", t, timeout, fence.clear_geofence)
            finally:
                fence.destroy()
        else:
            raise ValueError("MAVSDK has no call to clear rally points")

    def import_qgc_plan(
        self, path: str | Path
    ) -> tuple[list[WireItem], list[WireItem], list[WireItem]]:
        """MAVSDK's own QGroundControl importer on `path`: (mission, fence, rally) as WireItems.

        Needs a connected vehicle (MAVSDK asks it for its autopilot type: for ArduPilot it puts
        the planned home in as item 0). Raises MissionRejectedError naming MAVSDK's result
        (e.g. FAILED_TO_PARSE_QGC_PLAN) when it refuses the file.
        """
        try:
            data = self._call(
                "import",
                MISSION_TYPE.MISSION,
                10.0,
                lambda: self._raw.import_qgroundcontrol_mission(str(path)),
            )
        except MissionRejectedError as exc:
            raise MissionRejectedError(
                f"MAVSDK's QGroundControl importer refused {path}: {exc.name}", name=exc.name
            ) from None
        return (
            [_wire_of(r) for r in data.mission_items],
            [_wire_of(r) for r in data.geofence_items],
            [_wire_of(r) for r in data.rally_items],
        )


def _wire_of(r: Any) -> WireItem:
    f32 = [float(v) for v in (r.param1, r.param2, r.param3, r.param4, r.z)]
    return WireItem(
        int(r.seq), int(r.frame), int(r.command), int(r.current), int(r.autocontinue),
        f32[0], f32[1], f32[2], f32[3], int(r.x), int(r.y), f32[4], int(r.mission_type),
    )  # fmt: skip


def make_client(via: str, connect: str) -> Any:
    """A MissionClient: "mavsdk" (MAVSDK's MissionRaw) or "pymavlink" (ours)."""
    if via == "mavsdk":
        return MavsdkClient(connect)
    if via == "pymavlink":
        from lamde_mission.vehicle.mavlink_client import MavlinkClient

        return MavlinkClient(connect)
    raise ValueError(f"via must be one of {', '.join(VIAS)}, got {via!r}")


def upload_mission(
    mission: Sequence[MissionItem],
    fence: Sequence[MissionItem] | None = (),
    *,
    connect: str = "udpin://0.0.0.0:14540",
    via: str = "mavsdk",
    timeout: float = 30.0,
    attempts: int = 3,
    log: Callable[[str], None] | None = None,
    rally: Sequence[MissionItem] | None = None,
    autopilot: str | None = None,
) -> UploadReport:
    """Upload a mission and its fence to the vehicle at `connect`, read both back, compare.

    `fence=None` leaves the vehicle's fence alone (a `.waypoints` file has none); an empty
    fence clears it. `rally` (MISSION_TYPE_RALLY items; None leaves the vehicle's alone) goes up
    as the rally list. `autopilot` (px4, ardupilot, generic) overrides the storage rules read
    from the vehicle's HEARTBEAT (`transfer.upload_and_verify`). Waits up to `timeout` s for
    the vehicle and up to `timeout` s per attempt;
    a failed attempt (time-out, lost messages, read-back difference) is retried as a whole up
    to `attempts` times. Returns the report; raises a `VehicleError` subclass (NoVehicleError,
    MissionRejectedError, TransferError, ReadbackMismatchError; `.report` attached) on failure,
    ValueError for bad arguments or items MAVLink cannot carry.
    """
    if not (isinstance(timeout, int | float) and math.isfinite(timeout) and timeout > 0):
        raise ValueError(f"timeout must be a positive number of seconds, got {timeout!r}")
    if via not in VIAS:
        raise ValueError(f"via must be one of {', '.join(VIAS)}, got {via!r}")
    client = make_client(via, connect)
    try:
        return upload_and_verify(
            client, mission, fence, rally=rally, autopilot=autopilot, timeout=timeout,
            attempts=attempts, endpoint=connect, log=log,
        )  # fmt: skip
    finally:
        client.close()
