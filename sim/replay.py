"""Replay a MAVLink mission on a map: a timeline of the flight and the paper's totals.

The replay reads mission items (what a vehicle would receive), not the optimiser's arrays, and
flies them with the paper's model (Sec. 3): every navigation item is a full stop; each leg
between stops is flown with the trapezoid (or triangle) speed profile of Eq. 1; data flows
only while hovering, sensor j receiving R_ij * T_i at hover point i. With `radio.access`
"scheduled" the sensors in range share R_lambda by time slots instead: sensor j receives the
share D_ij of the sim's own allocation LP (`scheduled_allocation`), D_ij <= R_ij * T_i and
sum_j D_ij <= R_lambda * T_i.

What counts in f: exactly the paper's terms. t_fly sums the legs from the take-off position
through every stop to the landing position; t_hover sums the hover times. The vertical
take-off and landing (and an RTL flight back to launch) are simulated and reported
(t_takeoff, t_land, t_return, t_total) but excluded from f, as the paper's model has no
vertical motion. They are flown rest to rest (Eq. 1 with the map's acceleration) at most at the
map's `uav.climb_speed` up and `uav.descent_speed` down, the vehicle's vertical speeds in
missions (defaults: ArduPilot's climb, 2.5 m/s, and PX4's descent, 1 m/s, the slower of the
two autopilots' defaults each); the energy of a sortie counts them (`sim.energy`).

A leg between stops at different altitudes (a mission edited by hand: the planner writes every
stop at the map's altitude) is flown as a straight line that takes as long as the slower of
its horizontal profile and its vertical one, the climb or descent rest-to-rest (Eq. 1) at
the same vertical speeds; that time is in t_fly, so a climb is never free. With equal altitudes
(every planned mission) the legs are the paper's, to the bit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sim.mission import CMD, SNAP_M, MissionError, MissionItem, Route, items_to_route

__all__ = [
    "PHASES",
    "Timeline",
    "Totals",
    "replay",
    "replay_route",
    "leg_time",
    "leg_position",
    "hover_rates",
    "scheduled_allocation",
    "vertical_time",
    "far_from_area",
    "far_distance",
]

#: the names a `Timeline` sample's phase takes, in flight order; `_Recorder.add` refuses any
#: other, so a misspelt phase fails at once instead of going unnoticed by readers of `phase`
PHASES = ("takeoff", "fly", "hover", "return", "land")

#: m: an altitude change below this on a leg is the float32 round-off of one altitude written
#: twice, not a climb
Z_SNAP = 0.01


def vertical_time(dz: float, accel: float, up: float, down: float) -> float:
    """The time to climb or descend |dz| rest to rest: Eq. 1 (paper Sec. 3.1) with the map's
    acceleration, at most `up` m/s up and `down` m/s down.

    Args:
        dz: the altitude change (m): > 0 a climb, < 0 a descent; |dz| < `Z_SNAP` takes 0 s.
        accel: the UAV's acceleration (m/s^2), > 0.
        up: the climb speed (m/s, the map's `uav.climb_speed`), > 0.
        down: the descent speed (m/s, the map's `uav.descent_speed`), > 0.

    Returns:
        The time (s).
    """
    if abs(dz) < Z_SNAP:
        return 0.0
    return leg_time(abs(dz), up if dz > 0 else down, accel)


def leg_time(d: float, v_max: float, accel: float) -> float:
    """The sim's own Eq. 1 (paper Sec. 3.1): the rest-to-rest time over distance d, a
    trapezoid speed profile above d = v_max^2 / a, a triangle below.

    Args:
        d: the distance (m); d <= 0 takes 0 s.
        v_max: the cruise speed (m/s), > 0.
        accel: the acceleration a (m/s^2), > 0.

    Returns:
        The time (s).
    """
    if d <= 0.0:
        return 0.0
    if d > v_max * v_max / accel:
        return d / v_max + v_max / accel
    return 2.0 * math.sqrt(d / accel)


def leg_position(t: np.ndarray, d: float, v_max: float, accel: float) -> np.ndarray:
    """The distance covered at times t on a rest-to-rest leg of length d (Eq. 1's profile:
    accelerate at a, cruise at v_max on a trapezoid, decelerate at a).

    Args:
        t: times since the leg's start (s), any shape; clipped to 0 .. `leg_time(d, ...)`.
        d: the leg's length (m).
        v_max: the cruise speed (m/s), > 0.
        accel: the acceleration a (m/s^2), > 0.

    Returns:
        The distance covered (m, 0 .. d), t's shape; zeros for a leg of no time (d <= 0).
    """
    t = np.asarray(t, dtype=float)
    total = leg_time(d, v_max, accel)
    if total <= 0.0:
        return np.zeros_like(t)
    t = np.clip(t, 0.0, total)
    if d > v_max * v_max / accel:
        ta = v_max / accel
        s = np.where(
            t < ta,
            0.5 * accel * t * t,
            np.where(
                t <= total - ta,
                0.5 * v_max * ta + v_max * (t - ta),
                d - 0.5 * accel * (total - t) ** 2,
            ),
        )
    else:
        th = 0.5 * total
        s = np.where(t < th, 0.5 * accel * t * t, d - 0.5 * accel * (total - t) ** 2)
    return np.clip(s, 0.0, d)


def hover_rates(
    points: np.ndarray, altitudes: np.ndarray, sensors: np.ndarray, peak: float, decay: float
) -> np.ndarray:
    """The sim's own link rates R_ij = max(R_c - xi * sqrt(|p_i - s_j|^2 + h_i^2), 0) (paper
    Sec. 3.1, with each point's own altitude h_i for H).

    Args:
        points: hover points p_i (m, local), I pairs, e.g. (I, 2).
        altitudes: each point's altitude h_i above home (m), (I,).
        sensors: sensor positions s_j (m, local), (J, 2).
        peak: R_c (Mbit/s).
        decay: xi (Mbit/s per m).

    Returns:
        R (Mbit/s, >= 0), shape (I, J).
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    diff = points[:, None, :] - np.asarray(sensors, dtype=float)[None, :, :]
    dist = np.sqrt((diff**2).sum(axis=2) + np.asarray(altitudes, dtype=float)[:, None] ** 2)
    return np.maximum(peak - decay * dist, 0.0)


def scheduled_allocation(
    rates: np.ndarray, times: np.ndarray, required: np.ndarray, bandwidth: float
) -> np.ndarray:
    """Scheduled access (`radio.access` "scheduled"): the data D_ij (Mbit) each hover point
    takes from each sensor when the sensors in range share R_lambda by time slots.

    The sim's own LP (scipy's HiGHS), not the planner's: maximise s, the share of its
    requirement the worst sensor gets, subject to D_ij <= R_ij T_i (the link), sum_j D_ij <=
    R_lambda T_i (the point's bandwidth) and sum_i D_ij >= s Q_j (every j with Q_j > 0),
    D_ij >= 0. C4 holds exactly when some allocation meets every Q_j, i.e. s >= 1; the
    data margin is s - 1 for every sensor.

    Args:
        rates: the link rates R_ij (Mbit/s), (I, J) (or I x J numbers).
        times: the hover times T_i (s), (I,); negative counts as 0.
        required: each sensor's required data Q_j (Mbit), (J,).
        bandwidth: R_lambda (Mbit/s).

    Returns:
        D (Mbit), shape (I, J): zero where R_ij = 0, T_i = 0 or Q_j = 0.
    """
    from scipy.optimize import linprog
    from scipy.sparse import coo_matrix

    rates = np.asarray(rates, dtype=float).reshape(len(times), -1)
    times = np.maximum(np.asarray(times, dtype=float), 0.0)
    req = np.asarray(required, dtype=float)
    D = np.zeros_like(rates)
    ii, jj = np.nonzero((rates > 0) & (req[None, :] > 0) & (times[:, None] > 0))
    need = np.flatnonzero(req > 0)
    if len(ii) == 0 or len(need) == 0:
        return D
    n = len(ii)
    # variables: D_k (k over the links, in Mbit / Q_j), then s
    scale = req[jj]
    row_of = np.full(len(req), -1)
    row_of[need] = np.arange(len(need))
    # point rows: sum_j Q_j d_ij <= R_lambda T_i; sensor rows: s - sum_i d_ij <= 0
    r = np.concatenate([ii, len(times) + row_of[jj], len(times) + np.arange(len(need))])
    c = np.concatenate([np.arange(n), np.arange(n), np.full(len(need), n)])
    v = np.concatenate([scale, -np.ones(n), np.ones(len(need))])
    A = coo_matrix((v, (r, c)), shape=(len(times) + len(need), n + 1)).tocsr()
    b = np.concatenate([bandwidth * times, np.zeros(len(need))])
    bounds = [(0.0, float(rates[i, j] * times[i] / req[j])) for i, j in zip(ii, jj, strict=True)]
    res = linprog(np.concatenate([np.zeros(n), [-1.0]]), A_ub=A, b_ub=b,
                  bounds=[*bounds, (0.0, None)], method="highs")  # fmt: skip
    if res.x is None:  # cannot happen (D = 0, s = 0 is feasible); report no data
        return D
    D[ii, jj] = np.maximum(res.x[:n], 0.0) * scale
    return D


def far_distance(route: Route, map: Any) -> float | None:  # noqa: A002
    """How far the mission lies from the map's area [0, W] x [0, H] when every stop lies
    farther from it than the area's size, max(W, H) (a mission for another map, or a map with
    another origin). O(stops).

    Args:
        route: the mission as flown (its stops, local metres).
        map: the map (its `spec.area`).

    Returns:
        The distance of the nearest stop from the area, m; None when a stop lies within
        max(W, H) of it (or the route has no stops, or the map no area).
    """
    area = getattr(map.spec, "area", None)
    if area is None or not len(route.stops):
        return None
    w, h = float(area.width), float(area.height)
    xy = np.asarray(route.stops, dtype=float).reshape(-1, 2)
    dx = np.maximum.reduce([np.zeros(len(xy)), -xy[:, 0], xy[:, 0] - w])
    dy = np.maximum.reduce([np.zeros(len(xy)), -xy[:, 1], xy[:, 1] - h])
    d = float(np.min(np.hypot(dx, dy)))
    return d if d > max(w, h) else None


def far_from_area(route: Route, map: Any) -> str | None:  # noqa: A002
    """A note when every stop of the mission lies farther from the map's area [0, W] x [0, H]
    than the area's size, max(W, H) (`far_distance`): a mission for another map, or a map with
    another origin, whose verdicts measure kilometres of nothing. O(stops).

    Args:
        route: the mission as flown (its stops, local metres).
        map: the map (its `spec.area`; its origin named in the note when it has one).

    Returns:
        "the mission lies N km from this map's area (...): the wrong map, or another
        origin?", or None when a stop lies within that distance (or the map has no area).
    """
    d = far_distance(route, map)
    if d is None:
        return None
    origin = getattr(map.spec, "origin", None)
    where = (f" (origin lat {float(origin.lat):.6g}, lon {float(origin.lon):.6g})"
             if origin is not None else "")  # fmt: skip
    return (f"the mission lies {d / 1000:,.1f} km from this map's area{where}: the wrong map, "
            "or another origin? (the figures below are measured that far away, on a projection "
            "made for this map: they mean nothing)")


@dataclass(frozen=True)
class Totals:
    """The paper's terms for the flown mission, plus the vertical and return parts outside f."""

    t_fly: float
    t_hover: float
    f: float
    alpha: float
    collected: dict[str, float]
    t_takeoff: float
    t_land: float
    t_return: float
    t_total: float
    distance: float
    speed: float
    accel: float


@dataclass(frozen=True, eq=False)
class Timeline:
    """Samples of the flight and its totals.

    Samples: `t` (N,) s, `xy` (N, 2) local m, `z` (N,) m above home, `phase` (N,) one of
    `PHASES` (takeoff/fly/hover/return/land), `data` (N, J) Mbit collected so far per sensor.
    Each phase segment contributes its first and last instant (so boundary times appear twice,
    once per phase) and points every `dt` seconds in between.
    """

    t: np.ndarray
    xy: np.ndarray
    z: np.ndarray
    phase: tuple[str, ...]
    data: np.ndarray
    sensor_ids: tuple[str, ...]
    route: Route
    path: np.ndarray
    leg_lengths: np.ndarray
    leg_times: np.ndarray
    hover_points: np.ndarray
    hover_times: np.ndarray
    hover_altitudes: np.ndarray
    hover_seqs: tuple[int, ...]
    rates: np.ndarray
    return_leg: np.ndarray | None
    totals: Totals
    notes: tuple[str, ...] = field(default=())
    #: scheduled access only: the data D_ij (Mbit) each hover point takes from each sensor
    #: (`scheduled_allocation`); None in simultaneous access (every sensor at R_ij)
    allocation: np.ndarray | None = None
    #: (N,) m/s: the cruise speed each leg is flown at (the mission's DO_CHANGE_SPEED, at most
    #: v_max), for the energy of the flight (`sim.energy`)
    leg_speeds: np.ndarray | None = None

    @property
    def collected(self) -> np.ndarray:
        """Data collected per sensor at the end of the mission.

        Returns:
            (J,) Mbit, a copy of the last row of `data`.
        """
        return self.data[-1].copy()


#: most numbers the per-sensor data samples (N x J) may hold: 160 MB of float64
_MAX_CELLS = 20_000_000


class _Recorder:
    """The samples of one replay; at most `cap` of them (a guard: `replay_route` sizes `dt` so
    that the phases fit, and a sample count beyond it is a bug, not a long mission)."""

    def __init__(self, n_sensors: int, dt: float, cap: int | None = None):
        self.dt = dt
        self.cap = cap
        self.count = 0
        self.t: list[np.ndarray] = []
        self.xy: list[np.ndarray] = []
        self.z: list[np.ndarray] = []
        self.phase: list[str] = []
        self.data: list[np.ndarray] = []
        self.n_sensors = n_sensors

    def times(self, t0: float, duration: float) -> np.ndarray:
        n = max(int(math.ceil(duration / self.dt)), 1) if duration > 0 else 1
        self.count += n + 1
        if self.cap is not None and self.count > self.cap:
            raise RuntimeError(f"replay: {self.count} samples exceed the bound {self.cap}")
        return np.linspace(t0, t0 + duration, n + 1)

    def add(self, phase: str, t: np.ndarray, xy: np.ndarray, z: np.ndarray, data: np.ndarray):
        """Append one phase segment's samples: times t (n,) s, xy (n, 2) m, z (n,) m and data
        (n, J) Mbit, each labelled `phase`.

        Raises:
            ValueError: `phase` is not one of `PHASES` (a bug in the replay).
        """
        if phase not in PHASES:
            raise ValueError(f"replay: phase {phase!r} is not one of {PHASES}")
        self.t.append(t)
        self.xy.append(xy)
        self.z.append(z)
        self.phase.extend([phase] * len(t))
        self.data.append(data)


def replay(
    items: Sequence[MissionItem],
    map: Any,  # noqa: A002
    *,
    dt: float = 1.0,
    speed_limit: float | None = None,
) -> Timeline:
    """Fly a stored mission over a map with the paper's model (module docstring): the
    timeline of the flight and the paper's totals.

    Args:
        items: the mission's items (type MISSION) in seq order, as a vehicle receives them
            (`sim.mission.MissionItem`; fence and rally items are ignored, noted).
        map: the map (a `planner_core.model.mapio.Map` or anything with its fields): its
            origin places the items, its start is the default launch, and `spec` (uav, radio,
            objective, safety), `sensors`, `sensor_ids` and `required_data` fly it.
        dt: the sampling step (s), > 0; a mission too long for the sample bound is sampled
            more coarsely (the totals stay exact).
        speed_limit: the vehicle's own horizontal speed limit (m/s, > 0; PX4's
            MPC_XY_VEL_MAX caps a DO_CHANGE_SPEED's cruise speed): every leg is flown at
            most at it, with a note; None: the mission's speeds (at most v_max).

    Returns:
        The `Timeline`: samples `t` (N,) s, `xy` (N, 2) m, `z` (N,) m, `phase` (N,), `data`
        (N, J) Mbit, and the `Totals` (t_fly, t_hover, f in s; collected Mbit per sensor).

    Raises:
        MissionError: a mission the sim cannot fly, naming the item, or one whose duration
            is not finite.
        sim.geo.MissingOriginError: the map has no origin (lat, lon) to place the items.
        ValueError: dt is not positive.
    """
    return replay_route(items_to_route(items, map), map, dt=dt, speed_limit=speed_limit)


def replay_route(route: Route, map: Any, *, dt: float = 1.0,  # noqa: A002
                 speed_limit: float | None = None) -> Timeline:
    """`replay` for a Route already read from items (`sim.mission.items_to_route`).

    Args:
        route: the mission as flown: launch, stops (m, local), altitudes, hover times (s),
            speeds, finish.
        map: the map, as for `replay` (its `spec`, `sensors`, `sensor_ids`, `required_data`).
        dt: the sampling step (s), > 0; coarsened for a mission too long for the sample bound.
        speed_limit: as for `replay`.

    Returns:
        The `Timeline`, as for `replay`.

    Raises:
        MissionError: the mission's duration is not finite.
        ValueError: dt is not positive.
    """
    if not dt > 0:
        raise ValueError("dt must be positive")
    spec = map.spec
    uav, radio = spec.uav, spec.radio
    notes = list(route.notes)
    v_max = float(uav.max_speed)
    warned: set[Any] = set()

    if speed_limit is not None and not (math.isfinite(speed_limit) and speed_limit > 0):
        raise ValueError(f"speed_limit must be a positive speed (m/s), got {speed_limit!r}")

    def flown(speed: float | None) -> float:
        """A DO_CHANGE_SPEED speed as flown: at most the UAV's v_max and the vehicle's own
        limit."""
        if speed is None:
            speed = v_max
        elif speed > v_max and speed not in warned:
            warned.add(speed)
            notes.append(f"mission speed {speed:g} m/s exceeds the UAV's v_max {v_max:g} m/s; "
                         "flown at v_max")  # fmt: skip
        speed = min(float(speed), v_max)
        if speed_limit is not None and speed > speed_limit:
            if ("limit", speed) not in warned:
                warned.add(("limit", speed))
                notes.append(f"mission speed {speed:g} m/s exceeds the vehicle's speed limit "
                             f"{speed_limit:g} m/s; flown at the limit")  # fmt: skip
            speed = float(speed_limit)
        return speed

    n_stops = len(route.stops)
    if route.leg_speeds:
        leg_v = np.array([flown(sp) for sp in route.leg_speeds], dtype=float)
        v_end = flown(route.final_speed)
    else:  # a Route made by hand: one speed for every leg
        leg_v = np.full(n_stops, flown(route.speed))
        v_end = flown(route.speed)
    v = float(leg_v[0]) if n_stops else v_end
    a = float(uav.acceleration)
    up, down = float(uav.climb_speed), float(uav.descent_speed)
    alpha = float(spec.objective.alpha)
    sensors = np.asarray(map.sensors, dtype=float)
    ids = tuple(map.sensor_ids)
    J = len(ids)

    stops = route.stops
    path = np.vstack([route.launch[None, :], stops])
    seg = np.diff(path, axis=0)
    lengths = np.sqrt((seg**2).sum(axis=1))
    lengths = np.where(lengths < SNAP_M, 0.0, lengths)
    h_to = route.takeoff_altitude
    if h_to is None:
        h_to = float(route.altitudes[0]) if len(route.altitudes) else float(uav.altitude)
    # each stop's altitude as flown (a LAND item lands where it is: its leg keeps the altitude)
    flown_alt = np.empty(n_stops)
    z_prev = float(h_to)
    for k in range(n_stops):
        if route.commands[k] != CMD.LAND:
            z_prev = float(route.altitudes[k])
        flown_alt[k] = z_prev
    climbs = np.diff(np.concatenate([[float(h_to)], flown_alt])) if n_stops else np.zeros(0)
    times = np.array([max(leg_time(d, float(vk), a), vertical_time(float(dz), a, up, down))
                      for d, vk, dz in zip(lengths, leg_v, climbs, strict=True)])  # fmt: skip
    if np.any(np.abs(climbs) >= Z_SNAP):
        k = int(np.argmax(np.abs(climbs)))
        notes.append(f"the mission changes altitude between stops (by up to {climbs[k]:+.1f} m, "
                     f"on the leg to item {route.seqs[k]}): such legs are timed with climbs at "
                     f"{up:g} m/s and descents at {down:g} m/s at most")  # fmt: skip
    hov_mask = route.is_hover
    rates_all = hover_rates(stops, route.altitudes, sensors, radio.peak_rate, radio.decay)
    rates = rates_all[hov_mask]
    # scheduled access: each sensor sends its share D_ij over the hover, at D_ij / T_i
    allocation = None
    flow_rates = rates_all
    if getattr(radio, "access", "simultaneous") == "scheduled":
        req = np.asarray(map.required_data, dtype=float)
        margin = float(getattr(getattr(spec, "safety", None), "data_margin", 0.0))
        allocation = scheduled_allocation(rates, route.hover_times[hov_mask],
                                          req * (1.0 + margin), float(radio.bandwidth))
        th_h = route.hover_times[hov_mask]
        flow_rates = np.zeros_like(rates_all)
        flow_rates[hov_mask] = np.divide(allocation, th_h[:, None],
                                         out=np.zeros_like(allocation),
                                         where=th_h[:, None] > 0)  # fmt: skip

    # bounded cost: a long mission (hours of hovering, a file's 1e38 s, a 10 km take-off) is
    # sampled more coarsely so that `data` (N x J) holds at most _MAX_CELLS numbers plus two
    # per phase segment (a number set by the mission's size, not its values); totals stay
    # exact. `span` bounds every phase from above: the take-off (the TAKEOFF altitude is part
    # of alt_max), each leg and hover, the return (at most the whole path) and the landing.
    alt_max = float(np.max(np.abs(route.altitudes), initial=abs(float(uav.altitude))))
    if route.takeoff_altitude is not None:
        alt_max = max(alt_max, abs(float(route.takeoff_altitude)))
    v_slow = min(v, v_end, float(np.min(leg_v, initial=v)))
    span = (float(times.sum()) + float(np.nansum(route.hover_times[hov_mask]))
            + 2.0 * leg_time(alt_max, min(v_slow, up, down), a)
            + leg_time(float(np.abs(seg).sum()), v_slow, a))  # fmt: skip
    n_max = max(_MAX_CELLS // (J + 4), 1000)
    if not math.isfinite(span):
        raise MissionError(f"the mission's duration is not finite ({span} s)")
    if span / dt > n_max:
        dt = span / n_max
    rec = _Recorder(J, dt, cap=n_max + 2 * (2 * n_stops + 4))
    clock = 0.0
    pos = route.launch.astype(float).copy()
    alt_now = 0.0
    q = np.zeros(J)

    def const(n: int) -> tuple[np.ndarray, np.ndarray]:
        return np.tile(pos, (n, 1)), np.tile(q, (n, 1))

    # take-off (vertical, outside f): a climb at the climb speed (a descent below home, which
    # ALT fails, at the descent speed)
    v_to = up if h_to >= 0 else down
    t_takeoff = leg_time(abs(h_to), v_to, a)
    ts = rec.times(clock, t_takeoff)
    xy, dq = const(len(ts))
    rec.add("takeoff", ts, xy, leg_position(ts - clock, abs(h_to), v_to, a) * np.sign(h_to), dq)
    clock += t_takeoff
    alt_now = h_to

    for k in range(len(stops)):
        d, tl = float(lengths[k]), float(times[k])
        target_alt = float(flown_alt[k])
        if tl > 0.0:
            ts = rec.times(clock, tl)
            dz = target_alt - alt_now
            if vertical_time(dz, a, up, down) > leg_time(d, float(leg_v[k]), a):  # the climb
                frac = leg_position(ts - clock, abs(dz), up if dz > 0 else down, a) / abs(dz)
            else:
                frac = leg_position(ts - clock, d, float(leg_v[k]), a) / d
            xy = pos[None, :] + frac[:, None] * (stops[k] - pos)[None, :]
            z = alt_now + frac * (target_alt - alt_now)
            rec.add("fly", ts, xy, z, np.tile(q, (len(ts), 1)))
            clock += tl
        pos = stops[k].astype(float).copy()
        alt_now = target_alt
        if hov_mask[k]:
            th = float(route.hover_times[k])
            r = flow_rates[k]
            ts = rec.times(clock, th)
            data = q[None, :] + (ts - clock)[:, None] * r[None, :]
            xy, _ = const(len(ts))
            rec.add("hover", ts, xy, np.full(len(ts), alt_now), data)
            q = q + r * th
            clock += th

    t_fly = float(times.sum())
    t_hover = float(route.hover_times[hov_mask].sum())

    return_leg = None
    t_return = 0.0
    if route.finish == "rtl":
        return_leg = np.vstack([pos, route.launch])
        d = float(np.linalg.norm(route.launch - pos))
        d = 0.0 if d < SNAP_M else d
        t_return = leg_time(d, v_end, a)
        if t_return > 0.0:
            ts = rec.times(clock, t_return)
            s = leg_position(ts - clock, d, v_end, a)
            xy = pos[None, :] + (s / d)[:, None] * (route.launch - pos)[None, :]
            rec.add("return", ts, xy, np.full(len(ts), alt_now), np.tile(q, (len(ts), 1)))
            clock += t_return
            pos = route.launch.astype(float).copy()

    t_land = 0.0
    if route.finish in ("land", "rtl"):
        v_land = down if alt_now >= 0 else up
        t_land = leg_time(abs(alt_now), v_land, a)
        ts = rec.times(clock, t_land)
        xy, dq = const(len(ts))
        z = alt_now - leg_position(ts - clock, abs(alt_now), v_land, a) * np.sign(alt_now)
        rec.add("land", ts, xy, z, dq)
        clock += t_land
    else:
        notes.append("the mission does not land (no LAND or RETURN_TO_LAUNCH item)")

    far = far_from_area(route, map)
    if far is not None:  # first: every verdict below is measured from the wrong place
        notes.insert(0, far)

    totals = Totals(
        t_fly=t_fly,
        t_hover=t_hover,
        f=alpha * t_fly + (1.0 - alpha) * t_hover,
        alpha=alpha,
        collected=dict(zip(ids, q.tolist(), strict=True)),
        t_takeoff=t_takeoff,
        t_land=t_land,
        t_return=t_return,
        t_total=clock,
        distance=float(lengths.sum()),
        speed=v_end,
        accel=a,
    )
    return Timeline(
        t=np.concatenate(rec.t),
        xy=np.vstack(rec.xy),
        z=np.concatenate(rec.z),
        phase=tuple(rec.phase),
        data=np.vstack(rec.data),
        sensor_ids=ids,
        route=route,
        path=path,
        leg_lengths=lengths,
        leg_times=times,
        hover_points=stops[hov_mask],
        hover_times=route.hover_times[hov_mask],
        hover_altitudes=route.altitudes[hov_mask],
        hover_seqs=tuple(s for s, h in zip(route.seqs, hov_mask, strict=True) if h),
        rates=rates,
        return_leg=return_leg,
        totals=totals,
        notes=tuple(notes),
        allocation=allocation,
        leg_speeds=leg_v,
    )
