"""The sim's own energy of a replayed mission (issue 33): a second opinion on the planner's.

Power: the rotary-wing model of Zeng, Xu and Zhang (IEEE Trans. Wireless Commun. 18(4), 2019,
Eq. 12), P(V) = P0 (1 + 3 V^2 / U_tip^2) + Pi (sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2))^(1/2)
+ 1/2 d0 rho s A V^3, the parameters from the map's `uav.power` (defaults: the defaults table,
the only thing of planner_core the sim reads).

Unlike the planner (`planner_core.model.energy`, Gauss-Legendre quadrature), the sim integrates
each ramp of its replayed speed profile in CLOSED FORM: with y = (v_i / v0)^2 the induced
velocity's square in hover units (y^2 + y w^2 = 1, w = u / v0),

    int_0^V P(u) du = P0 (V + V^3 / U_tip^2) + Pi v0 (artanh(z) + z) / 2 + d0 rho s A V^4 / 8,

z = sqrt(1 - y^2) = w sqrt(y) at w = V / v0 (differentiate to check: d/dw of the middle term is
sqrt(y)). A ramp at acceleration a costs that over a. The replay's phases: the vertical
take-off and landing at hover power P(0) (the level-flight model has no climb term), every
horizontal leg at the speed the mission sets for it (trapezoid or triangle, as `sim.replay`
flies it) and P(0) over any time a change of altitude adds to the leg, an RTL return leg, and
P(0) x every hover time.

Cost: O(legs) per mission, independent of the sensors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from planner_core.defaults import MAP_DEFAULTS
from sim.replay import leg_time

__all__ = ["SimPower", "MissionEnergy", "power", "ramp_energy", "leg_energy", "battery",
           "mission_energy"]  # fmt: skip

_FIELDS = ("blade_profile_w", "induced_w", "tip_speed", "induced_velocity",
           "fuselage_drag_ratio", "air_density", "rotor_solidity", "rotor_disc_area")  # fmt: skip


@dataclass(frozen=True)
class SimPower:
    """Zeng et al. (2019) parameters, named as in the map file's `uav.power`."""

    blade_profile_w: float
    induced_w: float
    tip_speed: float
    induced_velocity: float
    fuselage_drag_ratio: float
    air_density: float
    rotor_solidity: float
    rotor_disc_area: float

    @classmethod
    def of(cls, map: Any) -> SimPower:  # noqa: A002
        """From a map's `spec.uav.power` (absent fields: the defaults table's values).

        Args:
            map: a loaded map; one without `spec.uav.power` takes every default.

        Returns:
            The parameters, floats (W, m/s, kg/m^3, m^2).
        """
        spec = getattr(getattr(getattr(map, "spec", None), "uav", None), "power", None)
        vals = {}
        for name in _FIELDS:
            v = getattr(spec, name, None) if spec is not None else None
            vals[name] = float(MAP_DEFAULTS[f"uav.power.{name}"].value if v is None else v)
        return cls(**vals)

    @property
    def hover(self) -> float:
        """Hover power, P(0) = P0 + Pi.

        Returns:
            P(0), W.
        """
        return power(0.0, self)


def power(v: float, p: SimPower) -> float:
    """Propulsion power at level speed V: Zeng et al. (2019) Eq. 12 (the induced term through
    y, which keeps its digits at high speed).

    Args:
        v: speed V (m/s); its sign is ignored.
        p: the model's parameters.

    Returns:
        P(V), W.
    """
    v = abs(float(v))
    w = v / p.induced_velocity
    y = 1.0 / (math.sqrt(1.0 + 0.25 * w**4) + 0.5 * w * w)
    parasite = 0.5 * p.fuselage_drag_ratio * p.air_density * p.rotor_solidity * p.rotor_disc_area
    return (p.blade_profile_w * (1.0 + 3.0 * v * v / p.tip_speed**2)
            + p.induced_w * math.sqrt(y) + parasite * v**3)  # fmt: skip


def ramp_energy(v_peak: float, accel: float, p: SimPower) -> float:
    """Energy of one ramp between rest and v_peak at constant acceleration: (1/a) int_0^V P(u)
    du in closed form (module docstring).

    Args:
        v_peak: V (m/s); <= 0 costs 0.
        accel: a (m/s^2), > 0.
        p: the model's parameters.

    Returns:
        J.
    """
    big_v = max(float(v_peak), 0.0)
    if big_v <= 0.0:
        return 0.0
    v0 = p.induced_velocity
    w = big_v / v0
    y = 1.0 / (math.sqrt(1.0 + 0.25 * w**4) + 0.5 * w * w)
    z = w * math.sqrt(y)  # sqrt(1 - y^2), since 1 - y^2 = y w^2
    # artanh(z) = ln((1 + z) / y): (1 + z)(1 - z) = y^2; log1p keeps the small-w digits
    one_minus_y = y * w * w / (1.0 + y)
    artanh = math.log1p(z) - math.log1p(-one_minus_y)
    profile = p.blade_profile_w * (big_v + big_v**3 / p.tip_speed**2)
    induced = p.induced_w * v0 * 0.5 * (artanh + z)
    parasite = (p.fuselage_drag_ratio * p.air_density * p.rotor_solidity * p.rotor_disc_area
                * big_v**4 / 8.0)  # fmt: skip
    return (profile + induced + parasite) / float(accel)


