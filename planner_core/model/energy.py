"""Propulsion power and energy of a rotary-wing UAV, once for the planner (issue 33).

Power: the rotary-wing model of Zeng, Xu and Zhang, "Energy minimization for wireless
communication with rotary-wing UAV", IEEE Trans. Wireless Commun. 18(4), 2019, Eq. (12):

    P(V) = P0 (1 + 3 V^2 / U_tip^2)                                 (blade profile)
         + Pi (sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2))^(1/2)     (induced)
         + 1/2 d0 rho s A V^3                                        (parasite)

with that paper's Table I as defaults (`planner_core.defaults`, `uav.power.*`); hover power
P(0) = P0 + Pi (168.49 W with the defaults).

Energy of a leg: the leg is flown rest to rest with the SAME trapezoid speed profile as the
model's leg time (paper Eq. 1, `planner_core.model.formulas.flight_time`): accelerate at `a` to
v_max (or to the triangle's peak sqrt(a d) on a leg shorter than v_max^2 / a), cruise, decelerate
at `a`. With v = a t on a ramp, E_ramp = (1/a) int_0^V P(u) du, integrated by Gauss-Legendre on
panels no wider than v0 (the induced term's knee; tests/test_energy.py holds it to a fine
quadrature and to the closed form within 1e-9); the cruise costs P(v_max) x its time.

Energy of a sortie (depot -> hover points -> depot): the horizontal legs as above, plus the
vertical take-off and landing (their Eq. 1 time over the altitude H at the climb and descent
speeds `uav.climb_speed` and `uav.descent_speed`, at hover power P(0): the level-flight model
has no climb term; documented in docs/energy.md), plus P(0) x every hover
time. It is LINEAR in the hover times: E = E_flight(route) + P(0) / 3600 x sum_k t_k (Wh), which
keeps the sortie planner's hover-time LP an LP.

A leaf module: numpy and the defaults table only. The sim (`sim.energy`) keeps its own second
implementation (a closed-form ramp integral over its replayed profile). Cost: O(legs x panels)
per call, panels = ceil(v_max / v0) <= 64 (5 with the defaults), independent of the sensors.

Units: m, s, m/s, m/s^2, W, Wh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner_core.defaults import MAP_DEFAULTS
from planner_core.model.formulas import flight_time

__all__ = [
    "J_PER_WH",
    "PowerParams",
    "DEFAULT_POWER",
    "power_w",
    "hover_power_w",
    "ramp_energy_j",
    "leg_energy_wh",
    "hover_energy_wh",
    "vertical_time_s",
    "vertical_energy_wh",
    "route_flight_energy_wh",
    "sortie_energy_wh",
    "battery_energy_wh",
    "hover_endurance_s",
    "usable_energy_wh",
    "battery_for_usable_wh",
    "least_energy_per_metre_wh",
]

#: joules in one watt-hour
J_PER_WH = 3600.0

#: Gauss-Legendre nodes and weights on [-1, 1] per panel (exact for polynomials of degree 15)
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(8)
#: most panels one ramp integral uses (panels are at most v0 wide, so up to v_max = 64 v0)
_MAX_PANELS = 64


@dataclass(frozen=True)
class PowerParams:
    """Zeng et al. (2019) Table I parameters of the propulsion power model.

    `p0` P0, blade profile power in hover (W); `pi` Pi, induced power in hover (W); `u_tip`
    U_tip, blade tip speed (m/s); `v0` mean rotor induced velocity in hover (m/s); `d0`
    fuselage drag ratio; `rho` air density (kg/m^3); `s` rotor solidity; `area` A, rotor disc
    area (m^2). Map fields `uav.power.*` (`planner_core.defaults`).
    """

    p0: float
    pi: float
    u_tip: float
    v0: float
    d0: float
    rho: float
    s: float
    area: float

    @classmethod
    def from_spec(cls, spec: Any) -> PowerParams:
        """From the map file's `uav.power` (an object with the schema's field names:
        `blade_profile_w`, `induced_w`, `tip_speed`, `induced_velocity`, `fuselage_drag_ratio`,
        `air_density`, `rotor_solidity`, `rotor_disc_area`); None gives `DEFAULT_POWER`.

        Args:
            spec: the `uav.power` settings, or None.

        Returns:
            The parameters (each field read as a float), or `DEFAULT_POWER`.
        """
        if spec is None:
            return DEFAULT_POWER
        return cls(
            p0=float(spec.blade_profile_w), pi=float(spec.induced_w),
            u_tip=float(spec.tip_speed), v0=float(spec.induced_velocity),
            d0=float(spec.fuselage_drag_ratio), rho=float(spec.air_density),
            s=float(spec.rotor_solidity), area=float(spec.rotor_disc_area),
        )  # fmt: skip

    @property
    def hover_w(self) -> float:
        """P(0) = P0 + Pi, W.

        Returns:
            The hover power P(0), W (`hover_power_w`).
        """
        return hover_power_w(self)


def _default(name: str) -> float:
    return float(MAP_DEFAULTS[f"uav.power.{name}"].value)


#: the defaults table's parameters (Zeng et al. 2019, Table I): P(0) = 168.49 W
DEFAULT_POWER = PowerParams(
    p0=_default("blade_profile_w"), pi=_default("induced_w"), u_tip=_default("tip_speed"),
    v0=_default("induced_velocity"), d0=_default("fuselage_drag_ratio"),
    rho=_default("air_density"), s=_default("rotor_solidity"), area=_default("rotor_disc_area"),
)  # fmt: skip


def _power(power: PowerParams | None) -> PowerParams:
    return DEFAULT_POWER if power is None else power


def power_w(v: Any, power: PowerParams | None = None) -> np.ndarray:
    """Propulsion power P(V) of level flight at speed V (Zeng et al. 2019, Eq. 12).

    The induced term's (sqrt(1 + x^2) - x) with x = V^2 / (2 v0^2) is evaluated as its equal
    1 / (sqrt(1 + x^2) + x), which keeps its digits at high speed.

    Args:
        v: speeds V (m/s), any shape; negative speeds count by their size.
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        P(V) in W, v's shape (a 0-d array for a scalar).
    """
    profile, induced, parasite = _power_terms(v, _power(power))
    return profile + induced + parasite


def _power_terms(v: Any, p: PowerParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The three terms of P(V) (W): blade profile (rising in V), induced (falling), parasite
    (rising); `power_w` is their sum."""
    v = np.abs(np.asarray(v, dtype=float))
    v2 = v * v
    x = v2 / (2.0 * p.v0 * p.v0)
    induced = p.pi * np.sqrt(1.0 / (np.sqrt(1.0 + x * x) + x))
    return (p.p0 * (1.0 + 3.0 * v2 / (p.u_tip * p.u_tip)), induced,
            0.5 * p.d0 * p.rho * p.s * p.area * v2 * v)  # fmt: skip


