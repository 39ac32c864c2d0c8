"""QGroundControl `.plan` files (JSON): mission items, exclusion geofence, no rally points.

Layout follows QGC's documented plan format (file version 1, mission version 2, geoFence
version 2, rallyPoints version 2). Choices:

- firmwareType 12 (MAV_AUTOPILOT_PX4) by default: QGC's default, and our NaN yaw parameters
  follow PX4's "NaN = keep the yaw mode" meaning. ArduPilot reads the same items (it ignores
  those yaw parameters); pass `firmware_type=3` to tag a file for ArduPilot.
- vehicleType 2 (MAV_TYPE_QUADROTOR): the paper's rotary-wing UAV.
- NaN parameters are written as JSON null, as QGC does; read back as NaN.
- Every fence shape carries "inclusion": false explicitly (QGC treats a missing key as an
  inclusion fence).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from lamde_mission.atomic import write_text_atomic
from lamde_mission.formats.ranges import FLOAT32_MAX, check_item_count, check_mission_item
from lamde_mission.items import (
    CMD,
    MISSION_TYPE,
    MissionError,
    MissionItem,
    fence_from_items,
    fence_item,
)
from planner_core.textio import InputError, read_json

__all__ = [
    "FIRMWARE_PX4",
    "FIRMWARE_ARDUPILOT",
    "VEHICLE_QUADROTOR",
    "plan_document",
    "parse_plan_document",
    "write_qgc_plan",
    "read_qgc_plan",
]

FIRMWARE_PX4 = 12  # MAV_AUTOPILOT_PX4
FIRMWARE_ARDUPILOT = 3  # MAV_AUTOPILOT_ARDUPILOTMEGA
VEHICLE_QUADROTOR = 2  # MAV_TYPE_QUADROTOR
_CIRCLES = (CMD.FENCE_CIRCLE_INCLUSION, CMD.FENCE_CIRCLE_EXCLUSION)
ALTITUDE_MODE_RELATIVE = 1  # QGC: altitude relative to launch


def _num(v: float) -> float | None:
    v = float(v)
    return None if math.isnan(v) else v


def _simple_item(it: MissionItem) -> dict[str, Any]:
    return {
        "AMSLAltAboveTerrain": None,
        "Altitude": _num(it.z),
        "AltitudeMode": ALTITUDE_MODE_RELATIVE,
        "autoContinue": bool(it.autocontinue),
        "command": int(it.command),
        "doJumpId": int(it.seq) + 1,
        "frame": int(it.frame),
        "params": [_num(p) for p in it.params],
        "type": "SimpleItem",
    }


def _fence_section(fence: Sequence[MissionItem]) -> dict[str, Any]:
    try:
        circles, polygons = fence_from_items(fence)
    except MissionError as exc:
        raise ValueError(str(exc)) from None
    return {
        "circles": [
            {
                "circle": {"center": [lat, lon], "radius": float(r)},
                "inclusion": bool(inc),
                "version": 1,
            }
            for lat, lon, r, inc in circles
        ],
        "polygons": [
            {
                "inclusion": bool(poly[0][2]),
                "polygon": [[lat, lon] for lat, lon, _ in poly],
                "version": 1,
            }
            for poly in polygons
        ],
        "version": 2,
    }


def plan_document(
    items: Sequence[MissionItem],
    fence: Sequence[MissionItem] = (),
    *,
    home: tuple[float, float, float],
    cruise_speed: float,
    hover_speed: float | None = None,
    firmware_type: int = FIRMWARE_PX4,
    vehicle_type: int = VEHICLE_QUADROTOR,
) -> dict[str, Any]:
    """The `.plan` JSON object. `home` is (lat, lon, altitude AMSL) of the planned home."""
    if not items:
        raise ValueError("a QGC plan needs at least one mission item")
    return {
        "fileType": "Plan",
        "geoFence": _fence_section(fence),
        "groundStation": "lamde-mission",
        "mission": {
            "cruiseSpeed": float(cruise_speed),
            "firmwareType": int(firmware_type),
            "globalPlanAltitudeMode": ALTITUDE_MODE_RELATIVE,
            "hoverSpeed": float(cruise_speed if hover_speed is None else hover_speed),
            "items": [_simple_item(it) for it in items],
            "plannedHomePosition": [float(home[0]), float(home[1]), float(home[2])],
            "vehicleType": int(vehicle_type),
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
    }


def _float(v: Any, where: str) -> float:
    if v is None:
        return float("nan")
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise MissionError(f"{where}: expected a number or null, got {v!r}")
    return float(v)


def _latlon_pair(v: Any, where: str) -> tuple[float, float]:
    if not isinstance(v, list) or len(v) < 2:
        raise MissionError(f"{where}: expected [lat, lon]")
    return _float(v[0], where), _float(v[1], where)


def _plan_field(where: str, name: str) -> str:
    """The .plan name of a MissionItem field of item `where`."""
    params = {"param1": 0, "param2": 1, "param3": 2, "param4": 3, "x": 4, "y": 5, "z": 6}
    if name in params:
        return f"{where}.params[{params[name]}]"
    return f"{where}.{'autoContinue' if name == 'autocontinue' else name}"


def parse_plan_document(doc: Any) -> tuple[list[MissionItem], list[MissionItem]]:
    """Mission items and fence items of a `.plan` JSON object; raise MissionError if malformed."""
    if not isinstance(doc, dict) or doc.get("fileType") != "Plan":
        raise MissionError('not a QGroundControl plan (fileType must be "Plan")')
    mission = doc.get("mission")
    if not isinstance(mission, dict) or not isinstance(mission.get("items"), list):
        raise MissionError("mission.items: missing or not a list")
    check_item_count(len(mission["items"]), "mission.items")
    items: list[MissionItem] = []
    for k, raw in enumerate(mission["items"]):
        where = f"mission.items[{k}]"
        if not isinstance(raw, dict):
            raise MissionError(f"{where}: not an object")
        if raw.get("type") != "SimpleItem":
            raise MissionError(
                f"{where}: item type {raw.get('type')!r} is not supported (only SimpleItem; "
                "complex items such as surveys must be converted in QGroundControl first)"
            )
        params = raw.get("params")
        if not isinstance(params, list) or len(params) != 7:
            raise MissionError(f"{where}.params: expected 7 values")
        p = [_float(v, f"{where}.params[{i}]") for i, v in enumerate(params)]
        try:
            command, frame = raw["command"], raw["frame"]
        except KeyError as exc:
            raise MissionError(f"{where}.{exc.args[0]}: required field is missing") from None
        item = (
            MissionItem(
                seq=len(items), command=command, frame=frame, current=0,
                autocontinue=int(bool(raw.get("autoContinue", True))),
                param1=p[0], param2=p[1], param3=p[2], param4=p[3], x=p[4], y=p[5], z=p[6],
                mission_type=MISSION_TYPE.MISSION,
            )
        )  # fmt: skip
        check_mission_item(item, lambda f, w=where: _plan_field(w, f))
        items.append(item)
    fence = _parse_fence(doc.get("geoFence"))
    return items, fence


def _parse_fence(gf: Any) -> list[MissionItem]:
    """Fence items from a geoFence section: polygons first, then circles (QGC's order)."""
    if gf is None:
        return []
    if not isinstance(gf, dict):
        raise MissionError("geoFence: not an object")
    out: list[MissionItem] = []

    def add(command: int, p1: float, lat: float, lon: float, where: str) -> None:
        it = fence_item(len(out), command, p1, lat, lon)
        names = {"param1": "radius" if command in _CIRCLES else "vertex count",
                 "x": "latitude", "y": "longitude"}  # fmt: skip
        check_mission_item(it, lambda f: f"{where} ({names.get(f, f)})")
        out.append(it)
        check_item_count(len(out), "geoFence")

    for k, poly in enumerate(gf.get("polygons") or []):
        where = f"geoFence.polygons[{k}]"
        verts = poly.get("polygon") if isinstance(poly, dict) else None
        if not isinstance(verts, list) or len(verts) < 3:
            raise MissionError(f"{where}.polygon: needs at least 3 [lat, lon] vertices")
        inclusion = bool(poly.get("inclusion", True))
        cmd = (CMD.FENCE_POLYGON_VERTEX_INCLUSION if inclusion
               else CMD.FENCE_POLYGON_VERTEX_EXCLUSION)  # fmt: skip
        for i, v in enumerate(verts):
            lat, lon = _latlon_pair(v, f"{where}.polygon[{i}]")
            add(cmd, len(verts), lat, lon, f"{where}.polygon[{i}]")
    for k, c in enumerate(gf.get("circles") or []):
        where = f"geoFence.circles[{k}]"
        circle = c.get("circle") if isinstance(c, dict) else None
        if not isinstance(circle, dict):
            raise MissionError(f"{where}: missing 'circle'")
        lat, lon = _latlon_pair(circle.get("center"), f"{where}.circle.center")
        r = _float(circle.get("radius"), f"{where}.circle.radius")
        if not (math.isfinite(r) and 0 < r <= FLOAT32_MAX):
            raise MissionError(f"{where}.circle.radius: must be a positive finite number, "
                               f"got {r:g}")  # fmt: skip
        inclusion = bool(c.get("inclusion", True))
        cmd = CMD.FENCE_CIRCLE_INCLUSION if inclusion else CMD.FENCE_CIRCLE_EXCLUSION
        add(cmd, r, lat, lon, f"{where}.circle")
    return out


def write_qgc_plan(
    path: str | Path,
    items: Sequence[MissionItem],
    fence: Sequence[MissionItem] = (),
    **kwargs: Any,
) -> Path:
    """Write a `.plan` file atomically; keyword arguments as for `plan_document`."""
    doc = plan_document(items, fence, **kwargs)
    return write_text_atomic(path, json.dumps(doc, indent=4, allow_nan=False) + "\n")


def read_qgc_plan(path: str | Path) -> tuple[list[MissionItem], list[MissionItem]]:
    """(mission items, fence items) of a `.plan` file; raise MissionError if malformed."""
    try:
        doc = read_json(path)
    except InputError as exc:
        raise MissionError(str(exc)) from None
    return parse_plan_document(doc)