def leg_energy(d: float, v_max: float, accel: float, p: SimPower) -> float:
    """Energy of a rest-to-rest leg (paper Eq. 1's profile: trapezoid above v_max^2 / a,
    triangle peaking at sqrt(a d) below), as `sim.replay.leg_position` flies it: two ramps
    (`ramp_energy`) plus P(v_max) over the cruise.

    Args:
        d: leg length (m); <= 0 costs 0.
        v_max: cruise speed (m/s), > 0.
        accel: a (m/s^2), > 0.
        p: the model's parameters.

    Returns:
        J.
    """
    if d <= 0.0:
        return 0.0
    ramps = v_max * v_max / accel
    if d > ramps:
        return 2.0 * ramp_energy(v_max, accel, p) + power(v_max, p) * (d - ramps) / v_max
    return 2.0 * ramp_energy(math.sqrt(accel * d), accel, p)


def battery(map: Any, p: SimPower | None = None) -> tuple[float, float] | None:  # noqa: A002
    """The map's battery from `uav.battery.energy_wh`, else `uav.endurance_s` (hover seconds:
    endurance_s x P(0) / 3600 Wh); the reserve from `uav.battery.reserve` or the defaults table.

    Args:
        map: a loaded map.
        p: the power parameters for P(0) (default `SimPower.of(map)`; used only with
            endurance_s).

    Returns:
        (full battery Wh, reserve fraction), or None when the map gives no battery.
    """
    uav = map.spec.uav
    b = getattr(uav, "battery", None)
    energy = getattr(b, "energy_wh", None) if b is not None else None
    endurance = getattr(uav, "endurance_s", None)
    reserve = getattr(b, "reserve", None) if b is not None else None
    if reserve is None:
        reserve = MAP_DEFAULTS["uav.battery.reserve"].value
    if energy is not None:
        return float(energy), float(reserve)
    if endurance is not None:
        p = p or SimPower.of(map)
        return float(endurance) * p.hover / 3600.0, float(reserve)
    return None


@dataclass(frozen=True)
class MissionEnergy:
    """What a replayed mission spends, Wh, by phase; `total` is their sum.

    Attributes:
        vertical: the take-off and landing at P(0).
        flight: the horizontal legs, with P(0) over the time a climb or descent adds.
        ret: the RTL return leg (0 without one).
        hover: P(0) x the hover times.
    """

    vertical: float
    flight: float
    ret: float
    hover: float

    @property
    def total(self) -> float:
        """The mission's energy.

        Returns:
            vertical + flight + ret + hover, Wh.
        """
        return self.vertical + self.flight + self.ret + self.hover


def mission_energy(timeline: Any, map: Any) -> MissionEnergy:  # noqa: A002
    """The energy of a `sim.replay.Timeline` on `map`, Wh: take-off and landing at P(0) over
    their replayed times, each horizontal leg at its replayed speed (`Timeline.leg_speeds`)
    plus P(0) over the time a climb or descent adds to it, the RTL return leg at the final
    speed, hovers at P(0).

    Args:
        timeline: the replay (`sim.replay.Timeline`).
        map: the loaded map (its `uav.power`, through `SimPower.of`).

    Returns:
        The energy by phase, Wh.
    """
    p = SimPower.of(map)
    t = timeline.totals
    a = float(t.accel)
    hover_w = p.hover
    flight = 0.0
    for d, v, tl in zip(timeline.leg_lengths, timeline.leg_speeds, timeline.leg_times,
                        strict=True):  # fmt: skip
        flight += leg_energy(float(d), float(v), a, p)
        # a leg paced by its climb or descent (`sim.replay.vertical_time`) takes longer than its
        # horizontal profile: that time at P(0), as the vertical take-off and landing
        flight += hover_w * max(float(tl) - leg_time(float(d), float(v), a), 0.0)
    ret = 0.0
    if timeline.return_leg is not None:
        seg = timeline.return_leg[1] - timeline.return_leg[0]
        d = math.hypot(float(seg[0]), float(seg[1]))
        # as the replay: a return shorter than its snap distance is not flown
        ret = leg_energy(d, float(t.speed), a, p) if t.t_return > 0.0 else 0.0
    return MissionEnergy(
        vertical=hover_w * (t.t_takeoff + t.t_land) / 3600.0,
        flight=flight / 3600.0,
        ret=ret / 3600.0,
        hover=hover_w * float(t.t_hover) / 3600.0,
    )
