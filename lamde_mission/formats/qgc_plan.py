"""QGroundControl `.plan` files (JSON): mission items, geofence and rally points.

`plan_document` (`write_qgc_plan`) writes the three lists and `parse_plan_lists` reads them
back; the planner's missions (`formats.write_mission`) carry an exclusion geofence (the map's
obstacles) and an empty rally-point list. Layout follows QGC's documented plan format (file
version 1, mission version 2, geoFence version 2, rallyPoints version 2). Choices:

- firmwareType 12 (MAV_AUTOPILOT_PX4) by default: QGC's default, and our NaN yaw parameters
  follow PX4's "NaN = keep the yaw mode" meaning. ArduPilot reads the same items (it ignores
  those yaw parameters); pass `firmware_type=3` to tag a file for ArduPilot.
- vehicleType 2 (MAV_TYPE_QUADROTOR): the paper's rotary-wing UAV.
- NaN parameters are written as JSON null, as QGC does; read back as NaN.
- Every fence shape carries its "inclusion" flag explicitly, from its fence items' command
  (inclusion or exclusion; false for the planner's obstacles): QGC treats a missing key as an
  inclusion fence, and so does the reader.
- A geofence's FENCE_RETURN_POINT item is its `breachReturn`; rally points are written as
  [lat, lon, alt] and read back as RALLY_POINT items (relative altitude).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from lamde_mission.atomic import write_text_atomic
from lamde_mission.formats.ranges import FLOAT32_MAX, check_item_count, check_mission_item
from lamde_mission.items import (
    CMD,
    FRAME,
    MISSION_TYPE,
    MissionError,
    MissionItem,
    fence_from_items,
    fence_item,
)
from planner_core.textio import quoted

__all__ = [
    "FIRMWARE_PX4",
    "VEHICLE_QUADROTOR",
    "plan_document",
    "parse_plan_document",
    "write_qgc_plan",
]

FIRMWARE_PX4 = 12  # MAV_AUTOPILOT_PX4
VEHICLE_QUADROTOR = 2  # MAV_TYPE_QUADROTOR
_CIRCLES = (CMD.FENCE_CIRCLE_INCLUSION, CMD.FENCE_CIRCLE_EXCLUSION)
_LLA = {"x": "latitude", "y": "longitude", "z": "altitude"}
ALTITUDE_MODE_RELATIVE = 1  # QGC: altitude relative to launch


def _num(v: float) -> float | None:
    v = float(v)
    return None if math.isnan(v) else v


def _simple_item(it: MissionItem) -> dict[str, Any]:
    if it.command == CMD.DO_JUMP:  # QGC's DO_JUMP param1 is the target's doJumpId (seq + 1)
        it = replace(it, param1=it.param1 + 1)
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
    section: dict[str, Any] = {}
    ret = [it for it in fence if it.command == CMD.FENCE_RETURN_POINT]
    if ret:
        section["breachReturn"] = [float(ret[0].x), float(ret[0].y), float(ret[0].z)]
    return section | {
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
    rally: Sequence[MissionItem] = (),
) -> dict[str, Any]:
    """The `.plan` JSON object. `home` is (lat, lon, altitude AMSL) of the planned home.

    Args:
        items: the mission items (at least one); a DO_JUMP's param1 is written as the
            target's doJumpId (seq + 1), NaN parameters as null.
        fence: fence items (`geofence_items`), grouped into circles and polygons.
        home: (lat, lon, alt) of the planned home: degrees, degrees, metres AMSL.
        cruise_speed: m/s.
        hover_speed: m/s; None: `cruise_speed`.
        firmware_type: QGC's firmwareType, a MAV_AUTOPILOT value (default PX4, 12).
        vehicle_type: a MAV_TYPE value (default quadrotor, 2).
        rally: rally point items, written as [lat, lon, alt].

    Returns:
        The document (file version 1, mission, geoFence and rallyPoints version 2).

    Raises:
        ValueError: no mission items, or fence items that do not group into shapes.
    """
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
        "rallyPoints": {"points": [[float(r.x), float(r.y), float(r.z)] for r in rally],
                        "version": 2},
        "version": 1,
    }


def _float(v: Any, where: str) -> float:
    if v is None:
        return float("nan")
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise MissionError(f"{where}: expected a number or null, got {quoted(v)}")
    return float(v)


def _bool(obj: dict[str, Any], key: str, where: str, default: bool) -> bool:
    """A JSON boolean field of `obj` (`default` when the key is absent); MissionError naming
    `where.key` for anything else: a string "false" is not false, and 0/1 are not QGC's."""
    if key not in obj:
        return default
    v = obj[key]
    if not isinstance(v, bool):
        shown = repr(v) if len(repr(v)) <= 40 else repr(v)[:37] + "..."
        raise MissionError(f"{where}.{key}: expected true or false, got {shown}")
    return v