def hover_power_w(power: PowerParams | None = None) -> float:
    """P(0) = P0 + Pi (W), the hover power (Zeng et al. 2019, Eq. 12 at V = 0).

    Args:
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        P(0), W.
    """
    return float(power_w(0.0, power))


def ramp_energy_j(v_peak: Any, accel: float, power: PowerParams | None = None, *,
                  v_top: float | None = None) -> np.ndarray:  # fmt: skip
    """Energy (J) of one constant-acceleration ramp from rest to v_peak (or back to rest):
    (1/a) int_0^V P(u) du, composite Gauss-Legendre: k panels of V / k each, 8 nodes a panel,
    k = ceil(v_top / v0) (at most 64), so a panel is at most v0 wide.

    Args:
        v_peak: ramp end speeds V (m/s), any shape, >= 0.
        accel: a (m/s^2), > 0.
        power: the model's parameters (default `DEFAULT_POWER`).
        v_top: the speed that sets the panel count (default: the largest V); `leg_energy_wh`
            passes v_max, so every leg is integrated alike whatever else is in the batch.

    Returns:
        Energy in J, v_peak's shape.
    """
    p = _power(power)
    vp = np.maximum(np.asarray(v_peak, dtype=float), 0.0)
    top = float(vp.max(initial=0.0)) if v_top is None else float(v_top)
    k = int(min(max(math.ceil(top / p.v0), 1), _MAX_PANELS))
    # panel j of each V covers [j V / k, (j + 1) V / k]; nodes (k * 8,) as fractions of V
    frac = ((np.arange(k)[:, None] + 0.5 * (_GL_NODES[None, :] + 1.0)) / k).reshape(-1)
    weights = np.tile(_GL_WEIGHTS, k) * (0.5 / k)
    u = vp[..., None] * frac
    # an elementwise product and a sum along the last axis: the same bits per element
    # whatever the batch (a matrix product's blocking would not promise that)
    return (power_w(u, p) * weights).sum(axis=-1) * vp / accel


