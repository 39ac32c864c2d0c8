"""Sorties and fleet plans: what a battery-limited crew flies (issue 33), and how it is scored.

A `Sortie` is one flight on one battery: take-off at a depot, straight legs through its points
(hover points, and detour corners with hover time 0, as the planner's single-flight plans hold
them), landing at a depot. A `FleetPlan` holds each vehicle's sorties in flying order; a vehicle
takes off for its next sortie where its last one landed, after a battery swap of `swap_s`.

Scores (paper Sec. 3 per sortie):

* f of a sortie: alpha x t_fly + (1 - alpha) x t_hover (the paper's f; t_fly the Eq. 1 legs);
* duration of a sortie: t_fly + t_hover + the vertical take-off and landing (the sim's clock);
* energy of a sortie: `planner_core.model.energy.sortie_energy_wh` (the one planner-side
  formula), linear in the hover times: E = E_flight(route) + P(0) / 3600 x sum t;
* "total" = sum of f over sorties + swap_s per swap (swaps = sorties - vehicles flying);
  "makespan" = max over vehicles of (sum of its durations + swap_s per swap), ties by total.

Cost: O(points) per sortie score (the energy module's legs); nothing here grows with sensors
except `shares` (O(points x sensors): the link rates).

Units: m, s, Wh, Mbit.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np

from planner_core.model import energy as E
from planner_core.model import mapio as _mapio
from planner_core.model.formulas import flight_time

__all__ = [
    "ENERGY_SLACK",
    "HOVER_ROUND_S",
    "FleetSettings",
    "FleetPlan",
    "Sortie",
    "END_DEPOT",
]

#: fraction of the usable energy the planner leaves unplanned: the sim integrates its own
#: replayed speed profile (`sim.energy`), which may differ from the planner's by rounding
ENERGY_SLACK = 0.002
#: seconds per hover point the planner keeps in hand for storage: a mission file stores hover
#: times rounded up to whole seconds (`lamde_mission.storage`), which costs up to P(0) x 1 s
HOVER_ROUND_S = 1.0
#: name of the landing site at the map's end, when the map gives no `fleet.depots` and its end
#: is not its start (a sortie may land there: `planner_core.model.mapio.Map.sortie_sites`)
END_DEPOT = _mapio.END_DEPOT


@dataclass(frozen=True, eq=False)
class FleetSettings:
    """Everything a fleet plan is scored with, read once from a map.

    Attributes:
        depot_names: (D,) depot names; depots (D, 2) their positions, m.
        start_depots: indices of the depots a vehicle's first sortie may leave (all, or the
            map's start alone when the map gives no depots).
        uavs: vehicles flying at once; swap_s: seconds per battery swap.
        usable_wh: energy one sortie may spend (battery x (1 - reserve)), Wh.
        power: the propulsion model's parameters (`planner_core.model.energy.PowerParams`).
        uav: the map's `uav` settings (speed, acceleration, altitude, T_max).
        alpha: the paper's weight of flight against hover time.
        goal: "total" or "makespan".
        pads: (V, D, 2) the pads of each depot, m (`Map.vehicle_pads`; [0] is `depots`); the
            vehicles a plan sends to a depot take them in the order of their numbers; None:
            every vehicle at the depot itself.
        pad_wh: Wh `budget_wh` keeps back for the pads: a sortie is searched from its depot
            and flown from its vehicle's pad (`planner_core.fleet.search.on_pads`), which
            costs at most one leg from the pad to the depot at each end and a corner there
            (`from_map` gives that full allowance; the search may keep less and re-time). 0
            for one vehicle, and for a plan already on its pads.
    """

    depot_names: tuple[str, ...]
    depots: np.ndarray
    start_depots: tuple[int, ...]
    uavs: int
    swap_s: float
    usable_wh: float
    power: Any
    uav: Any
    alpha: float
    goal: str
    pads: np.ndarray | None = None
    pad_wh: float = 0.0

    @classmethod
    def from_map(cls, m: Any, goal: str | None = None,
                 uavs: int | None = None) -> FleetSettings:
        """From a loaded map with a battery (`Map.usable_energy_wh`, `depots`, `uavs`,
        `swap_s`, `goal`); `goal` overrides the map's. Without `fleet.depots` the depots are
        the map's start ("home", where every vehicle starts) and, when it differs, its end.

        Without a battery the usable energy is infinite (a fleet flies one sortie a vehicle).

        Args:
            m: a loaded map (`planner_core.model.mapio.Map`).
            goal: "total" or "makespan"; None takes the map's `fleet.goal`.
            uavs: the vehicles a plan may fly, at most the map's `fleet.uavs` (None: all of
                them); the pads stay the map's layout for its whole fleet (`Map.vehicle_pads`),
                the ones its files and `verify` give each vehicle.

        Returns:
            The settings.

        Raises:
            ValueError: an unknown goal.
        """
        usable = m.usable_energy_wh
        if usable is None:  # a fleet without a battery: sorties of any length
            usable = float("inf")
        goal = goal or m.goal
        if goal not in ("total", "makespan"):
            raise ValueError(f"goal: must be 'total' or 'makespan', got {goal!r}")
        names, dep, starts = m.sortie_sites
        n = int(m.uavs) if uavs is None else max(1, min(int(uavs), int(m.uavs)))
        st = cls(depot_names=tuple(names), depots=dep, start_depots=starts,
                 uavs=n, swap_s=float(m.swap_s), usable_wh=float(usable),
                 power=m.power, uav=m.spec.uav, alpha=float(m.spec.objective.alpha),
                 goal=goal)  # fmt: skip
        if st.uavs < 2:
            return st
        pads = m.vehicle_pads
        reach = float(np.hypot(*(pads - np.asarray(dep)[None]).reshape(-1, 2).T).max())
        allowance = 2.0 * (float(st.leg_energies(np.array(reach))) + st._kept_wh(1))
        return replace(st, pads=pads, pad_wh=allowance)

    def pad(self, k: int, depot: int) -> np.ndarray:
        """Pad k of a depot (`planner_core.model.pads.pad_ranks` says which vehicle uses it).

        Args:
            k: the pad's index, 0 the depot itself (beyond `pads`: the depot).
            depot: index into `depots`.

        Returns:
            (2,) m.
        """
        if self.pads is None or k >= len(self.pads):
            return np.asarray(self.depots[depot], dtype=float)
        return np.asarray(self.pads[k, depot], dtype=float)

    def on_pads(self) -> FleetSettings:
        """These settings for a plan whose sorties fly from their vehicles' pads: no pad
        allowance kept back (`pad_wh` 0).

        Returns:
            The settings with `pad_wh` 0.
        """
        return replace(self, pad_wh=0.0)

    @cached_property
    def hover_w(self) -> float:
        """P(0), W.

        Returns:
            The hover power P(0) of `power` (`energy.hover_power_w`), W.
        """
        return float(E.hover_power_w(self.power))

    @cached_property
    def vertical_wh(self) -> float:
        """Energy of one sortie's take-off and landing, Wh (`energy.vertical_energy_wh`).

        Returns:
            Wh, at the UAV's altitude, climb and descent speeds and acceleration.
        """
        u = self.uav
        return E.vertical_energy_wh(float(u.altitude), float(u.climb_speed),
                                    float(u.descent_speed), float(u.acceleration),
                                    self.power)  # fmt: skip

    @cached_property
    def vertical_s(self) -> float:
        """Seconds of one sortie's take-off and landing (`energy.vertical_time_s`: Eq. 1 over
        the altitude at the climb speed, then at the descent speed).

        Returns:
            Seconds.
        """
        u = self.uav
        return E.vertical_time_s(float(u.altitude), float(u.climb_speed),
                                 float(u.descent_speed), float(u.acceleration))

    def leg_times(self, d: np.ndarray) -> np.ndarray:
        """Eq. 1 time of rest-to-rest legs at the UAV's max speed and acceleration
        (`planner_core.model.formulas.flight_time`).

        Args:
            d: leg lengths (m), any shape; d <= 0 takes 0 s.

        Returns:
            Seconds, d's shape.
        """
        return flight_time(d, float(self.uav.max_speed), float(self.uav.acceleration))

    def leg_energies(self, d: np.ndarray) -> np.ndarray:
        """Energy of rest-to-rest legs flown with Eq. 1's profile (`energy.leg_energy_wh`).

        Args:
            d: leg lengths (m), any shape; d <= 0 costs 0.

        Returns:
            Wh, d's shape.
        """
        return E.leg_energy_wh(d, float(self.uav.max_speed), float(self.uav.acceleration),
                               self.power)  # fmt: skip

    def hover_wh(self, t_s: Any) -> np.ndarray:
        """Energy of hovering t seconds at P(0) (`energy.hover_energy_wh`).

        Args:
            t_s: hover times (s), any shape.

        Returns:
            Wh, t_s's shape.
        """
        return E.hover_energy_wh(t_s, self.power)

    def _kept_wh(self, n_points: Any) -> Any:
        """What `budget_wh` keeps back beyond `ENERGY_SLACK`: `HOVER_ROUND_S` of hover power
        P(0) per point, for storage's rounding (Wh, n_points' shape)."""
        return self.hover_w * HOVER_ROUND_S * n_points / E.J_PER_WH

    def budget_wh(self, n_points: int) -> float:
        """Energy a sortie may plan to spend: the usable energy less `ENERGY_SLACK` of it,
        `HOVER_ROUND_S` of hover power P(0) per point (kept for storage's rounding) and
        `pad_wh` (kept for flying from the vehicle's pad).

        Args:
            n_points: points of the sortie (hover points and detour corners).

        Returns:
            Wh (infinite without a battery).
        """
        return self.usable_wh * (1.0 - ENERGY_SLACK) - self._kept_wh(n_points) - self.pad_wh

    def usable_for(self, spend_wh: Any, n_points: Any) -> Any:
        """The least usable energy (battery x (1 - reserve)) whose `budget_wh(n_points)` is
        `spend_wh`: the inverse of `budget_wh`, for saying what battery a sortie would need.

        Args:
            spend_wh: Wh a sortie plans to spend, any shape.
            n_points: its points (hover points and detour corners), broadcast with it.

        Returns:
            Wh, the broadcast shape.
        """
        return ((np.asarray(spend_wh, dtype=float) + self._kept_wh(np.asarray(n_points))
                 + self.pad_wh) / (1.0 - ENERGY_SLACK))  # fmt: skip


@dataclass(frozen=True, eq=False)
class Sortie:
    """One flight on one battery: depot `start` -> `points` (k, 2) -> depot `end`, hovering
    `times` (k,) s at the points (0 at detour corners). Depots are indices into
    `FleetSettings.depots`; the sortie takes off from pad `pads[0]` of depot `start` and lands
    at pad `pads[1]` of depot `end` (`FleetSettings.pad`; indices: 0, the default, is the depot
    itself, pad 1 as `check` numbers them). Points and times are stored as read-only float copies.

    Raises:
        ValueError: `times` and `points` of different lengths.
    """

    start: int
    end: int
    points: np.ndarray
    times: np.ndarray
    pads: tuple[int, int] = (0, 0)

    def __post_init__(self) -> None:
        p = np.asarray(self.points, dtype=float).reshape(-1, 2).copy()
        t = np.asarray(self.times, dtype=float).reshape(-1).copy()
        if len(p) != len(t):
            raise ValueError(f"times: {len(t)} hover times for {len(p)} points")
        p.flags.writeable = False
        t.flags.writeable = False
        object.__setattr__(self, "points", p)
        object.__setattr__(self, "times", t)

    def path(self, s: FleetSettings) -> np.ndarray:
        """The flown route: the pad at depot `start`, the points, the pad at depot `end`.

        Args:
            s: the settings whose depots `start` and `end` index.

        Returns:
            (k + 2, 2) positions, m.
        """
        return np.vstack([s.pad(self.pads[0], self.start), self.points,
                          s.pad(self.pads[1], self.end)])

    def leg_lengths(self, s: FleetSettings) -> np.ndarray:
        """Lengths of the straight legs of `path`.

        Args:
            s: the fleet's settings.

        Returns:
            (k + 1,) lengths, m.
        """
        return np.hypot(*np.diff(self.path(s), axis=0).T)

    def t_fly(self, s: FleetSettings) -> float:
        """Horizontal flight time t_fly: Eq. 1 per leg, summed (no take-off or landing).

        Args:
            s: the fleet's settings.

        Returns:
            Seconds.
        """
        return float(s.leg_times(self.leg_lengths(s)).sum())

    @property
    def t_hover(self) -> float:
        """Sum of the hover times, s.

        Returns:
            Seconds (0 for a sortie without points).
        """
        return float(self.times.sum())

    def f(self, s: FleetSettings) -> float:
        """The paper's f of this sortie (Sec. 3): alpha t_fly + (1 - alpha) t_hover.

        Args:
            s: the fleet's settings (alpha, speeds, depots).

        Returns:
            f, seconds.
        """
        return s.alpha * self.t_fly(s) + (1.0 - s.alpha) * self.t_hover

    def duration(self, s: FleetSettings) -> float:
        """Time from take-off to landing: t_fly + t_hover + `FleetSettings.vertical_s`.

        Args:
            s: the fleet's settings.

        Returns:
            Seconds.
        """
        return self.t_fly(s) + self.t_hover + s.vertical_s

    def flight_wh(self, s: FleetSettings) -> float:
        """Energy of everything but the hovers: `sortie_energy_wh` with zero hover times
        (legs, take-off and landing).

        Args:
            s: the fleet's settings.

        Returns:
            Wh.
        """
        return E.sortie_energy_wh(self.path(s), np.zeros(len(self.points)), s.uav, s.power)

    def energy(self, s: FleetSettings) -> float:
        """Energy of the sortie (`planner_core.model.energy.sortie_energy_wh`).

        Args:
            s: the fleet's settings.

        Returns:
            Wh.
        """
        return E.sortie_energy_wh(self.path(s), self.times, s.uav, s.power)

    def with_times(self, times: np.ndarray) -> Sortie:
        """The same route with other hover times.

        Args:
            times: (k,) hover times, s.

        Returns:
            A new sortie.

        Raises:
            ValueError: `times` not one per point.
        """
        return Sortie(self.start, self.end, self.points, times, self.pads)


@dataclass(frozen=True, eq=False)
class FleetPlan:
    """Each vehicle's sorties in flying order (`vehicles[v][k]`), scored with `settings`.

    `evaluations`: plans the pipeline and the fleet search evaluated to make it (counted);
    `notes`: what the search did (JSON-ready lines)."""

    settings: FleetSettings
    vehicles: tuple[tuple[Sortie, ...], ...]
    evaluations: int = 0
    notes: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "vehicles", tuple(tuple(v) for v in self.vehicles if v))

    @property
    def sorties(self) -> list[Sortie]:
        """Every sortie, vehicle by vehicle.

        Returns:
            A new list of the sorties, each vehicle's in flying order.
        """
        return [s for v in self.vehicles for s in v]

    @property
    def swaps(self) -> int:
        """Battery swaps: sorties after each vehicle's first.

        Returns:
            The count, >= 0.
        """
        return sum(len(v) - 1 for v in self.vehicles)

    def vehicle_span(self, v: int) -> float:
        """Time vehicle v flies from its first take-off to its last landing: the sum of its
        sorties' `Sortie.duration` plus `swap_s` per swap.

        Args:
            v: index into `vehicles`.

        Returns:
            Seconds.

        Raises:
            IndexError: v out of range.
        """
        s = self.settings
        return sum(x.duration(s) for x in self.vehicles[v]) + s.swap_s * (len(self.vehicles[v]) - 1)

    @property
    def makespan(self) -> float:
        """The longest vehicle's span, s.

        Returns:
            Seconds (`vehicle_span`'s largest; 0.0 without vehicles).
        """
        return max((self.vehicle_span(v) for v in range(len(self.vehicles))), default=0.0)

    @property
    def total(self) -> float:
        """Sum of the paper's f over sorties + swap_s per swap (the "total" objective).

        Returns:
            Seconds.
        """
        s = self.settings
        return sum(x.f(s) for x in self.sorties) + s.swap_s * self.swaps

    @property
    def total_time(self) -> float:
        """Seconds of flight, hover, take-off and landing over all sorties, plus the swaps.

        Returns:
            Seconds (`Sortie.duration` summed, plus `swap_s` per swap).
        """
        s = self.settings
        return sum(x.duration(s) for x in self.sorties) + s.swap_s * self.swaps

    def objective(self, goal: str | None = None) -> tuple[float, float]:
        """What the search minimises, compared as a tuple.

        Args:
            goal: "total" or "makespan"; None takes the settings' goal. Any other value is
                read as "makespan".

        Returns:
            (total, makespan) for "total", (makespan, total) otherwise; seconds.
        """
        g = goal or self.settings.goal
        return (self.total, self.makespan) if g == "total" else (self.makespan, self.total)

    def chained(self) -> bool:
        """Whether the sorties chain: every vehicle's first sortie leaves a start depot and each
        later one the depot the one before it landed at (a vehicle takes off where it stands).

        Returns:
            True when they do.
        """
        st = self.settings
        for vs in self.vehicles:
            if vs[0].start not in st.start_depots:
                return False
            if any(a.end != b.start for a, b in zip(vs[:-1], vs[1:], strict=True)):
                return False
        return True

    def energy_ok(self) -> bool:
        """Whether every sortie's `Sortie.energy` is within `FleetSettings.usable_wh` (the
        planner's model, without `budget_wh`'s margins).

        Returns:
            True when all are.
        """
        u = self.settings.usable_wh
        return all(x.energy(self.settings) <= u for x in self.sorties)

    def replace(
        self, vehicles: Any, *, evaluations: int | None = None, notes: tuple[str, ...] | None = None
    ) -> FleetPlan:
        """This plan with other vehicles (and evaluation count / notes).

        Args:
            vehicles: each vehicle's sorties in flying order (empty vehicles are dropped).
            evaluations: the new count; None keeps this plan's.
            notes: the new notes; None keeps this plan's.

        Returns:
            A new plan with the same settings.
        """
        return FleetPlan(self.settings, vehicles,
                         self.evaluations if evaluations is None else evaluations,
                         self.notes if notes is None else notes)  # fmt: skip