def _latlon_pair(v: Any, where: str) -> tuple[float, float]:
    if not isinstance(v, list) or len(v) < 2:
        raise MissionError(f"{where}: expected [lat, lon]")
    return _float(v[0], where), _float(v[1], where)


#: the sections of a .plan, and the lists each holds (absent or null: none)
SECTIONS = {"mission": ("items",), "geoFence": ("polygons", "circles"),
            "rallyPoints": ("points",)}


def _check_sections(doc: dict[str, Any]) -> None:
    """MissionError naming the first section that is not an object (absent or null: none),
    or a list of one (`geoFence.polygons`, `rallyPoints.points`) that is not a list, before
    anything iterates them (a number there was a TypeError, a list an AttributeError)."""
    for name, lists in SECTIONS.items():
        sec = doc.get(name)
        if sec is None:
            continue
        if not isinstance(sec, dict):
            raise MissionError(f"{name}: expected an object, got {_kind(sec)}")
        for key in lists:
            v = sec.get(key)
            if v is not None and not isinstance(v, list):
                raise MissionError(f"{name}.{key}: expected a list, got {_kind(v)}")


def _kind(v: Any) -> str:
    """What a JSON value is, for a message (never the value itself: it may be megabytes)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    return {dict: "an object", list: "a list", str: "a string", int: "a number",
            float: "a number"}.get(type(v), type(v).__name__)  # fmt: skip


#: the section versions this reader understands (QGroundControl's plan format)
VERSIONS = {"version": 1, "mission.version": 2, "geoFence.version": 2, "rallyPoints.version": 2}


def _check_versions(doc: dict[str, Any]) -> None:
    for path, want in VERSIONS.items():
        node: Any = doc
        *parents, key = path.split(".")
        for p in parents:
            node = node.get(p) if isinstance(node, dict) else None
        if not isinstance(node, dict) or key not in node:
            if parents:  # a missing optional section, or a section without a version: accepted
                continue
            raise MissionError(f"{path}: missing (a QGroundControl plan says its file version)")
        got = node[key]
        if got != want:
            raise MissionError(f"{path}: version {quoted(got)} is not supported (this reader knows "
                               f"version {want})")  # fmt: skip


def _plan_field(where: str, name: str) -> str:
    """The .plan name of a MissionItem field of item `where`."""
    params = {"param1": 0, "param2": 1, "param3": 2, "param4": 3, "x": 4, "y": 5, "z": 6}
    if name in params:
        return f"{where}.params[{params[name]}]"
    return f"{where}.{'autoContinue' if name == 'autocontinue' else name}"


def parse_plan_document(doc: Any) -> tuple[list[MissionItem], list[MissionItem]]:
    """Mission items and fence items of a `.plan` JSON object (`parse_plan_lists` also gives
    the rally points).

    Args:
        doc: the parsed JSON.

    Returns:
        (mission, fence) items.

    Raises:
        MissionError: the document is malformed.
    """
    items, fence, _rally = parse_plan_lists(doc)
    return items, fence


def parse_plan_lists(
    doc: Any,
) -> tuple[list[MissionItem], list[MissionItem], list[MissionItem]]:
    """(mission, fence, rally) items of a `.plan` JSON object; MissionError if malformed.

    Unsupported file/section versions are refused naming the field. A DO_JUMP's param1 (a
    `doJumpId` in QGC's files) becomes the target's sequence number in the mission list. The
    geoFence's `breachReturn` becomes a FENCE_RETURN_POINT (5000) fence item, first; rally
    points become RALLY_POINT (5100) items of MAV_MISSION_TYPE_RALLY.

    Args:
        doc: the parsed JSON.

    Returns:
        (mission, fence, rally) lists of `MissionItem`.

    Raises:
        MissionError: the document is malformed (naming the field).
    """
    if not isinstance(doc, dict) or doc.get("fileType") != "Plan":
        raise MissionError('not a QGroundControl plan (fileType must be "Plan")')
    _check_sections(doc)
    _check_versions(doc)
    mission = doc.get("mission")
    if not isinstance(mission, dict) or not isinstance(mission.get("items"), list):
        raise MissionError("mission.items: missing or not a list")
    check_item_count(len(mission["items"]), "mission.items")
    items: list[MissionItem] = []
    jump_ids: dict[int, int] = {}
    for k, raw in enumerate(mission["items"]):
        where = f"mission.items[{k}]"
        if not isinstance(raw, dict):
            raise MissionError(f"{where}: not an object")
        if raw.get("type") != "SimpleItem":
            raise MissionError(
                f"{where}: item type {quoted(raw.get('type'))} is not supported (only SimpleItem; "
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
        jump_id = raw.get("doJumpId")
        if jump_id is not None:
            if isinstance(jump_id, bool) or not isinstance(jump_id, int):
                raise MissionError(f"{where}.doJumpId: expected an integer, got {quoted(jump_id)}")
            if jump_id in jump_ids:  # DO_JUMP to it would go to whichever came last
                raise MissionError(f"{where}.doJumpId: {jump_id} is also the doJumpId of "
                                   f"mission.items[{jump_ids[jump_id]}]; each must be unique")
            jump_ids[jump_id] = len(items)
        item = (
            MissionItem(
                seq=len(items), command=command, frame=frame, current=0,
                autocontinue=int(_bool(raw, "autoContinue", where, True)),
                param1=p[0], param2=p[1], param3=p[2], param4=p[3], x=p[4], y=p[5], z=p[6],
                mission_type=MISSION_TYPE.MISSION,
            )
        )  # fmt: skip
        check_mission_item(item, lambda f, w=where: _plan_field(w, f))
        items.append(item)
    for k, it in enumerate(items):
        if it.command == CMD.DO_JUMP:
            target = jump_ids.get(int(it.param1)) if math.isfinite(it.param1) else None
            if target is None:
                raise MissionError(f"mission.items[{k}]: DO_JUMP targets doJumpId "
                                   f"{it.param1!r}, which no item has")  # fmt: skip
            items[k] = replace(it, param1=float(target))
    from lamde_mission.formats.waypoints import check_mission_list

    check_mission_list(items, "mission.items")
    fence = _parse_fence(doc.get("geoFence"))
    rally = _parse_rally(doc.get("rallyPoints"))
    return items, fence, rally


def _parse_rally(rp: Any) -> list[MissionItem]:
    if rp is None:
        return []
    if not isinstance(rp, dict):
        raise MissionError("rallyPoints: not an object")
    out = []
    for k, p in enumerate(rp.get("points") or []):
        where = f"rallyPoints.points[{k}]"
        if not isinstance(p, list) or len(p) != 3:
            raise MissionError(f"{where}: expected [lat, lon, alt]")
        lat, lon = _latlon_pair(p, where)
        alt = _float(p[2], where)
        it = MissionItem(seq=len(out), command=CMD.RALLY_POINT,
                         frame=FRAME.GLOBAL_RELATIVE_ALT, x=lat, y=lon, z=alt,
                         mission_type=MISSION_TYPE.RALLY)  # fmt: skip
        check_mission_item(it, lambda f, w=where: f"{w} ({_LLA.get(f, f)})")
        out.append(it)
        check_item_count(len(out), "rallyPoints.points")
    return out


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

    br = gf.get("breachReturn")
    if br is not None:
        if not isinstance(br, list) or len(br) != 3:
            raise MissionError("geoFence.breachReturn: expected [lat, lon, alt]")
        lat, lon = _latlon_pair(br, "geoFence.breachReturn")
        alt = _float(br[2], "geoFence.breachReturn")
        if not (math.isnan(lat) or math.isnan(lon)):
            it = MissionItem(seq=0, command=CMD.FENCE_RETURN_POINT,
                             frame=FRAME.GLOBAL_RELATIVE_ALT, x=lat, y=lon, z=alt,
                             mission_type=MISSION_TYPE.FENCE)  # fmt: skip
            check_mission_item(it, lambda f: f"geoFence.breachReturn ({_LLA.get(f, f)})")
            out.append(it)
    for k, poly in enumerate(gf.get("polygons") or []):
        where = f"geoFence.polygons[{k}]"
        verts = poly.get("polygon") if isinstance(poly, dict) else None
        if not isinstance(verts, list) or len(verts) < 3:
            raise MissionError(f"{where}.polygon: needs at least 3 [lat, lon] vertices")
        inclusion = _bool(poly, "inclusion", where, True)
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
        inclusion = _bool(c, "inclusion", where, True)
        cmd = CMD.FENCE_CIRCLE_INCLUSION if inclusion else CMD.FENCE_CIRCLE_EXCLUSION
        add(cmd, r, lat, lon, f"{where}.circle")
    return out


def write_qgc_plan(
    path: str | Path,
    items: Sequence[MissionItem],
    fence: Sequence[MissionItem] = (),
    **kwargs: Any,
) -> Path:
    """Write a `.plan` file atomically; keyword arguments as for `plan_document`.

    Args:
        path: the file to write.
        items: the mission items.
        fence: the fence items.
        **kwargs: `home`, `cruise_speed` and the other keywords of `plan_document`.

    Returns:
        The path written.

    Raises:
        ValueError: as `plan_document`, or a non-finite number JSON cannot hold.
    """
    doc = plan_document(items, fence, **kwargs)
    return write_text_atomic(path, json.dumps(doc, indent=4, allow_nan=False) + "\n")