def leg_energy_wh(d: Any, v_max: float, accel: float, power: PowerParams | None = None
                  ) -> np.ndarray:  # fmt: skip
    """Energy of rest-to-rest legs flown with the model's trapezoid speed profile (paper Eq. 1).

    A leg longer than v_max^2 / a ramps to v_max, cruises (d - v_max^2 / a) / v_max seconds and
    ramps down; a shorter one is a triangle peaking at sqrt(a d). E = 2 E_ramp(V_peak) +
    P(v_max) x t_cruise. The profile's duration is `formulas.flight_time(d, v_max, accel)`.

    Args:
        d: leg lengths (m), any shape; d <= 0 costs 0.
        v_max: cruise speed (m/s), > 0.
        accel: acceleration a (m/s^2), > 0.
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        Energy in Wh, d's shape.
    """
    p = _power(power)
    d = np.maximum(np.asarray(d, dtype=float), 0.0)
    ramp_d = v_max * v_max / accel  # both ramps together, at full speed
    cruise = d > ramp_d
    e = np.zeros_like(d)
    if cruise.any():
        full = 2.0 * float(ramp_energy_j(v_max, accel, p, v_top=v_max))
        e = np.where(cruise, full + float(power_w(v_max, p)) * (d - ramp_d) / v_max, e)
    tri = ~cruise & (d > 0.0)
    if tri.any():
        e[tri] = 2.0 * ramp_energy_j(np.sqrt(accel * d[tri]), accel, p, v_top=v_max)
    return e / J_PER_WH


def hover_energy_wh(t_s: Any, power: PowerParams | None = None) -> np.ndarray:
    """Energy of hovering t seconds: P(0) t / 3600 (Wh), t's shape (negative t counts 0).

    Args:
        t_s: hover times (s), any shape.
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        Energy in Wh.
    """
    return hover_power_w(power) * np.maximum(np.asarray(t_s, dtype=float), 0.0) / J_PER_WH


def vertical_time_s(altitude: float, climb_speed: float, descent_speed: float,
                    accel: float) -> float:
    """Seconds of the vertical take-off to `altitude` and the landing from it: Eq. 1 over
    |altitude| at most `climb_speed` up, then at most `descent_speed` down (the autopilots'
    vertical speeds in missions, `uav.climb_speed` and `uav.descent_speed`).

    Args:
        altitude: H (m); 0 gives 0.
        climb_speed, descent_speed: vertical speeds (m/s), > 0.
        accel: the UAV's acceleration (m/s^2), > 0.

    Returns:
        Seconds.
    """
    h = abs(float(altitude))
    if h <= 0.0:
        return 0.0
    return sum(float(flight_time(h, float(v), accel)) for v in (climb_speed, descent_speed))


def vertical_energy_wh(altitude: float, climb_speed: float, descent_speed: float,
                       accel: float, power: PowerParams | None = None) -> float:
    """Energy of the vertical take-off to `altitude` and the landing from it: their time
    (`vertical_time_s`) at hover power P(0) (Wh). The level-flight model has no climb term;
    the sim (`sim.replay`) flies the same two vertical phases at the same speeds.

    Args:
        altitude: H (m); 0 gives 0.
        climb_speed, descent_speed: vertical speeds (m/s), > 0.
        accel: the UAV's acceleration (m/s^2), > 0.
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        Energy in Wh.
    """
    t = vertical_time_s(altitude, climb_speed, descent_speed, accel)
    return float(hover_energy_wh(t, power))


