"""The mission as the vehicle sees it: MAVLink items, their command/frame enums, and the route
they fly.

This is the sim's vocabulary: `lamde_mission` writes plans into it (`lamde_mission.items`
re-exports these names) and the sim reads missions through it. Pure values and functions: no
I/O, no vehicle, nothing of the optimiser. Command, frame and mission-type numbers are pymavlink's
generated constants (MAVLink common.xml).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from pymavlink import mavutil

from planner_core.defaults import MAP_DEFAULTS
from sim.geo import latlon_to_enu, origin_of

__all__ = [
    "CMD",
    "FRAME",
    "MISSION_TYPE",
    "MAX_FLIGHT_ALTITUDE",
    "SNAP_M",
    "MissionError",
    "MissionItem",
    "Route",
    "fence_from_items",
    "check_items",
    "command_name",
    "items_equal",
    "items_to_route",
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
    DO_JUMP = _m.MAV_CMD_DO_JUMP  # 177
    DO_CHANGE_SPEED = _m.MAV_CMD_DO_CHANGE_SPEED  # 178
    FENCE_RETURN_POINT = _m.MAV_CMD_NAV_FENCE_RETURN_POINT  # 5000
    FENCE_POLYGON_VERTEX_INCLUSION = _m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION  # 5001
    FENCE_POLYGON_VERTEX_EXCLUSION = _m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION  # 5002
    FENCE_CIRCLE_INCLUSION = _m.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION  # 5003
    FENCE_CIRCLE_EXCLUSION = _m.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION  # 5004
    RALLY_POINT = _m.MAV_CMD_NAV_RALLY_POINT  # 5100

    #: commands that belong to the fence list (MAV_MISSION_TYPE_FENCE), never to a mission
    FENCE_COMMANDS = frozenset({5000, 5001, 5002, 5003, 5004})


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
        """The seven MAVLink parameters.

        Returns:
            (p1, p2, p3, p4, lat, lon, alt): param1..param4, x (deg), y (deg), z (m).
        """
        return (self.param1, self.param2, self.param3, self.param4, self.x, self.y, self.z)

    def with_seq(self, seq: int) -> MissionItem:
        """This item at another position in its list.

        Args:
            seq: the new sequence number (cast to int).

        Returns:
            A copy with `seq` replaced.
        """
        return replace(self, seq=int(seq))

    def without_nan(self, fill: float = 0.0) -> MissionItem:
        """This item with NaN parameters replaced by `fill` (for formats without NaN).

        Args:
            fill: the value for each NaN among param1..param4, x, y, z.

        Returns:
            A copy (the same values where none is NaN).
        """
        names = ("param1", "param2", "param3", "param4", "x", "y", "z")
        return replace(self, **{k: fill for k in names if math.isnan(getattr(self, k))})

    def same_as(self, other: MissionItem, *, rel: float = 0.0, abs_: float = 0.0) -> bool:
        """Equality that treats NaN parameters as equal (dataclass `==` does not).

        Args:
            other: the item to compare with.
            rel: relative tolerance on the seven parameters (`math.isclose`'s rel_tol).
            abs_: absolute tolerance on them, in their own units (`math.isclose`'s abs_tol).

        Returns:
            True when seq, command, frame, current, autocontinue and mission_type are equal
            and each parameter is close (or NaN in both).
        """
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
    """Two item lists are equal item by item (NaN equal to NaN).

    Args:
        a: the first list of items.
        b: the second list of items.
        rel: relative tolerance on each parameter (`MissionItem.same_as`).
        abs_: absolute tolerance on each parameter (`MissionItem.same_as`).

    Returns:
        True when the lists have the same length and every pair is `same_as`.
    """
    if len(a) != len(b):
        return False
    return all(x.same_as(y, rel=rel, abs_=abs_) for x, y in zip(a, b, strict=True))


# ------------------------------------------------------------------------- fence items -> shapes


def fence_from_items(items: Iterable[MissionItem]) -> tuple[list[tuple], list[list[tuple]]]:
    """Group fence items into circles and polygons.

    Args:
        items: fence items (MAV_MISSION_TYPE_FENCE) in seq order; FENCE_RETURN_POINT items
            are skipped.

    Returns:
        (circles, polygons): circles [(lat, lon, radius, inclusion)] (deg, deg, m from
        param1, bool); polygons [[(lat, lon, inclusion), ...]], one list per polygon, each
        vertex carrying its polygon's `inclusion` (the first element's 3rd field).

    Raises:
        MissionError: a polygon whose vertex count does not match param1 (interrupted, or
            the last one short), a polygon of fewer than 3 vertices, or an item that is not
            a fence item.
    """
    circles: list[tuple] = []
    polygons: list[list[tuple]] = []
    pending: list[MissionItem] = []
    poly_cmds = (CMD.FENCE_POLYGON_VERTEX_EXCLUSION, CMD.FENCE_POLYGON_VERTEX_INCLUSION)
    for it in items:
        if it.command == CMD.FENCE_RETURN_POINT:  # the breach-return point: not a shape
            continue
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

#: most items one replay runs (DO_JUMP repeats included) before the mission is refused
MAX_EXECUTED_ITEMS = 100_000

#: highest altitude above or below home (m) the sim flies: the map's own `uav.altitude` bound
#: (planner_core.defaults: "a rotary-wing UAV flies above the ground and below 10 km"), so a
#: mission file cannot ask for more than a map may; DJI's and the common multirotors' service
#: ceilings lie below 7 km AMSL
MAX_FLIGHT_ALTITUDE: float = float(MAP_DEFAULTS["uav.altitude"].bounds[1])
#: DO_CHANGE_SPEED param1 values (MAVLink SPEED_TYPE) that name a vertical speed: ArduPilot
#: Copter's mission sets its climb or descent speed from them (WPNAV_SPEED_UP / _DN), while PX4's
#: navigator takes param2 as the cruise speed whatever the type. The sim flies PX4's reading, the
#: slower and costlier one for a battery, and says so in a note.
_VERTICAL_SPEED_TYPES = {2.0: "climb speed", 3.0: "descent speed"}

#: m/s: the least DO_CHANGE_SPEED speed the sim flies: the map's own `uav.max_speed` bound
MIN_MISSION_SPEED: float = float(MAP_DEFAULTS["uav.max_speed"].bounds[0])

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
    #: per stop: the DO_CHANGE_SPEED speed in force on the leg that arrives there (m/s; None:
    #: none set yet, the UAV's v_max); empty means `speed` for every leg
    leg_speeds: tuple[float | None, ...] = field(default=())
    #: the speed in force at the end of the mission (the RTL return leg flies at it)
    final_speed: float | None = None

    @property
    def hover_points(self) -> np.ndarray:
        """The stops that are hover points of the paper's model.

        Returns:
            (I, 2) local metres, `stops[is_hover]`.
        """
        return self.stops[self.is_hover]

    @property
    def hover_durations(self) -> np.ndarray:
        """The hover times of the hover points.

        Returns:
            (I,) seconds, `hover_times[is_hover]`.
        """
        return self.hover_times[self.is_hover]


def _relative_alt(it: MissionItem, home_alt: float | None) -> float:
    """The altitude of `it` above home (m); MissionError for a frame the sim cannot fly or an
    altitude beyond +-MAX_FLIGHT_ALTITUDE. `home_alt` None (no map yet): an absolute altitude
    is returned as it is, unchecked (`check_items` knows no home)."""
    if it.frame in _RELATIVE_FRAMES:
        rel = float(it.z)
        what = "above home"
    elif it.frame in _GLOBAL_FRAMES:
        if home_alt is None:
            return float(it.z)
        rel = float(it.z) - home_alt
        what = f"AMSL, {rel:.10g} m above home at {home_alt:g} m"
    else:
        raise MissionError(
            f"item {it.seq}: frame {it.frame} is not supported (use a global frame, absolute or "
            "relative altitude)"
        )
    if not abs(rel) <= MAX_FLIGHT_ALTITUDE:
        raise MissionError(
            f"item {it.seq}: altitude {float(it.z):.10g} m ({what}) is outside "
            f"[-{MAX_FLIGHT_ALTITUDE:g}, {MAX_FLIGHT_ALTITUDE:g}] m of home: no rotary-wing UAV "
            "flies 10 km (the map's uav.altitude bound)"
        )
    return rel


def _has_position(it: MissionItem) -> bool:
    """MAVLink: latitude and longitude both 0 (or NaN) mean "the current position"."""
    if math.isnan(it.x) or math.isnan(it.y):
        return False
    return not (it.x == 0.0 and it.y == 0.0)


def command_name(c: int) -> str:
    """The MAV_CMD name of command number `c` (e.g. 16 -> "MAV_CMD_NAV_WAYPOINT").

    Args:
        c: the MAV_CMD number.

    Returns:
        Its name in pymavlink's MAV_CMD enum, or "command <c>" for a number it lacks.
    """
    entry = mavutil.mavlink.enums["MAV_CMD"].get(c)
    return entry.name if entry is not None else f"command {c}"


_command_name = command_name


def check_items(items: Sequence[MissionItem]) -> None:
    """The checks of `items_to_route` that need no map, with the same messages: frames,
    altitudes above home, LOITER_TIME, a second TAKEOFF, DO_JUMP, unsupported navigation
    commands, a mission with nothing to fly. `upload` runs them before sending (absolute
    altitudes are checked against home only by `items_to_route`: home is the map's).

    Args:
        items: the mission items, in seq order (fence and rally items are skipped).

    Raises:
        MissionError: the first problem, naming the item, as `items_to_route` words it.
    """
    _walk(items, (0.0, 0.0, None), np.zeros(2))


def items_to_route(items: Sequence[MissionItem], map: Any) -> Route:  # noqa: A002
    """Read a mission back into local metres: launch, stops, hover times, speed and finish.

    Supported navigation commands: TAKEOFF, WAYPOINT (param1 = hold s), LOITER_TIME (param1 =
    s), LAND, RETURN_TO_LAUNCH; DO_CHANGE_SPEED sets the speed from its position on (the legs
    after it; a speed <= 0 changes nothing, as on PX4 and ArduPilot, one below
    `MIN_MISSION_SPEED` is refused; a climb or descent speed type, param1 2 or 3, is flown as
    the cruise speed, as PX4 does, with a note of ArduPilot's reading); DO_JUMP (param1 = the
    target's seq in this list, param2 = repeats) is flown: the items from the target on run
    again, `param2` more times, at most `MAX_EXECUTED_ITEMS` items in all (a jump repeated
    forever, param2 = -1, is refused). Other DO/CONDITION commands are ignored with a note.
    Items after LAND/RTL are ignored with a note. Altitudes more than `MAX_FLIGHT_ALTITUDE`
    above or below home are refused. Each distinct note is made once, with how many times it
    came up when a DO_JUMP repeats it. Without a TAKEOFF item the launch is the map's start,
    with a note of what each autopilot does then (ArduCopter refuses to start the mission on
    the ground; PX4 climbs first where it stands).

    Args:
        items: the mission items, in seq order (fence and rally items are ignored, noted).
        map: the map (its origin places the items, its start is the default launch).

    Returns:
        The Route the mission flies.

    Raises:
        MissionError: anything the sim cannot fly, naming the item.
    """
    lat0, lon0, home_alt = origin_of(map)
    return _walk(items, (lat0, lon0, home_alt), np.asarray(map.start, dtype=float))


def _walk(
    items: Sequence[MissionItem],
    origin: tuple[float, float, float | None],
    start: np.ndarray,
) -> Route:
    """`items_to_route` from an origin (lat, lon, home altitude or None) and a start point."""
    lat0, lon0, home_alt = origin
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
    # each distinct note once, with how often it came up (a DO_JUMP loop passes an ignored
    # item once per repeat: 24,000 identical lines); insertion order kept
    seen: dict[str, int] = {}

    def note(text: str) -> None:
        seen[text] = seen.get(text, 0) + 1

    mission = [it for it in items if it.mission_type == MISSION_TYPE.MISSION]
    if len(mission) != len(list(items)):
        note("non-mission items (fence/rally) were ignored")

    def position(it: MissionItem) -> tuple[float, float]:
        if home_alt is None:  # check_items: no map, the positions do not matter
            return 0.0, 0.0
        e, n = latlon_to_enu(it.x, it.y, (lat0, lon0, home_alt))
        return float(e), float(n)

    def current() -> tuple[float, float]:
        return stops[-1] if stops else (float(launch[0]), float(launch[1]))

    speeds: list[float | None] = []
    index_of_seq = {int(it.seq): k for k, it in enumerate(mission)}
    jumps_left: dict[int, int] = {}  # DO_JUMP list index -> repeats still to fly
    held: set[int] = set()  # seqs noted for autocontinue 0 (once each, DO_JUMP or not)
    pc = 0
    executed = 0
    while pc < len(mission):
        it = mission[pc]
        pc += 1
        executed += 1
        if executed > MAX_EXECUTED_ITEMS:
            raise MissionError(f"the mission runs more than {MAX_EXECUTED_ITEMS} items "
                               "(DO_JUMP repeats): refused")  # fmt: skip
        c = it.command
        if finish != "none":
            note(f"items from seq {it.seq} on come after the landing and were ignored")
            break
        if not it.autocontinue and c < 100 and int(it.seq) not in held:  # a NAV_* item
            held.add(int(it.seq))
            note(f"item {it.seq}: autocontinue 0: PX4 holds there until told to go on "
                 "(ArduPilot ignores the flag); the sim flies on")  # fmt: skip
        if c == CMD.DO_JUMP:
            target, repeats = it.param1, it.param2
            if not (math.isfinite(target) and math.isfinite(repeats)):
                raise MissionError(f"item {it.seq}: DO_JUMP needs a target and a repeat count")
            if int(repeats) < 0:
                raise MissionError(f"item {it.seq}: DO_JUMP repeated forever (param2 = "
                                   f"{int(repeats)}) has no end to fly to")  # fmt: skip
            k = index_of_seq.get(int(target))
            if k is None:
                raise MissionError(f"item {it.seq}: DO_JUMP targets item {int(target)}, which "
                                   "the mission does not have")  # fmt: skip
            left = jumps_left.setdefault(pc - 1, int(repeats))
            if left > 0:
                jumps_left[pc - 1] = left - 1
                pc = k
            continue
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
            speeds.append(speed)
            alts.append(_relative_alt(it, home_alt))
            hover.append(max(hold, 0.0))
            is_hover.append(c == CMD.LOITER_TIME or hold > 0.0)
            seqs.append(int(it.seq))
            cmds.append(int(c))
        elif c == CMD.LAND:
            stops.append(position(it) if _has_position(it) else current())
            speeds.append(speed)
            alts.append(0.0)
            hover.append(0.0)
            is_hover.append(False)
            seqs.append(int(it.seq))
            cmds.append(int(c))
            finish = "land"
        elif c == CMD.RETURN_TO_LAUNCH:
            finish = "rtl"
        elif c == CMD.DO_CHANGE_SPEED:
            if not math.isfinite(it.param2) or it.param2 <= 0.0:
                # PX4 and ArduPilot change the speed only for a positive one (-1: no change)
                note(f"item {it.seq}: DO_CHANGE_SPEED speed {it.param2:g} m/s leaves the "
                     "speed as it was (autopilots take only a positive one)")  # fmt: skip
            elif it.param2 < MIN_MISSION_SPEED:
                raise MissionError(
                    f"item {it.seq}: DO_CHANGE_SPEED speed {it.param2:g} m/s is below "
                    f"{MIN_MISSION_SPEED:g} m/s, the least a map's uav.max_speed may be (a "
                    "mission that slow does not end in any battery's time)")
            else:
                speed = float(it.param2)
                if it.param1 in _VERTICAL_SPEED_TYPES:
                    note(f"item {it.seq}: DO_CHANGE_SPEED of speed type {it.param1:g} "
                         f"({_VERTICAL_SPEED_TYPES[it.param1]}) is flown as the cruise speed, "
                         "as PX4 flies any speed type; ArduPilot Copter changes only its "
                         f"{_VERTICAL_SPEED_TYPES[it.param1]} for what follows")  # fmt: skip
        elif c < 100:  # MAV_CMD_NAV_* range: a movement the sim cannot model
            raise MissionError(f"item {it.seq}: {_command_name(c)} is not supported by the sim")
        else:  # CONDITION_* / DO_* / others: no horizontal motion
            note(f"item {it.seq}: {_command_name(c)} ignored by the sim")
    if not stops:
        raise MissionError("the mission has no navigation items to fly")
    if takeoff_alt is None:
        # ArduCopter's ModeAuto::init refuses AUTO on the ground unless the first navigation
        # command is a take-off; PX4's navigator climbs first where it stands (to the first
        # item's altitude, at least MIS_TAKEOFF_ALT) unless told to require one
        note("no TAKEOFF item: ArduCopter will not start this mission on the ground (\"Auto: "
             "Missing Takeoff Cmd\"; it flies it only if switched to AUTO in the air); PX4 "
             "climbs where it stands first; the sim assumes that climb, at the map's start, "
             "to the first item's altitude")
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
        notes=tuple(n if k == 1 else f"{n} ({k:,} times: DO_JUMP repeats)"
                    for n, k in seen.items()),
        leg_speeds=tuple(speeds),
        final_speed=speed,
    )
