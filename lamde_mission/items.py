"""Plan -> MAVLink mission items (and geofence items), and mission items -> local route.

Pure functions over frozen values: no I/O and no vehicle. The mission flown is

    TAKEOFF (at the start, to the map's altitude H)
    DO_CHANGE_SPEED (ground speed = v_max)
    LOITER_TIME x I (one per hover point; param1 = hover seconds; each is a full stop)
    WAYPOINT (at the end point)
    LAND (at the end point)  |  RETURN_TO_LAUNCH

Navigation items use MAV_FRAME_GLOBAL_RELATIVE_ALT (altitude above home); DO commands use
MAV_FRAME_MISSION. Yaw parameters are NaN ("keep the autopilot's yaw behaviour"), as QGroundControl
writes them. Latitude/longitude come from the map's origin through `lamde_mission.geo`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from pymavlink import mavutil

from lamde_mission.geo import enu_to_latlon, latlon_to_enu, origin_of

__all__ = [
    "MissionItem",
    "MissionError",
    "Route",
    "plan_to_items",
    "geofence_items",
    "fence_item",
    "fence_shapes",
    "items_to_route",
    "items_equal",
    "CMD",
    "FRAME",
    "MISSION_TYPE",
]

_m = mavutil.mavlink


class CMD:
    """The MAV_CMD values this module writes or reads (from pymavlink's generated constants)."""

    WAYPOINT = _m.MAV_CMD_NAV_WAYPOINT  # 16
    LOITER_UNLIM = _m.MAV_CMD_NAV_LOITER_UNLIM  # 17
    LOITER_TIME = _m.MAV_CMD_NAV_LOITER_TIME  # 19
    RETURN_TO_LAUNCH = _m.MAV_CMD_NAV_RETURN_TO_LAUNCH  # 20
    LAND = _m.MAV_CMD_NAV_LAND  # 21
    TAKEOFF = _m.MAV_CMD_NAV_TAKEOFF  # 22
    DO_CHANGE_SPEED = _m.MAV_CMD_DO_CHANGE_SPEED  # 178
    FENCE_POLYGON_VERTEX_INCLUSION = _m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION  # 5001
    FENCE_POLYGON_VERTEX_EXCLUSION = _m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION  # 5002
    FENCE_CIRCLE_INCLUSION = _m.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION  # 5003
    FENCE_CIRCLE_EXCLUSION = _m.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION  # 5004


class FRAME:
    GLOBAL = _m.MAV_FRAME_GLOBAL  # 0: altitude above mean sea level
    MISSION = _m.MAV_FRAME_MISSION  # 2: not a position (DO commands)
    GLOBAL_RELATIVE_ALT = _m.MAV_FRAME_GLOBAL_RELATIVE_ALT  # 3: altitude above home
    GLOBAL_INT = _m.MAV_FRAME_GLOBAL_INT  # 5
    GLOBAL_RELATIVE_ALT_INT = _m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT  # 6


class MISSION_TYPE:  # noqa: N801 - mirrors the MAVLink enum name
    MISSION = _m.MAV_MISSION_TYPE_MISSION  # 0
    FENCE = _m.MAV_MISSION_TYPE_FENCE  # 1
    RALLY = _m.MAV_MISSION_TYPE_RALLY  # 2


_NAN = float("nan")


class MissionError(ValueError):
    """A mission the sim cannot fly (unsupported command or frame, missing positions)."""


@dataclass(frozen=True)
class MissionItem:
    """One MAVLink MISSION_ITEM: x = latitude (deg), y = longitude (deg), z = altitude (m)."""

    seq: int
    command: int
    frame: int = FRAME.GLOBAL_RELATIVE_ALT
    current: int = 0
    autocontinue: int = 1
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    mission_type: int = MISSION_TYPE.MISSION

    @property
    def params(self) -> tuple[float, float, float, float, float, float, float]:
        """The seven MAVLink parameters [p1, p2, p3, p4, lat, lon, alt]."""
        return (self.param1, self.param2, self.param3, self.param4, self.x, self.y, self.z)

    def with_seq(self, seq: int) -> MissionItem:
        return replace(self, seq=int(seq))

    def without_nan(self, fill: float = 0.0) -> MissionItem:
        """This item with NaN parameters replaced by `fill` (for formats without NaN)."""
        names = ("param1", "param2", "param3", "param4", "x", "y", "z")
        return replace(self, **{k: fill for k in names if math.isnan(getattr(self, k))})

    def same_as(self, other: MissionItem, *, rel: float = 0.0, abs_: float = 0.0) -> bool:
        """Equality that treats NaN parameters as equal (dataclass `==` does not)."""
        ints = ("seq", "command", "frame", "current", "autocontinue", "mission_type")
        if any(int(getattr(self, k)) != int(getattr(other, k)) for k in ints):
            return False
        for a, b in zip(self.params, other.params, strict=True):
            if math.isnan(a) or math.isnan(b):
                if not (math.isnan(a) and math.isnan(b)):
                    return False
            elif not math.isclose(a, b, rel_tol=rel, abs_tol=abs_):
                return False
        return True


def items_equal(
    a: Sequence[MissionItem], b: Sequence[MissionItem], *, rel: float = 0.0, abs_: float = 0.0
) -> bool:
    """Two item lists are equal item by item (NaN equal to NaN)."""
    if len(a) != len(b):
        return False
    return all(x.same_as(y, rel=rel, abs_=abs_) for x, y in zip(a, b, strict=True))


# ----------------------------------------------------------------------------- plan -> items


def _latlon(map_: Any, pts: np.ndarray) -> list[tuple[float, float]]:
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    lat, lon = enu_to_latlon(pts[:, 0], pts[:, 1], map_)
    return [(float(a), float(b)) for a, b in zip(lat, lon, strict=True)]


def plan_to_items(
    plan: Any,
    map: Any,  # noqa: A002 - the project's name for it
    *,
    finish: Literal["land", "rtl"] = "land",
    speed: float | None = None,
) -> list[MissionItem]:
    """The mission (MAV_MISSION_TYPE_MISSION items, seq from 0) that flies `plan` on `map`.

    `plan` is anything with `hover_points` (I x 2, local metres) and `hover_times` (s).
    `speed` overrides the cruise speed (default the map's v_max). With finish="rtl" the last
    item is RETURN_TO_LAUNCH: the vehicle flies back to the start, a leg outside the paper's f.
    """
    if finish not in ("land", "rtl"):
        raise ValueError(f"finish must be 'land' or 'rtl', got {finish!r}")
    hp = np.asarray(plan.hover_points, dtype=float).reshape(-1, 2)
    ht = np.asarray(plan.hover_times, dtype=float).reshape(-1)
    if len(hp) != len(ht):
        raise ValueError("hover_points and hover_times differ in length")
    uav = map.spec.uav
    alt = float(uav.altitude)
    v = float(uav.max_speed if speed is None else speed)
    start, end = _latlon(map, map.start)[0], _latlon(map, map.end)[0]
    hover_ll = _latlon(map, hp)
    out: list[MissionItem] = []

    def add(command: int, frame: int, *params: float, pos: tuple[float, float, float] = (0, 0, 0)):
        p = list(params) + [0.0] * (4 - len(params))
        out.append(
            MissionItem(
                seq=len(out), command=command, frame=frame,
                param1=float(p[0]), param2=float(p[1]), param3=float(p[2]), param4=float(p[3]),
                x=float(pos[0]), y=float(pos[1]), z=float(pos[2]),
            )
        )  # fmt: skip

    rel = FRAME.GLOBAL_RELATIVE_ALT
    # TAKEOFF: p1 minimum pitch (planes), p4 yaw (NaN: unchanged)
    add(CMD.TAKEOFF, rel, 0.0, 0.0, 0.0, _NAN, pos=(*start, alt))
    # DO_CHANGE_SPEED: p1 speed type 1 = ground speed, p2 speed m/s, p3 throttle -1 = no change
    add(CMD.DO_CHANGE_SPEED, FRAME.MISSION, 1.0, v, -1.0, 0.0)
    for (lat, lon), t in zip(hover_ll, ht, strict=True):
        # LOITER_TIME: p1 seconds, p2 heading required 0, p3 radius 0 (hover on the spot),
        # p4 xtrack 0 (leave from the centre)
        add(CMD.LOITER_TIME, rel, float(t), 0.0, 0.0, 0.0, pos=(lat, lon, alt))
    # WAYPOINT at the end: p1 hold 0 s, p2 acceptance radius 0 (autopilot default), p3 pass 0,
    # p4 yaw NaN
    add(CMD.WAYPOINT, rel, 0.0, 0.0, 0.0, _NAN, pos=(*end, alt))
    if finish == "land":
        # LAND: p1 abort altitude 0, p2 precision-land mode 0, p4 yaw NaN; z = 0 above home
        add(CMD.LAND, rel, 0.0, 0.0, 0.0, _NAN, pos=(*end, 0.0))
    else:
        add(CMD.RETURN_TO_LAUNCH, FRAME.MISSION)
    return out


# ----------------------------------------------------------------------------- geofence


def fence_shapes(map: Any) -> tuple[list[tuple[np.ndarray, float]], list[np.ndarray]]:  # noqa: A002
    """The map's obstacles as fence shapes in local metres: (circles [(centre, r)], polygons).

    Polygons are the rotated rectangles (from `map.rectangle_polygons`) then the no-fly zones
    and polygon obstacles (`map.shapes`), each an (n, 2) counter-clockwise vertex array: a shape
    without holes as its exterior ring (exclusion polygons need not be convex), a shape with
    holes as its convex pieces (a fence polygon has no holes; the pieces leave a courtyard open).
    """
    circles = [(np.array([c.x, c.y], dtype=float), float(c.radius))
               for c in map.spec.obstacles.circles]  # fmt: skip
    polys = [np.asarray(p, dtype=float) for p in map.rectangle_polygons]
    for sh in map.shapes:
        polys += sh.pieces() if sh.holes else [np.asarray(sh.shell, dtype=float)]
    return circles, polys


def fence_item(seq: int, command: int, p1: float, lat: float, lon: float) -> MissionItem:
    """One fence vertex or circle item as QGroundControl and MAVSDK write them (frame GLOBAL,
    autocontinue 0, mission type FENCE; param1 = vertex count or radius)."""
    return MissionItem(
        seq=seq, command=command, frame=FRAME.GLOBAL, autocontinue=0, param1=float(p1),
        x=lat, y=lon, z=0.0, mission_type=MISSION_TYPE.FENCE,
    )  # fmt: skip


def geofence_items(map: Any) -> list[MissionItem]:  # noqa: A002
    """Exclusion fence (MAV_MISSION_TYPE_FENCE) items for every obstacle of the map.

    Rectangles and no-fly zones: FENCE_POLYGON_VERTEX_EXCLUSION, one item per vertex (param1 =
    vertex count); then circles: FENCE_CIRCLE_EXCLUSION (param1 = radius m). Polygons first and
    autocontinue 0, as QGroundControl and MAVSDK's importer produce them, so the same fence
    reads the same through either. Frame GLOBAL (the altitude is unused by fences).
    """
    circles, polys = fence_shapes(map)
    out: list[MissionItem] = []

    def add(command: int, p1: float, lat: float, lon: float) -> None:
        out.append(fence_item(len(out), command, p1, lat, lon))

    for poly in polys:
        for lat, lon in _latlon(map, poly):
            add(CMD.FENCE_POLYGON_VERTEX_EXCLUSION, len(poly), lat, lon)
    for centre, r in circles:
        ((lat, lon),) = _latlon(map, centre)
        add(CMD.FENCE_CIRCLE_EXCLUSION, r, lat, lon)
    return out


def fence_from_items(items: Iterable[MissionItem]) -> tuple[list[tuple], list[list[tuple]]]:
    """Group fence items into circles [(lat, lon, radius, inclusion)] and polygons
    [[(lat, lon), ...] with `inclusion` as the first element's 3rd field]; raise MissionError
    on a polygon whose vertex count does not match param1."""
    circles: list[tuple] = []
    polygons: list[list[tuple]] = []
    pending: list[MissionItem] = []
    poly_cmds = (CMD.FENCE_POLYGON_VERTEX_EXCLUSION, CMD.FENCE_POLYGON_VERTEX_INCLUSION)
    for it in items:
        if it.command in (CMD.FENCE_CIRCLE_EXCLUSION, CMD.FENCE_CIRCLE_INCLUSION):
            if pending:
                raise MissionError(f"fence item {it.seq}: polygon interrupted before its end")
            inclusion = it.command == CMD.FENCE_CIRCLE_INCLUSION
            circles.append((it.x, it.y, it.param1, inclusion))
        elif it.command in poly_cmds:
            if pending and (it.command != pending[0].command or it.param1 != pending[0].param1):
                raise MissionError(f"fence item {it.seq}: polygon interrupted before its end")
            pending.append(it)
            n = int(round(pending[0].param1))
            if n < 3:
                raise MissionError(f"fence item {it.seq}: a polygon needs at least 3 vertices")
            if len(pending) == n:
                inclusion = pending[0].command == CMD.FENCE_POLYGON_VERTEX_INCLUSION
                polygons.append([(p.x, p.y, inclusion) for p in pending])
                pending = []
        else:
            raise MissionError(f"fence item {it.seq}: command {it.command} is not a fence item")
    if pending:
        raise MissionError("fence: the last polygon has fewer vertices than its param1 says")
    return circles, polygons


# ----------------------------------------------------------------------------- items -> route

#: legs shorter than this (metres) are zero: below what a mission file carries (MAVLink's
#: int32 1e-7 degree latitude is ~1.1 cm); avoids sqrt(d) blowing round-off up into seconds.
SNAP_M = 1e-6

_GLOBAL_FRAMES = {FRAME.GLOBAL, FRAME.GLOBAL_INT}
_RELATIVE_FRAMES = {FRAME.GLOBAL_RELATIVE_ALT, FRAME.GLOBAL_RELATIVE_ALT_INT}


@dataclass(frozen=True, eq=False)
class Route:
    """What a mission asks the vehicle to fly, in the map's local metres.

    `stops` are the horizontal positions the vehicle comes to rest at, in order (every
    navigation item is a full stop, as in the paper); `launch` is where it takes off.
    `hover_times[k]` is the time spent hovering at stop k (LOITER_TIME param1, or a WAYPOINT's
    hold time); `is_hover[k]` marks the stops that are hover points of the paper's model.
    """

    launch: np.ndarray
    takeoff_altitude: float | None
    stops: np.ndarray
    altitudes: np.ndarray
    hover_times: np.ndarray
    is_hover: np.ndarray
    seqs: tuple[int, ...]
    commands: tuple[int, ...]
    speed: float | None
    finish: Literal["land", "rtl", "none"]
    notes: tuple[str, ...] = field(default=())

    @property
    def hover_points(self) -> np.ndarray:
        return self.stops[self.is_hover]

    @property
    def hover_durations(self) -> np.ndarray:
        return self.hover_times[self.is_hover]


def _relative_alt(it: MissionItem, home_alt: float) -> float:
    if it.frame in _RELATIVE_FRAMES:
        return float(it.z)
    if it.frame in _GLOBAL_FRAMES:
        return float(it.z) - home_alt
    raise MissionError(
        f"item {it.seq}: frame {it.frame} is not supported (use a global frame, absolute or "
        "relative altitude)"
    )


def _has_position(it: MissionItem) -> bool:
    """MAVLink: latitude and longitude both 0 (or NaN) mean "the current position"."""
    if math.isnan(it.x) or math.isnan(it.y):
        return False
    return not (it.x == 0.0 and it.y == 0.0)


def _command_name(c: int) -> str:
    entry = mavutil.mavlink.enums["MAV_CMD"].get(c)
    return entry.name if entry is not None else f"command {c}"


def items_to_route(items: Sequence[MissionItem], map: Any) -> Route:  # noqa: A002
    """Read a mission back into local metres: launch, stops, hover times, speed and finish.

    Supported navigation commands: TAKEOFF, WAYPOINT (param1 = hold s), LOITER_TIME
    (param1 = s), LAND, RETURN_TO_LAUNCH; DO_CHANGE_SPEED sets the speed; other DO/CONDITION
    commands are ignored with a note. Items after LAND/RTL are ignored with a note. Raises
    MissionError for anything else the sim cannot fly.
    """
    lat0, lon0, home_alt = origin_of(map)
    start = np.asarray(map.start, dtype=float)
    launch = start.copy()
    takeoff_alt: float | None = None
    stops: list[tuple[float, float]] = []
    alts: list[float] = []
    hover: list[float] = []
    is_hover: list[bool] = []
    seqs: list[int] = []
    cmds: list[int] = []
    speed: float | None = None
    finish: Literal["land", "rtl", "none"] = "none"
    notes: list[str] = []
    mission = [it for it in items if it.mission_type == MISSION_TYPE.MISSION]
    if len(mission) != len(list(items)):
        notes.append("non-mission items (fence/rally) were ignored")

    def position(it: MissionItem) -> tuple[float, float]:
        e, n = latlon_to_enu(it.x, it.y, (lat0, lon0, home_alt))
        return float(e), float(n)

    def current() -> tuple[float, float]:
        return stops[-1] if stops else (float(launch[0]), float(launch[1]))

    for it in mission:
        c = it.command
        if finish != "none":
            notes.append(f"items from seq {it.seq} on come after the landing and were ignored")
            break
        if c == CMD.TAKEOFF:
            if stops or takeoff_alt is not None:
                raise MissionError(f"item {it.seq}: TAKEOFF in flight is not supported")
            if _has_position(it):
                launch = np.array(position(it))
            takeoff_alt = _relative_alt(it, home_alt)
        elif c in (CMD.WAYPOINT, CMD.LOITER_TIME):
            if c == CMD.LOITER_TIME and not (it.param1 >= 0 and math.isfinite(it.param1)):
                raise MissionError(f"item {it.seq}: LOITER_TIME needs a finite time >= 0 s")
            hold = float(it.param1) if math.isfinite(it.param1) else 0.0
            stops.append(position(it) if _has_position(it) else current())
            alts.append(_relative_alt(it, home_alt))
            hover.append(max(hold, 0.0))
            is_hover.append(c == CMD.LOITER_TIME or hold > 0.0)
            seqs.append(int(it.seq))
            cmds.append(int(c))
        elif c == CMD.LAND:
            stops.append(position(it) if _has_position(it) else current())
            alts.append(0.0)
            hover.append(0.0)
            is_hover.append(False)
            seqs.append(int(it.seq))
            cmds.append(int(c))
            finish = "land"
        elif c == CMD.RETURN_TO_LAUNCH:
            finish = "rtl"
        elif c == CMD.DO_CHANGE_SPEED:
            if it.param2 > 0 and math.isfinite(it.param2):
                speed = float(it.param2)
        elif c < 100:  # MAV_CMD_NAV_* range: a movement the sim cannot model
            raise MissionError(f"item {it.seq}: {_command_name(c)} is not supported by the sim")
        else:  # CONDITION_* / DO_* / others: no horizontal motion
            notes.append(f"item {it.seq}: {_command_name(c)} ignored by the sim")
    if not stops:
        raise MissionError("the mission has no navigation items to fly")
    if takeoff_alt is None:
        notes.append("no TAKEOFF item: launch assumed at the map's start")
    return Route(
        launch=launch,
        takeoff_altitude=takeoff_alt,
        stops=np.array(stops, dtype=float).reshape(-1, 2),
        altitudes=np.array(alts, dtype=float),
        hover_times=np.array(hover, dtype=float),
        is_hover=np.array(is_hover, dtype=bool),
        seqs=tuple(seqs),
        commands=tuple(cmds),
        speed=speed,
        finish=finish,
        notes=tuple(notes),
    )
