"""What an autopilot stores of a mission, and a plan made storable before it is written or sent.

A vehicle does not keep a mission's numbers as a planner computes them (MAVLink's
MISSION_ITEM_INT, the common mission protocol):

- latitude and longitude are int32 in 1e-7 degree (~1.1 cm north-south), in every global frame;
- param1..param4 and the altitude z are float32 (24-bit mantissa, relative step ~6e-8);
- ArduPilot keeps NAV_LOITER_TIME's param1 (hover seconds) in a 16-bit integer: whole seconds,
  the fraction cut off (AP_Mission converts the float to an unsigned integer). PX4 keeps it as a
  float. ArduPilot also uses mission item 0 as the home position and never flies it.

A plan exactly on the paper's constraint boundary (the hover-time LP puts it there) breaks C4
once stored that way. `storable_plan` moves each hover point to a point of the 1e-7 degree grid
(choosing, among the nearest grid points, one that keeps the legs clear of obstacles, the hover
point in the area and its bandwidth within R_lambda) and raises hover times just enough, then
rounds them *up* to what the autopilot stores. The result is judged by the sim on the stored
items (`stored_items`), never on the planner's own numbers.

Dialects (`DIALECTS`): "px4" (item 0 flown, hover time float32), "ardupilot" (item 0 = home,
hover time whole seconds) and "generic" (no home item, whole-second hover times: a file that
stores unchanged on either autopilot; QGroundControl firmwareType 0).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from types import SimpleNamespace
from typing import Any, Literal

import numpy as np
from pymavlink import mavutil

from lamde_mission.geo import enu_to_latlon, latlon_to_enu
from lamde_mission.items import CMD, MissionItem, plan_to_items

__all__ = [
    "Dialect",
    "DIALECTS",
    "AUTOPILOTS",
    "dialect_of",
    "dialect_for_autopilot",
    "LATLON_SCALE",
    "grid_degrees",
    "float32",
    "float32_up",
    "hover_time_up",
    "stored_item",
    "stored_items",
    "StorablePlan",
    "storable_plan",
    "CORNER_NOISE_S",
]

_m = mavutil.mavlink

#: MISSION_ITEM_INT x/y: degrees x 1e7 as int32
LATLON_SCALE = 1e7

#: frames whose x/y are latitude/longitude
_GLOBAL_FRAMES = frozenset({0, 3, 5, 6, 10, 11})


@dataclass(frozen=True)
class Dialect:
    """How one autopilot family stores a mission.

    `home_item`: mission item 0 is the home position (not flown) and our items start at 1.
    `whole_second_hover`: LOITER_TIME param1 is stored as whole seconds (truncated).
    `waypoint_radius`: NAV_WAYPOINT's param2 (acceptance radius) is stored; ArduPilot's
    AP_Mission keeps only param1 (the delay) of a WAYPOINT on Copter builds, so it reads back
    as 0 there, and a file that stores unchanged on either autopilot writes 0.
    `autopilot`: the MAV_AUTOPILOT value of its HEARTBEAT; `firmware_type`: QGroundControl's
    `.plan` firmwareType (the same enum).
    """

    name: str
    home_item: bool
    whole_second_hover: bool
    autopilot: int
    waypoint_radius: bool = False

    @property
    def firmware_type(self) -> int:
        """QGroundControl's `.plan` firmwareType: the MAV_AUTOPILOT value (the same enum).

        Returns:
            `autopilot`.
        """
        return self.autopilot


DIALECTS: dict[str, Dialect] = {
    "px4": Dialect("px4", False, False, _m.MAV_AUTOPILOT_PX4, waypoint_radius=True),
    "ardupilot": Dialect("ardupilot", True, True, _m.MAV_AUTOPILOT_ARDUPILOTMEGA),
    "generic": Dialect("generic", False, True, _m.MAV_AUTOPILOT_GENERIC),
}
AUTOPILOTS = tuple(DIALECTS)


def dialect_of(name: str | Dialect) -> Dialect:
    """The storage dialect of an autopilot family, by name.

    Args:
        name: "px4", "ardupilot" or "generic" (case and surrounding spaces ignored), or a
            `Dialect` (returned as it is).

    Returns:
        The `Dialect`.

    Raises:
        ValueError: an unknown name; the message names the choices.
    """
    if isinstance(name, Dialect):
        return name
    key = str(name).strip().lower()
    if key not in DIALECTS:
        raise ValueError(f"unknown autopilot {name!r} (choose {', '.join(AUTOPILOTS)})")
    return DIALECTS[key]


def dialect_for_autopilot(autopilot: int | str | None) -> Dialect:
    """The dialect of a vehicle, from its HEARTBEAT's autopilot field (MAVLink's
    MAV_AUTOPILOT enum).

    Args:
        autopilot: a MAV_AUTOPILOT number, or a name such as "ARDUPILOTMEGA",
            "MAV_AUTOPILOT_PX4" or "ardupilot" (case ignored), or None.

    Returns:
        "ardupilot" or "px4"'s `Dialect` for those autopilots, "generic" for anything else
        (None included).
    """
    if autopilot is None:
        return DIALECTS["generic"]
    if isinstance(autopilot, str):
        name = autopilot.upper().removeprefix("MAV_AUTOPILOT_")
        if name in ("ARDUPILOTMEGA", "ARDUPILOT"):
            return DIALECTS["ardupilot"]
        if name == "PX4":
            return DIALECTS["px4"]
        return DIALECTS["generic"]
    if int(autopilot) == _m.MAV_AUTOPILOT_ARDUPILOTMEGA:
        return DIALECTS["ardupilot"]
    if int(autopilot) == _m.MAV_AUTOPILOT_PX4:
        return DIALECTS["px4"]
    return DIALECTS["generic"]


# ----------------------------------------------------------------------------- storage rules


def grid_degrees(v: Any) -> Any:
    """Degrees on the int32 1e-7 degree grid, as MAVLink's MISSION_ITEM_INT carries them
    (x, y in degE7).

    Args:
        v: latitudes or longitudes (degrees), a number or any shape.

    Returns:
        The nearest grid values (degrees, round half to even): a float for a number, else an
        array of v's shape.
    """
    a = np.asarray(v, dtype=float)
    out = np.round(a * LATLON_SCALE) / LATLON_SCALE
    return float(out) if np.ndim(out) == 0 else out


def float32(v: float) -> float:
    """A number as a float32 field stores it (IEEE 754 binary32, round to nearest), as
    MISSION_ITEM_INT's param1..4 and z are.

    Args:
        v: the number.

    Returns:
        The stored value as a Python float (NaN stays NaN; beyond float32's range, +-inf).
    """
    v = float(v)
    return v if math.isnan(v) else float(np.float32(v))


def float32_up(v: float) -> float:
    """The smallest float32 (IEEE 754 binary32) value >= v.

    Args:
        v: the number.

    Returns:
        That value as a Python float (inf above float32's largest finite value).
    """
    v = float(v)
    f = np.float32(v)
    if float(f) < v:
        f = np.nextafter(f, np.float32(np.inf))
    return float(f)


def _float32_down(v: float) -> float:
    f = np.float32(v)
    if float(f) > v:
        f = np.nextafter(f, np.float32(-np.inf))
    return float(f)


def hover_time_up(t: float, dialect: Dialect | str, t_max: float | None = None) -> float:
    """The smallest hover time >= t that `dialect` stores unchanged: whole seconds for
    ArduPilot-style storage (AP_Mission's uint16), else float32.

    Args:
        t: the hover time (s); negative counts as 0 (whole seconds: t within 1e-12,
            relative, above a whole second counts as that second).
        dialect: a `Dialect` or its name.
        t_max: the most it may be (s; None: no bound): a time that would round above it
            becomes the largest storable value <= t_max.

    Returns:
        The storable hover time (s).

    Raises:
        ValueError: an unknown dialect name.
    """
    d = dialect_of(dialect)
    t = max(float(t), 0.0)
    if d.whole_second_hover:
        up = float(math.ceil(t - 1e-12 * max(t, 1.0)))  # 3.0000000000001 s is 3 s of noise
        up = max(up, 0.0)
        if t_max is not None and up > t_max:
            up = float(math.floor(t_max))
        return up
    up = float32_up(t)
    if t_max is not None and up > t_max:
        up = _float32_down(t_max)
    return up


def stored_item(item: MissionItem, dialect: Dialect | str) -> MissionItem:
    """A mission item as the autopilot stores it (MAVLink's MISSION_ITEM_INT; ArduPilot's
    AP_Mission for whole-second dialects).

    Lat/lon go on the 1e-7 degree grid (global frames; NaN kept), params and altitude to
    float32; for whole-second dialects LOITER_TIME's param1 is cut to whole seconds in
    0..65535 (as ArduPilot's uint16 conversion does), and a WAYPOINT's param2 (a corner's
    acceptance radius) is 0 where the dialect does not store it (`Dialect.waypoint_radius`).

    Args:
        item: the item as written (x, y in degrees in a global frame, z in m).
        dialect: a `Dialect` or its name.

    Returns:
        A new item with the stored values.

    Raises:
        ValueError: an unknown dialect name.
    """
    d = dialect_of(dialect)
    p1, p2 = item.param1, item.param2
    if d.whole_second_hover and item.command == CMD.LOITER_TIME and math.isfinite(p1):
        p1 = float(min(max(math.floor(float32(p1)), 0), 65535))
    if not d.waypoint_radius and item.command == CMD.WAYPOINT:
        p2 = 0.0
    kw: dict[str, float] = {
        "param1": float32(p1),
        "param2": float32(p2),
        "param3": float32(item.param3),
        "param4": float32(item.param4),
        "z": float32(item.z),
    }
    if item.frame in _GLOBAL_FRAMES:
        for k in ("x", "y"):
            v = getattr(item, k)
            kw[k] = v if math.isnan(v) else grid_degrees(v)
    return replace(item, **kw)


def stored_items(items: Sequence[MissionItem], dialect: Dialect | str) -> list[MissionItem]:
    """Every item as the autopilot stores it (`stored_item`).

    Args:
        items: the mission items, in order.
        dialect: a `Dialect` or its name.

    Returns:
        The stored items, in the same order.

    Raises:
        ValueError: an unknown dialect name.
    """
    d = dialect_of(dialect)
    return [stored_item(it, d) for it in items]


# ----------------------------------------------------------------------------- storable plans


@dataclass(frozen=True, eq=False)
class StorablePlan:
    """Hover points on the 1e-7 degree grid (local metres) and hover times the autopilot stores
    unchanged; `moved_m` is how far each point moved, `added_s` the hover seconds added."""

    hover_points: np.ndarray
    hover_times: np.ndarray
    dialect: Dialect
    moved_m: np.ndarray
    added_s: np.ndarray
    #: (map, planning_map, finish) it was made for: `storable_plan` hands it back unchanged
    #: when asked again for the same (objects compared by identity)
    made_for: tuple[Any, Any, str] | None = field(default=None, repr=False)

    @property
    def n_hover(self) -> int:
        """The number of points, I (hover points and 0 s corners).

        Returns:
            I, the length of `hover_times`.
        """
        return len(self.hover_times)


def _grid_point(map_: Any, p: np.ndarray) -> np.ndarray:
    """The local position of the grid point nearest to `p`."""
    lat, lon = enu_to_latlon(p[0], p[1], map_)
    e, n = latlon_to_enu(grid_degrees(lat), grid_degrees(lon), map_)
    return np.array([float(e), float(n)])


def _candidates(map_: Any, p: np.ndarray, reach: int) -> np.ndarray:
    """Grid points around `p` (local metres), nearest first."""
    lat, lon = enu_to_latlon(p[0], p[1], map_)
    i0 = math.floor(float(lat) * LATLON_SCALE)
    j0 = math.floor(float(lon) * LATLON_SCALE)
    steps = range(-reach + 1, reach + 1)
    la = np.array([(i0 + di) / LATLON_SCALE for di in steps for _ in steps])
    lo = np.array([(j0 + dj) / LATLON_SCALE for _ in steps for dj in steps])
    e, n = latlon_to_enu(la, lo, map_)
    pts = np.column_stack([e, n])
    order = np.argsort(np.hypot(*(pts - p).T), kind="stable")
    return pts[order]


#: s: a planned hover time below this is a detour corner's (0 s, written as NAV_WAYPOINT), not a
#: hover: rounding noise of the hover-time LP (~1e-12 s); a microsecond of hover collects at
#: most R_c x 1e-6 Mbit, which the storage's own check (a sensor short is raised elsewhere)
#: makes up
CORNER_NOISE_S = 1e-6


#: a plan that collects at least this share less than a sensor's requirement as planned is
#: short by its own making, not by storage's round-off: `storable_plan` makes up only what
#: storing it took away (the planner's plans meet C4 to ~1e-9 relative)
PLANNED_SHORT = 1e-6


def _checked_plan(plan: Any) -> tuple[np.ndarray, np.ndarray]:
    """(hover points (I, 2) m, hover times (I,) s) of `plan` as floats, checked: a shape,
    non-finite number or negative time no mission file can hold raises ValueError naming
    the field and the first offending index."""
    hp = np.asarray(plan.hover_points, dtype=float)
    ht = np.asarray(plan.hover_times, dtype=float).reshape(-1)
    if hp.size == 0:
        hp = hp.reshape(0, 2)
    if hp.ndim != 2 or hp.shape[1] != 2:
        raise ValueError(f"hover_points: shape {hp.shape}, expected (I, 2) metres")
    if len(ht) != len(hp):
        raise ValueError(f"hover_times: {len(ht)} times for {len(hp)} hover points")
    for name, a in (("hover_points", hp), ("hover_times", ht)):
        bad = np.flatnonzero(~np.isfinite(a.reshape(len(a), -1)).all(axis=1)) if len(a) else []
        if len(bad):
            raise ValueError(f"{name}[{int(bad[0])}]: {a[bad[0]]} is not a finite number")
    neg = np.flatnonzero(ht < 0.0)
    if len(neg):
        raise ValueError(f"hover_times[{int(neg[0])}]: {ht[neg[0]]:g} s is negative")
    return hp, ht


def storable_plan(
    plan: Any,
    map: Any,  # noqa: A002 - the project's name for it
    dialect: Dialect | str = "generic",
    *,
    planning_map: Any = None,
    finish: Literal["land", "rtl"] = "land",
) -> StorablePlan:
    """A plan made exactly storable by an autopilot (module docstring: MISSION_ITEM_INT's
    grid and float32, ArduPilot's whole seconds), so the stored mission still meets C1-C5.

    Each hover point moves to a nearby 1e-7 degree grid point whose legs (from the previous,
    already stored, point and to the next) stay out of the obstacles of `planning_map` (the
    map the plan was made on: the obstacles inflated by the clearance; default `map`), that
    lies in the area (C1) and, in simultaneous access, keeps its rates within R_lambda (C3);
    the nearest such point of a growing neighbourhood (1, 2, 4, 8 then 16 steps of the grid,
    ~1 cm each: a detour corner whose legs graze two obstacle edges may need a few
    centimetres), else the nearest grid point. Cost: at most 32 x 32 candidates a point,
    each two legs against the obstacles, the larger neighbourhoods only where the smaller
    hold none. Hover times are then raised, where the sim finds a sensor short of
    `planning_map`'s required data (which includes the data margin), at the point with the
    best rate to it, and rounded up to the dialect's storage (`hover_time_up`, never above
    T_max), by no more than storing took away: a sensor the plan leaves short as planned
    (by more than `PLANNED_SHORT`) is raised only back to what the plan collects, so a plan
    is never repaired by being written; in simultaneous access never at a point whose summed
    rates exceed R_lambda
    (hovering there would break C3), and at a point that hovers already before a corner. A
    planned time below `CORNER_NOISE_S` counts as 0 s. A point of 0 s (a corner, written as
    NAV_WAYPOINT) is
    raised only while fewer than I_max points hover, so a plan with corner slots keeps at
    most I_max hover points. Every check uses the sim's own geometry and replay on the
    stored items.

    Args:
        plan: anything with `hover_points` (I, 2) m and `hover_times` (I,) s, in flight order.
        map: the map the mission is written for: its origin places the grid, its start and
            end are the route's ends.
        dialect: a `Dialect` or its name.
        planning_map: the map the plan was made on (obstacles inflated by the clearance,
            required data with the margin); None: `map`.
        finish: how the mission ends, "land" or "rtl" (as `plan_to_items` writes it).

    Returns:
        The `StorablePlan`: hover points (I, 2) m, hover times (I,) s, the dialect, moved_m
        (I,) m and added_s (I,) s. `plan` itself when it is a `StorablePlan` made for the
        same map and planning map (the same objects), dialect and finish: storing it again
        changes nothing, and `write_mission` is handed what `plan` made.

    Raises:
        ValueError: an unknown dialect name; hover points not (I, 2), hover times not one
            per point, a number not finite, or a negative hover time.
        lamde_mission.geo.MissingOriginError: the map has no origin.
    """
    from sim.obstacles import obstacle_shapes, overlap_lengths
    from sim.replay import hover_rates, replay

    d = dialect_of(dialect)
    pm = map if planning_map is None else planning_map
    made = getattr(plan, "made_for", None)
    if (isinstance(plan, StorablePlan) and plan.dialect == d and made is not None
            and made[0] is map and made[1] is pm and made[2] == finish):
        return plan  # already made for this map, dialect and finish: storing it again is a no-op
    hp, ht = _checked_plan(plan)
    # a corner's time comes out of the hover-time LP as 0 or as rounding noise (1e-12 s on
    # L02): noise stored as float32 (px4) was a LOITER_TIME of 1e-12 s, and in whole seconds
    # (ceil) a time just above the noise would be a 1 s hover; both are corners, 0 s
    ht = np.where(ht < CORNER_NOISE_S, 0.0, ht)
    spec = pm.spec
    W, H = spec.area.width, spec.area.height
    alt = float32(spec.uav.altitude)
    sensors = np.asarray(pm.sensors, dtype=float)
    bw = float(spec.radio.bandwidth)
    # C3 on a point's summed rates is the simultaneous access's (the paper's); in scheduled
    # access the sensors share R_lambda by time slots and the sim checks the allocation
    simultaneous = spec.radio.access != "scheduled"
    shapes = obstacle_shapes(pm)
    start = _grid_point(map, np.asarray(map.start, dtype=float))
    end = _grid_point(map, np.asarray(map.end, dtype=float))

    def ok(prev: np.ndarray, q: np.ndarray, nxt: np.ndarray) -> bool:
        if not (0.0 <= q[0] <= W and 0.0 <= q[1] <= H):
            return False
        rates = hover_rates(q[None, :], np.array([alt]), sensors, spec.radio.peak_rate,
                            spec.radio.decay)  # fmt: skip
        if simultaneous and rates.sum() > bw:
            return False
        if shapes:
            over = overlap_lengths(np.array([prev, q, nxt]), shapes)
            if float(over.sum()) > 1e-9:
                return False
        return True

    points = np.empty_like(hp)
    prev = start
    for i, p in enumerate(hp):
        nxt = hp[i + 1] if i + 1 < len(hp) else end
        chosen = None
        for reach in (1, 2, 4, 8, 16):
            for q in _candidates(map, p, reach):
                if ok(prev, q, nxt):
                    chosen = q
                    break
            if chosen is not None:
                break
        points[i] = chosen if chosen is not None else _grid_point(map, p)
        prev = points[i]

    t_max = float(spec.uav.max_hover_time)
    i_max = int(pm.max_hover_points or 0)  # 0: no limit known
    # a time above T_max (a peer's plan that breaks C2) is stored as it is, rounded up, for
    # verify to judge; rounding never takes a time within T_max past it
    times = np.array([hover_time_up(t, d, t_max if t <= t_max else None) for t in ht])
    need = np.asarray(pm.required_data, dtype=float)
    # what the plan collects as planned (before storage): storage makes up what storing took
    # away, up to the requirement, never a shortfall the plan had itself (a peer's
    # infeasible plan written for verify is judged as it is, not repaired)
    planned = replay(plan_to_items(SimpleNamespace(hover_points=hp, hover_times=ht), map,
                                   finish=finish), map).collected  # fmt: skip
    need = np.where(planned >= need * (1.0 - PLANNED_SHORT), need, np.minimum(planned, need))
    for _ in range(8):
        items = plan_to_items(SimpleNamespace(hover_points=points, hover_times=times), map,
                              finish=finish)  # fmt: skip
        tl = replay(stored_items(items, d), map)
        short = need - tl.collected
        if len(times) == 0 or not np.any(short > 0.0):
            break
        # (I, J) rates at the stored positions and altitude: the replay's at hover points, and
        # at a corner (not a hover point in the replay) what it would get if it hovered
        hov = np.asarray(tl.route.is_hover[: len(points)], dtype=bool)
        R = hover_rates(points, np.full(len(points), alt), sensors, spec.radio.peak_rate,
                        spec.radio.decay)  # fmt: skip
        R[hov] = tl.rates
        # a point may hover longer only where hovering keeps C3: a corner in a dense field
        # hears more than R_lambda in all, so raising it would make a hover point that fails
        # C3 (L08's 25-min battery map, seed 3, sortie 7: 49.7 of 25 Mbit/s)
        keeps_c3 = R.sum(axis=1) <= bw if simultaneous else np.ones(len(R), dtype=bool)
        raw = times.copy()
        for j in np.argsort(-short):
            if short[j] <= 0.0:
                continue
            room = (raw < t_max) & keeps_c3
            if i_max and np.count_nonzero(raw > 0.0) >= i_max:
                room &= raw > 0.0  # a corner (0 s) stays one once I_max points hover
            if not np.any(room & (R[:, j] > 0)):
                continue
            if np.any(room & (R[:, j] > 0) & (raw > 0.0)):
                room &= raw > 0.0  # a point that hovers already, before a corner is made one
            i = int(np.argmax(np.where(room, R[:, j], -1.0)))
            extra = short[j] / R[i, j] * (1.0 + 1e-9) + 1e-9
            raw[i] = min(raw[i] + extra, t_max)
        times = np.array([hover_time_up(t, d, t_max if t <= t_max else None) for t in raw])
    return StorablePlan(
        hover_points=points,
        hover_times=times,
        dialect=d,
        moved_m=np.hypot(*(points - hp).T) if len(hp) else np.zeros(0),
        added_s=times - ht,
        made_for=(map, pm, finish),
    )