def route_flight_energy_wh(path_xy: Any, v_max: float, accel: float,
                           power: PowerParams | None = None) -> float:  # fmt: skip
    """Energy (Wh) of the horizontal legs of a polyline flown stop to stop (no hover, no
    vertical phases): sum of `leg_energy_wh` over its straight legs.

    Args:
        path_xy: (K, 2) points in local metres, in flight order (K >= 1).
        v_max, accel: the UAV's speed (m/s) and acceleration (m/s^2).
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        Energy in Wh.

    Raises:
        ValueError: path_xy is not (K, 2).
    """
    pts = np.asarray(path_xy, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 1:
        raise ValueError(f"path_xy: expected shape (K, 2) with K >= 1, got {pts.shape}")
    seg = np.diff(pts, axis=0)
    return float(leg_energy_wh(np.hypot(seg[:, 0], seg[:, 1]), v_max, accel, power).sum())


def sortie_energy_wh(path_xy: Any, hover_s: Any, uav: Any,
                     power: PowerParams | None = None) -> float:  # fmt: skip
    """Energy (Wh) of one sortie: take-off at path_xy[0], the straight legs of path_xy flown
    stop to stop with Eq. 1's profile, hover times at the points, landing at path_xy[-1].

    path_xy is the route as the planner flies it: depot, hover points (detour corners among
    them, with hover time 0: the planner's legs are straight and its plans route around
    obstacles through such corners), depot. E = vertical_energy_wh(H) +
    route_flight_energy_wh(path) + P(0) / 3600 x sum(hover_s): linear in the hover times.

    Args:
        path_xy: (K, 2) local metres, K >= 2 (first and last: the depots).
        hover_s: hover times (s) at the points: (K - 2,) for the interior points or (K,).
        uav: the map's `uav` settings (`max_speed`, `acceleration`, `altitude`,
            `climb_speed`, `descent_speed`; a `planner_core.model.mapio.Map`'s `spec.uav`).
        power: the model's parameters (default `DEFAULT_POWER`; a map's `Map.power`).

    Returns:
        Energy in Wh.

    Raises:
        ValueError: path_xy is not (K, 2) with K >= 2, or hover_s has neither K - 2 nor K
            entries.
    """
    pts = np.asarray(path_xy, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
        raise ValueError(f"path_xy: expected shape (K, 2) with K >= 2, got {pts.shape}")
    t = np.asarray(hover_s, dtype=float).reshape(-1)
    if len(t) not in (len(pts) - 2, len(pts)):
        raise ValueError(f"hover_s: expected {len(pts) - 2} or {len(pts)} hover times for "
                         f"{len(pts)} points, got {len(t)}")  # fmt: skip
    v_max, accel = float(uav.max_speed), float(uav.acceleration)
    return (vertical_energy_wh(float(uav.altitude), float(uav.climb_speed),
                               float(uav.descent_speed), accel, power)
            + route_flight_energy_wh(pts, v_max, accel, power)
            + float(hover_energy_wh(t, power).sum()))  # fmt: skip


def battery_energy_wh(energy_wh: float | None, endurance_s: float | None,
                      power: PowerParams | None = None) -> float | None:  # fmt: skip
    """A full battery's energy (Wh): `uav.battery.energy_wh`, or `uav.endurance_s` hover seconds
    at P(0) (endurance_s x P(0) / 3600); None when neither is given.

    Args:
        energy_wh: the battery's energy (Wh) or None.
        endurance_s: hover seconds on one battery or None (not both given).
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        Wh, or None.

    Raises:
        ValueError: both are given.
    """
    if energy_wh is not None and endurance_s is not None:
        raise ValueError("uav.endurance_s: give the battery as uav.battery.energy_wh or as "
                         "uav.endurance_s, not both")  # fmt: skip
    if energy_wh is not None:
        return float(energy_wh)
    if endurance_s is not None:
        return float(hover_energy_wh(endurance_s, power))
    return None


def hover_endurance_s(energy_wh: Any, power: PowerParams | None = None) -> np.ndarray:
    """Seconds of hover at P(0) that `energy_wh` pays for: energy_wh x 3600 / P(0), the
    inverse of `hover_energy_wh` (and of `battery_energy_wh`'s endurance_s), for saying a
    battery as a `uav.endurance_s`.

    Args:
        energy_wh: energies (Wh), any shape.
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        Seconds, energy_wh's shape.
    """
    return np.asarray(energy_wh, dtype=float) * J_PER_WH / hover_power_w(power)


def usable_energy_wh(battery_wh: float, reserve: float) -> float:
    """Energy a sortie may spend (Wh): battery x (1 - reserve).

    Args:
        battery_wh: a full battery's energy (Wh).
        reserve: the fraction kept at landing, in [0, 0.9] (`uav.battery.reserve`).

    Returns:
        Wh.
    """
    return float(battery_wh) * (1.0 - float(reserve))


def battery_for_usable_wh(usable_wh: float, reserve: float) -> float:
    """The full battery (Wh) whose usable energy is `usable_wh`: usable / (1 - reserve), the
    inverse of `usable_energy_wh`.

    Args:
        usable_wh: energy a sortie may spend (Wh).
        reserve: the fraction kept at landing, in [0, 0.9] (`uav.battery.reserve`).

    Returns:
        Wh.
    """
    return float(usable_wh) / (1.0 - float(reserve))


def least_energy_per_metre_wh(v_max: float, power: PowerParams | None = None) -> float:
    """A lower bound (Wh per metre) on the energy of any horizontal flight at speeds up to
    v_max: E = int P(v) dt = int P(v) / v ds >= L x min_{0 < u <= v_max} P(u) / u, whatever the
    legs and their profiles. Proven on 20,000 geometric intervals [u_k, u_k+1] of (0, v_max]:
    there P(u) / u >= (profile(u_k) + induced(u_k+1) + parasite(u_k)) / u_k+1 (each term is
    monotone). Used by `check` (`planner_core.model.diagnose`) to prove a sensor or a depot out
    of a battery's reach.

    Args:
        v_max: the UAV's top speed (m/s), > 0.
        power: the model's parameters (default `DEFAULT_POWER`).

    Returns:
        Wh per metre (> 0).
    """
    p = _power(power)
    u = float(v_max) * np.geomspace(1e-6, 1.0, 20_001)
    lo_prof, _, lo_par = _power_terms(u[:-1], p)
    _, hi_ind, _ = _power_terms(u[1:], p)
    return float(np.min((lo_prof + hi_ind + lo_par) / u[1:])) / J_PER_WH
