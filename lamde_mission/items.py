"""Plan -> MAVLink mission items (and geofence items), written in the sim's vocabulary.

Pure functions over frozen values: no I/O and no vehicle. The mission flown is

    TAKEOFF (at the start, to the map's altitude H)
    DO_CHANGE_SPEED (ground speed = v_max)
    LOITER_TIME x I (one per hover point; param1 = hover seconds; each is a full stop), and a
        WAYPOINT (param1 hold 0, param2 `corner_radius`, 0 once stored for ArduPilot-style
        dialects: `lamde_mission.storage.Dialect.waypoint_radius`) for each point whose hover
        time is 0 s: a detour corner around an obstacle, flown through, not a hover point
    WAYPOINT (at the end point)
    LAND (at the end point)  |  RETURN_TO_LAUNCH

Navigation items use MAV_FRAME_GLOBAL_RELATIVE_ALT (altitude above home); DO commands use
MAV_FRAME_MISSION. Yaw parameters are NaN ("keep the autopilot's yaw behaviour"), as QGroundControl
writes them. Latitude/longitude come from the map's origin through `sim.geo`.

The item type, the MAVLink enums and reading items back into a route belong to the simulator
(`sim.mission`); they are re-exported here so that writers and readers share one vocabulary.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from sim.geo import enu_to_latlon
from sim.mission import (
    CMD,
    FRAME,
    MISSION_TYPE,
    SNAP_M,
    MissionError,
    MissionItem,
    Route,
    fence_from_items,
    items_equal,
    items_to_route,
)

__all__ = [
    "MissionItem",
    "MissionError",
    "Route",
    "plan_to_items",
    "geofence_items",
    "fence_item",
    "fence_shapes",
    "fence_from_items",
    "items_to_route",
    "items_equal",
    "CMD",
    "FRAME",
    "MISSION_TYPE",
    "SNAP_M",
    "CORNER_RADIUS_MIN_M",
    "corner_radius",
    "corner_stops",
    "corner_indices",
    "flown_again",
    "end_point_index",
]

_NAN = float("nan")

#: metres: the least acceptance radius written in a corner's param2 (PX4 multicopters switch to
#: the next item inside it; 0 there would mean NAV_ACC_RAD, 10 m by default)
CORNER_RADIUS_MIN_M = 0.5


def corner_radius(map_: Any) -> float:
    """The acceptance radius (m) written in a corner WAYPOINT's param2: the map's obstacle
    clearance (`safety.clearance`), at least `CORNER_RADIUS_MIN_M`.

    A pass-through waypoint is cut on the inside of the turn, towards the obstacle the corner
    goes around, by at most about the acceptance radius (PX4 multicopter: param2 when > 0, else
    NAV_ACC_RAD; ArduPilot Copter ignores param2 and blends the corner within WPNAV_RADIUS,
    2 m by default, under WPNAV_ACCEL_C). A cut of at most the clearance stays outside the true
    obstacle: see docs/missions.md.

    Args:
        map_: the map (its `spec.safety.clearance`, m).

    Returns:
        The radius in metres.
    """
    return max(float(map_.spec.safety.clearance), CORNER_RADIUS_MIN_M)


def corner_stops(route: Route) -> np.ndarray:
    """The stops of `route` that are corners: WAYPOINT items without a hold (not hover points),
    except the last WAYPOINT (the end point). (K, 2) local metres, in flying order.

    Args:
        route: a mission read back by `items_to_route`.

    Returns:
        The corners' positions (K x 2, m); empty (0 x 2) when there are none.
    """
    ks = corner_indices(route)
    return np.asarray(route.stops, dtype=float).reshape(-1, 2)[ks].reshape(-1, 2)


def corner_indices(route: Route) -> np.ndarray:
    """The indices in `route.stops` of the corners (`corner_stops`), in flying order.

    Args:
        route: a mission read back by `items_to_route`.

    Returns:
        (K,) integer indices; `route.seqs` at them names each corner's item (a DO_JUMP loop
        flies the same item again: the figure draws it once).
    """
    ks = _plain_waypoints(route)
    return np.asarray(ks[:-1], dtype=np.int64)  # the last: the end point's WAYPOINT


def _plain_waypoints(route: Route) -> list[int]:
    """The indices in `route.stops` of WAYPOINT stops without a hold, in flying order."""
    return [k for k, (c, h) in enumerate(zip(route.commands, route.is_hover, strict=True))
            if c == CMD.WAYPOINT and not h]  # fmt: skip


def end_point_index(route: Route) -> int | None:
    """The index in `route.stops` of the end point: the last WAYPOINT without a hold (the
    one `corner_indices` leaves out; a DO_JUMP loop's last pass of it).

    Args:
        route: a mission read back by `items_to_route`.

    Returns:
        The index, or None when the mission flies no such WAYPOINT. O(len(route.stops)).
    """
    ks = _plain_waypoints(route)
    return ks[-1] if ks else None


def flown_again(route: Route) -> dict[int, int]:
    """The items a DO_JUMP loop flies more than once: how many times each stop's item is flown.

    Args:
        route: a mission read back by `items_to_route` (a DO_JUMP loop repeats its items'
            stops in `route.stops`, each pass one stop, `route.seqs` naming the item).

    Returns:
        {seq: passes} for the items flown two or more times, in seq order; empty without a
        loop. O(len(route.seqs)).
    """
    counts: dict[int, int] = {}
    for s in route.seqs:
        counts[s] = counts.get(s, 0) + 1
    return {s: n for s, n in sorted(counts.items()) if n > 1}


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
    A point whose hover time is exactly 0 s (a detour corner: the search puts obstacle
    corners there, the LP gives them no time) is written as NAV_WAYPOINT with hold 0 and
    param2 = `corner_radius(map)`, not as a 0-second LOITER_TIME: it is a turn, not a hover
    point (the sim reads it as a stop that is not a hover point, and still as a full stop of
    Eq. 1's trapezoid: its time and energy are those of a stop, an upper bound on a blended
    turn).

    Args:
        plan: anything with `hover_points` (I, 2) local metres and `hover_times` (I,) s.
        map: the map, with an origin; its start, end, altitude H (m) and v_max (m/s).
        finish: "land" (LAND at the end point) or "rtl" (RETURN_TO_LAUNCH).
        speed: the cruise speed of DO_CHANGE_SPEED, m/s; None: the map's v_max.

    Returns:
        TAKEOFF, DO_CHANGE_SPEED, one LOITER_TIME (or corner WAYPOINT) per point, the end
        WAYPOINT, then LAND or RETURN_TO_LAUNCH; frame GLOBAL_RELATIVE_ALT at altitude H.

    Raises:
        ValueError: a `finish` other than "land"/"rtl", or hover points and hover times of
            different lengths.
        MissingOriginError: the map has no origin.
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
    r_corner = corner_radius(map)
    for (lat, lon), t in zip(hover_ll, ht, strict=True):
        if float(t) == 0.0:
            # a corner: WAYPOINT p1 hold 0 s, p2 acceptance radius, p3 pass 0, p4 yaw NaN
            add(CMD.WAYPOINT, rel, 0.0, r_corner, 0.0, _NAN, pos=(lat, lon, alt))
            continue
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

    Args:
        map: a loaded map.

    Returns:
        (circles, polygons): circles [(centre (2,), r)] in metres, polygons [(n, 2)] in
        metres.
    """
    circles = [(np.array([c.x, c.y], dtype=float), float(c.radius))
               for c in map.spec.obstacles.circles]  # fmt: skip
    polys = [np.asarray(p, dtype=float) for p in map.rectangle_polygons]
    for sh in map.shapes:
        polys += sh.pieces() if sh.holes else [np.asarray(sh.shell, dtype=float)]
    return circles, polys


def fence_item(seq: int, command: int, p1: float, lat: float, lon: float) -> MissionItem:
    """One fence vertex or circle item as QGroundControl and MAVSDK write them (frame GLOBAL,
    autocontinue 0, mission type FENCE; param1 = vertex count or radius).

    Args:
        seq: its position in the fence list.
        command: a FENCE_* MAV_CMD (`CMD`).
        p1: param1: the polygon's vertex count, or the circle's radius (m).
        lat: latitude, degrees.
        lon: longitude, degrees.

    Returns:
        The `MissionItem` (z 0).
    """
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

    Args:
        map: the map, with an origin.

    Returns:
        The fence items, seq from 0: the polygons of `fence_shapes` (rectangles, then no-fly
        zones and polygon obstacles) vertex by vertex, then the circles.

    Raises:
        MissingOriginError: the map has no origin.
    """
    circles, polys = fence_shapes(map)
    out: list[MissionItem] = []

    def add(command: int, p1: float, lat: float, lon: float) -> None:
        out.append(fence_item(len(out), command, p1, lat, lon))

    # every vertex and centre converted in one call (one per polygon made a campus of a
    # thousand obstacles spend a second here), then taken back in order
    pts = [np.asarray(p, dtype=float).reshape(-1, 2) for p in polys]
    pts += [np.asarray(c, dtype=float).reshape(-1, 2) for c, _ in circles]
    ll = iter(_latlon(map, np.vstack(pts)) if pts else [])
    for poly in polys:
        for _ in range(len(poly)):
            lat, lon = next(ll)
            add(CMD.FENCE_POLYGON_VERTEX_EXCLUSION, len(poly), lat, lon)
    for _, r in circles:
        lat, lon = next(ll)
        add(CMD.FENCE_CIRCLE_EXCLUSION, r, lat, lon)
    return out
