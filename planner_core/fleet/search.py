"""The sortie planner (issue 33): a battery-limited plan of sorties and vehicles, the split
optimised, each sortie planned by the declared pipeline.

`plan_fleet` (ours):

1. **Single flight.** The declared pipeline (`planner_core.pipeline.run_pipeline`: constructive
   plans, descents, DE, LP polish, final stage) on the planning map, as for a map without a
   battery: its hover points in flying order are a giant tour.
2. **Route first, cluster second** (`route_first`, also the benchmark's peer): the giant tour
   cut into battery-sized sorties by the optimal split with depot choice
   (`planner_core.fleet.split`), shared among the vehicles, hover times re-solved by the LP
   across sorties (`planner_core.fleet.lp`).
3. **Cluster first**: every sensor to its nearest depot; each depot's sensors planned by the
   pipeline as one flight from that depot back to it; the depots' tours joined in
   nearest-neighbour order from the first depot and split as in 2. The better of 2 and 3
   (`FleetPlan.objective`) is kept.
4. **Improving rounds** (at most `rounds`, while one improves the objective):
   * *re-plan sorties*: each sortie planned again by the pipeline from its depot to its depot,
     for the data it collects (the LP's shares; sensors it no longer serves left to the
     others), kept when its f falls within the battery and C3 holds with every sensor;
   * *merge*: two consecutive sorties of a vehicle planned by the pipeline as one;
   * *eliminate*: the sortie of least energy removed, its hover points inserted into the
     others (a swap saved when the LP finds hover times that fit every battery);
   * *transfer*: every hover point of a sortie tried at its cheapest insertion into each of
     the 3 nearest other sorties (a sensor's data then comes from the receiving sortie, or
     from several), kept when the LP across sorties finds a better objective;
   * *re-split*: each vehicle's sorties joined back into a tour and split again, both ways
     round (sorties merged or split, depots chosen again, the vehicles' shares moved);
   * *retour*: seeded or-opt moves on each vehicle's tour, each scored by its optimal split
     (Prins 2004: a giant tour evaluated by its split), `TOUR_TRIALS` per vehicle.
   Every change is scored by the LP across sorties on the whole plan.

Everything the pipeline evaluates goes through its counted `Evaluator` (budget `budget` for
the single flight, `sortie_budget` per sortie or depot plan); `FleetPlan.evaluations` is their
sum, and the LPs across sorties are counted in the notes. Same seed, same plan (the pipeline
runs' seeds derive from it).

Cost: the single flight's pipeline, plus D + rounds x 2S pipeline runs on about J / S sensors
each (S sorties, D depots: re-plans and merges), plus rounds x (TOUR_TRIALS x vehicles + 2)
splits (O(n x L x D^2) each, n hover points, L per sortie), plus rounds x n x 3 LPs of
N ~ n variables and J + S rows (O(N x J) each to build): about linear in the sensors for the
pipeline runs and quadratic for the transfer LPs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from planner_core.defaults import MAP_DEFAULTS
from planner_core.fleet.lp import collected_by_sortie, fleet_hover_lp
from planner_core.fleet.model import FleetPlan, FleetSettings, Sortie
from planner_core.fleet.split import (
    SHARE_MAX,
    Links,
    solo_need,
    solo_room,
    solo_sorties,
    split_tour,
    split_vehicles,
)
from planner_core.model import energy as E
from planner_core.model.mapio import sub_map_dict
from planner_core.streams import stream_rng, stream_seed
from planner_core.textio import counted, first_few, rounded_up

__all__ = ["SORTIE_BUDGET", "ROUNDS", "TRANSFER_NEIGHBOURS", "FleetResult", "plan_fleet",
           "route_first", "sortie_map_dict"]  # fmt: skip

#: evaluations of each pipeline run on one sortie's or one depot's sensors
SORTIE_BUDGET = 2000
#: metres: the least clearance a sub-run plans with (the map's own when larger). A sub-run's
#: legs to its depots end at a fixed point, which a mission stores on the 1e-7 degree grid
#: (up to ~1 cm off); a leg planned tangent to an obstacle there (clearance 0) would then cut
#: it (measured: L01, 25-min battery, seed 3, 1.1 m inside a circle), and storage cannot turn
#: a leg about a fixed end by moving the other
SUB_CLEARANCE = 0.1
#: improving rounds at most
ROUNDS = 3
#: other sorties a hover point is offered to in a transfer (the nearest by depot)
TRANSFER_NEIGHBOURS = 3
#: tour moves (a segment of 1-3 hover points moved up to `TOUR_WINDOW` places, either way
#: round) tried per vehicle and round, each scored by a split of the vehicle's tour
TOUR_TRIALS = 300
TOUR_WINDOW = 10
#: a hover point one sortie cannot serve alone is offered places on the way to it from this
#: many of its nearest depots, every 1/SPOT_STEPS of the way (`_Planner.best_spot`)
SPOT_DEPOTS = 3
SPOT_STEPS = 64
#: `_Planner.enough_battery` looks at the endurances between two powers of two seconds, P / 2
#: and P, in steps of P / ENOUGH_STEPS (0.8-1.6 %), up to the largest `uav.endurance_s` a map
#: may give (86,400 s)
ENOUGH_STEPS = 128
ENDURANCE_MAX_S = int(MAP_DEFAULTS["uav.endurance_s"].bounds[1])


class FleetResult:
    """A fleet plan with what made it: `plan` (the `FleetPlan`, planning-map coordinates),
    `single` (the single-flight plan's hover points and times), `peer` (the route-first
    cluster-second plan it started from, or None), `lps` (LPs across sorties solved)."""

    def __init__(
        self,
        plan: FleetPlan,
        single: tuple[np.ndarray, np.ndarray],
        peer: FleetPlan | None,
        lps: int,
    ) -> None:
        self.plan = plan
        self.single = single
        self.peer = peer
        self.lps = lps


def _seed(seed: int, *tags: int) -> int:
    """A derived pipeline seed (>= 0) for one sub-run: same seed and tags, same value."""
    return stream_seed(seed, "fleet", *tags) >> 1


#: the map file of one sortie (`planner_core.model.mapio.sub_map_dict`, its one home)
sortie_map_dict = sub_map_dict


class _Planner:
    """One fleet planning run: the map, its planning map's problem, settings, counters."""

    def __init__(self, m: Any, config: Any, goal: str | None, sortie_budget: int,
                 pad_wh: float | None = None, uavs: int | None = None) -> None:
        from planner_core.model.problem import Problem

        self.m = m
        self.uavs = uavs
        self.pm = m.planning_map()
        self.problem = Problem(self.pm, variable_length=config.variable_length)
        self.model = self.problem.model
        self.st = FleetSettings.from_map(m, goal, uavs)
        if pad_wh is not None:  # less kept back for the pads: `_finish` pins and re-times
            self.st = replace(self.st, pad_wh=min(float(pad_wh), self.st.pad_wh))
        self.config = config
        self.sortie_budget = int(sortie_budget)
        self.links = Links(self.problem)
        self.evaluations = 0
        self.lps = 0
        self.margin = 1.0 + float(m.spec.safety.data_margin)

    # ------------------------------------------------------------------ pipeline runs
    def _run(self, problem: Any, seed: int, budget: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The pipeline on `problem`: its hover points and times, None when infeasible."""
        from planner_core.pipeline import run_pipeline

        cfg = replace(self.config, seed=int(seed), budget=int(budget), time_limit=None)
        res = run_pipeline(problem, cfg)
        self.evaluations += res.evaluations
        b = problem.breakdown(res.x)
        if b["phi"] > 0.0:
            return None
        return (
            np.asarray(b["hover_points"], dtype=float).reshape(-1, 2),
            np.asarray(b["hover_times"], dtype=float),
        )

    def single(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Step 1: the single flight on the planning map."""
        return self._run(self.problem, self.config.seed, self.config.budget)

    def sub(
        self, a: np.ndarray, b: np.ndarray, req: np.ndarray, seed: int
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The pipeline from a to b (2,) for the data req (J,) Mbit of the planning map
        (with its margin): only the sensors that need data are put in the sub-map (the
        plan is then checked for C3 over every sensor)."""
        from planner_core.model.mapio import load_map
        from planner_core.model.problem import Problem

        keep = req > 0
        if not keep.any():
            return None
        d = sortie_map_dict(self.m, a, b, req / self.margin, keep=keep)
        d["safety"] = dict(d.get("safety") or {})
        d["safety"]["clearance"] = max(float(d["safety"].get("clearance", 0.0)), SUB_CLEARANCE)
        n = int(keep.sum())
        d["uav"]["max_hover_points"] = int(min(200, max(10, (n + 1) // 2 + 8)))
        sub = Problem(load_map(d).planning_map(), variable_length=self.config.variable_length)
        out = self._run(sub, seed, self.sortie_budget)
        if out is None or not self.c3_ok(out[0]):
            return None
        return out

    def c3_ok(self, pts: np.ndarray) -> bool:
        """C3 at every point with every sensor of the map (sum_j R_ij <= R_lambda)."""
        if not len(pts) or self.model.access != "simultaneous":
            return True
        return bool(np.all(self.model.rates(pts).sum(axis=1) <= self.model.bandwidth))

    # ------------------------------------------------------------------ plans
    def lp(self, plan: FleetPlan | None) -> FleetPlan | None:
        """The LP across sorties on `plan` (None passes through)."""
        if plan is None or not plan.chained():
            return None
        self.lps += 1
        out = fleet_hover_lp(plan, self.model)
        if out is None or not out.energy_ok():
            return None
        return out

    def split(self, P: np.ndarray, T: np.ndarray) -> FleetPlan | None:
        """A tour (its points moved where sorties reach them: `reachable`; corners joined
        into its blocked legs) split among the vehicles, LP'd."""
        joined = self.links.join(*self.reachable(P, T))
        if joined is None:
            return None
        return self.lp(split_vehicles(self.st, self.links, *joined))

    def reachable(self, P: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tour P (n, 2), T (n,) s with every hover point that one sortie cannot serve
        alone (no sortie of it alone fits the battery, or its hover needs several sorties:
        `split.solo_sorties` > 1) moved to `best_spot`, where taking the same data costs the
        least; the others as they are. A map planned as one flight puts its hover points where
        the flight is shortest, not where a battery's out-and-back reaches: a sensor far from
        every depot was then served from a point no sortie could reach, and no plan was found.

        Returns:
            (P', T'): P and T themselves when no point needs moving (or no battery).
        """
        P = np.asarray(P, dtype=float).reshape(-1, 2)
        T = np.asarray(T, dtype=float).reshape(-1)
        if not len(P) or not np.isfinite(self.st.usable_wh):
            return P, T
        k = solo_sorties(self.st, solo_room(self.st, self.links, P), T)
        move = np.flatnonzero((T > 0.0) & (k > 1))
        if not len(move):
            return P, T
        P, T = P.copy(), T.copy()
        for i in move:
            spot = self.best_spot(P[i], float(T[i]), float(k[i]))
            if spot is not None:
                P[i], T[i] = spot
        return P, T

    def best_spot(
        self, p: np.ndarray, t: float, k_here: float
    ) -> tuple[np.ndarray, float] | None:
        """Where to hover instead of p (t s) so the data p takes from each sensor costs the
        fewest sorties and least time: candidates every 1/`SPOT_STEPS` of the way from each of
        the `SPOT_DEPOTS` nearest depots to p (round the obstacles, through the visibility
        graph's corners), each hovering t' = max_j (R_pj t / R_qj) over the sensors p hears (0
        rate at q: not a candidate; C3 broken at q: neither), costed as k sorties out of and
        back to that depot with t' / k of hover each (k the least that fits the battery and
        T_max, at most `SHARE_MAX`): k (flight + swap) + t' weighted as the split weighs them.
        None when no candidate needs fewer than `k_here` sorties (p's own).

        Cost: `SPOT_DEPOTS` visibility-graph routes and SPOT_STEPS x J link rates.
        """
        st, model = self.st, self.model
        req = np.asarray(model.required, dtype=float)
        data = model.rates(p[None])[0] * t
        served = (data > 1e-9) & (req > 0)
        if not served.any():
            return None
        wf, wh, per = ((st.alpha, 1.0 - st.alpha, 0.0) if st.goal == "total"
                       else (1.0, 1.0, st.vertical_s))  # fmt: skip
        near = np.argsort(np.hypot(*(st.depots - p).T))[:SPOT_DEPOTS]
        best: tuple[float, np.ndarray, float] | None = None
        for d in near:
            way = self.links.way(st.depots[d], p)
            if way is None:
                continue
            path = np.vstack([st.depots[d], way, p])
            seg = np.hypot(*np.diff(path, axis=0).T)
            cum = np.concatenate([[0.0], np.cumsum(seg)])
            if cum[-1] <= 0.0:
                continue
            at = np.linspace(0.0, cum[-1], SPOT_STEPS + 1)[1:]
            s = np.minimum(np.searchsorted(cum, at, side="right") - 1, len(seg) - 1)
            part = at - cum[s]
            q = path[s] + (part / np.where(seg[s] > 0, seg[s], 1.0))[:, None] * (path[s + 1]
                                                                                 - path[s])
            e_full = np.concatenate([[0.0], np.cumsum(st.leg_energies(seg))])
            t_full = np.concatenate([[0.0], np.cumsum(st.leg_times(seg))])
            e_out = e_full[s] + st.leg_energies(part)
            t_out = t_full[s] + st.leg_times(part)
            room = st.budget_wh(1 + 2 * s) - st.vertical_wh - 2.0 * e_out
            R = model.rates(q)
            ok = (room > 0.0) & np.all(R[:, served] > 0.0, axis=1)
            if model.access == "simultaneous":
                ok &= R.sum(axis=1) <= model.bandwidth
            if not ok.any():
                continue
            tq = np.max(data[served] / np.where(R[:, served] > 0, R[:, served], 1.0), axis=1)
            k = solo_sorties(st, np.where(ok, room, 0.0), tq)
            cost = k * (wf * 2.0 * t_out + per) + (k - 1.0) * st.swap_s + wh * tq
            cost = np.where(ok & (k <= SHARE_MAX) & (k < k_here), cost, np.inf)
            i = int(np.argmin(cost))
            if np.isfinite(cost[i]) and (best is None or cost[i] < best[0]):
                best = (float(cost[i]), q[i].copy(), float(tq[i]))
        return None if best is None else (best[1], best[2])

    def why_not(self, single: tuple[np.ndarray, np.ndarray] | None, clustered: bool) -> str:
        """What failed, in words, and what to change, when no start gave a plan (`single`: the
        single flight, None when it found none; `clustered`: the depots' own flights were
        tried too): the single flight's first hover point that no sortie reaches even moved
        toward the depots, or that needs more than `SHARE_MAX` sorties; a leg no way round the
        obstacles joins; a corner of the tour (a detour round an obstacle) no sortie reaches;
        or the cut among the vehicles. Each battery case ends with `_advice`: the usable
        energy against what the point needs, and the battery, depots or vehicles that would
        change it. What `lamde-mission check` says CANNOT of the battery and depots
        (`diagnose.fleet_findings`) leads, since no battery that only fixes the search's point
        plans such a map; a battery that plans it (`enough_battery`) ends the line. Only said
        after planning failed: nothing here changes a plan.

        Args:
            single: the single flight's hover points (n, 2) m and times (n,) s, or None.
            clustered: the depots' own flights were tried too.

        Returns:
            One line, no trailing punctuation.

        Cost: `diagnose.fleet_findings` and `enough_battery`'s splits."""
        from planner_core.model.diagnose import fleet_findings

        # what `check` proves no plan can meet comes first: the search's own trouble below is
        # one tour's, and a battery that fixes it may still leave the map unplannable
        cannot = [f.message for f in fleet_findings(self.m) if f.fatal]
        lead = ""
        if cannot:
            more = (f" (and {counted(len(cannot) - 1, 'more CANNOT')} in `lamde-mission check`)"
                    if len(cannot) > 1 else "")  # fmt: skip
            lead = (f"no plan can meet this map (`lamde-mission check` says CANNOT): "
                    f"{cannot[0]}{more}; the search: ")
        reason = self._why_not(single, clustered)
        if single is None or not np.isfinite(self.st.usable_wh):
            return lead + reason
        enough = self.enough_battery(single)
        if enough is None:
            return (f"{lead}{reason}; no battery up to uav.endurance_s {ENDURANCE_MAX_S:,} cuts "
                    f"the same single flight (seed {self.config.seed}, budget "
                    f"{self.config.budget}) into sorties that fit it")
        wh, seconds = enough
        return (f"{lead}{reason}; a battery of {wh:.2f} Wh (uav.battery.energy_wh; or "
                f"uav.endurance_s {seconds:d}) plans this map: the same single flight (seed "
                f"{self.config.seed}, budget {self.config.budget}) cuts into sorties that fit "
                "it (a smaller one may plan too)")

    def _why_not(self, single: tuple[np.ndarray, np.ndarray] | None, clustered: bool) -> str:
        """`why_not`'s account of the search: what failed and what to change, without check's
        CANNOT and the battery that plans."""
        also = (" (nor did the depots' own flights, planned from each depot back to it)"
                if clustered else "")  # fmt: skip
        if single is None:
            return (f"the single flight found no feasible plan to cut into sorties (budget "
                    f"{self.config.budget}, seed {self.config.seed}){also}; a larger budget "
                    "may find one")
        st, model = self.st, self.model
        P, T = self.reachable(*single)
        room = solo_room(st, self.links, P)
        k = solo_sorties(st, room, T)
        for i in np.flatnonzero((T > 0.0) & (k > SHARE_MAX)):
            rates = model.rates(P[i : i + 1])[0]
            # the sensors it takes most data from (T_i R_ij), not the first in the map's order
            # (a reviewer's point 990 m from the first it named, 240 m from its own)
            ids = self.pm.sensor_ids
            take = [(float(T[i] * r), j) for j, (r, q) in enumerate(zip(rates, model.required,
                                                                         strict=True))
                    if r > 0 and q > 0]  # fmt: skip
            heard = [ids[j] for _, j in sorted(take, key=lambda o: (-o[0], o[1]))[:3]]
            served = first_few([repr(x) for x in heard], total=len(take)) or "no sensor"
            at = (f"the single flight's hover point at ({P[i, 0]:.0f}, {P[i, 1]:.0f}), "
                  f"serving {served}")
            if room[i] <= 0.0:
                return (f"{at}: no sortie from any depot reaches it and comes back on one "
                        f"battery, even moved toward the depots{also}; "
                        + self._advice(P[i], 0.0, " (no hover)"))
            return (f"{at}: its {T[i]:.4g} s of hover would need {k[i]:.0f} sorties, more "
                    f"than the {SHARE_MAX} the planner shares one point among{also}; "
                    + self._advice(P[i], float(T[i]) / SHARE_MAX,
                                   f" (1/{SHARE_MAX} of its hover)"))
        joined = self.links.join(P, T)
        if joined is None:
            return f"a leg of the single flight's tour has no way round the obstacles{also}"
        JP, JT = joined
        # the hover points all fit (above): a corner the tour turns at round an obstacle
        # (no hover) can still lie beyond every sortie's reach, and the split needs it flown
        joined_room = solo_room(st, self.links, JP)
        cut_off = np.flatnonzero(joined_room <= 0.0)
        if len(cut_off):
            i = int(cut_off[0])
            return (f"the single flight's tour turns round an obstacle at ({JP[i, 0]:.0f}, "
                    f"{JP[i, 1]:.0f}), a corner no sortie from any depot reaches and comes "
                    f"back from on one battery{also}; "
                    + self._advice(JP[i], 0.0, " (no hover)"))
        shares = solo_sorties(st, joined_room, JT)
        need, _, _ = solo_need(st, self.links, JP, JT / shares)
        i = int(np.argmax(need))
        what = "hover point" if JT[i] > 0.0 else "corner"
        shared = f" (its hover shared among {shares[i]:.0f})" if shares[i] > 1 else ""
        first = " or ".join(f"'{st.depot_names[d]}'" for d in st.start_depots)
        return (f"the single flight's tour cannot be cut into sorties that fit the battery "
                f"among {counted(st.uavs, 'vehicle')}, each taking off where "
                f"its last sortie landed, the first at depot {first}{also}; every point of the "
                f"tour fits a sortie of its own (the heaviest, the {what} at ({JP[i, 0]:.0f}, "
                f"{JP[i, 1]:.0f}){shared}, needs {need[i]:.2f} Wh of the {st.usable_wh:.2f} "
                "Wh usable), so what fails is getting a vehicle to the depots those sorties "
                "leave from: more vehicles (fleet.uavs), more depots or depots nearer the "
                "sensors and one another (fleet.depots), or a larger battery "
                "(uav.battery.energy_wh or uav.endurance_s)")

    def enough_battery(self, single: tuple[np.ndarray, np.ndarray]) -> tuple[float, int] | None:
        """A battery that plans this map: a whole `uav.endurance_s` at which the single flight's
        tour `single` splits into sorties that fit (`split`, as route first, cluster second
        cuts it: searched from the depots with no allowance for the pads and with the full
        one, the first and last `plan_fleet` plans with), and the same battery as
        `uav.battery.energy_wh` rounded up to 0.01 Wh (which splits it too). The single flight
        does not depend on the battery, so a plan with the same seed and budget on that
        battery finds this tour and this split of it, and its other start and rounds only keep
        a better plan: the battery suffices. It is not the least (another tour may need less).

        Searched on a grid that does not depend on the map's battery, so maps that differ only
        in it are told the same: the first power of two seconds above the map's endurance at
        which the tour splits, P, then the multiples of P / `ENOUGH_STEPS` above the last power
        that did not (and above the map's endurance), the first that splits.

        Args:
            single: the single flight's hover points (n, 2) m and times (n,) s.

        Returns:
            (Wh, seconds), or None: no battery (or no finite one), or no endurance up to the
            largest `uav.endurance_s` (86,400 s) splits the tour.

        Cost: at most log2(86,400) + `ENOUGH_STEPS` splits, each `split`'s (O(n x L x D^2)
        and an LP across sorties), twice as many with pads (tens of ms each on L01's tour).
        """
        import copy

        if not np.isfinite(self.st.usable_wh) or not len(single[0]):
            return None
        reserve = float(self.m.battery_reserve)
        full = FleetSettings.from_map(self.m, self.st.goal, self.uavs).pad_wh
        allowances = sorted({0.0, float(full)})
        top = ENDURANCE_MAX_S

        def splits(battery_wh: float) -> bool:
            usable = E.usable_energy_wh(battery_wh, reserve)
            trial = copy.copy(self)  # the same links and problem, another battery
            for pad in allowances:
                trial.st = replace(self.st, usable_wh=usable, pad_wh=pad)
                if trial.split(*single) is None:
                    return False
            return True

        def battery(seconds: int) -> float:
            return float(E.hover_energy_wh(seconds, self.st.power))

        have = int(np.floor(float(E.hover_endurance_s(
            E.battery_for_usable_wh(self.st.usable_wh, reserve), self.st.power))))  # fmt: skip
        below, power = have, 1
        while power <= have:
            power *= 2
        while not splits(battery(min(power, top))):
            if power >= top:
                return None
            below, power = max(below, power), 2 * power
        power = min(power, top)
        step = max(1, power // ENOUGH_STEPS)
        for seconds in [*range(step * (below // step + 1), power, step), power]:
            wh = rounded_up(battery(seconds), 2)
            if (seconds == power or splits(battery(seconds))) and splits(wh):
                return wh, seconds
        return None

    def _advice(self, p: np.ndarray, hover_s: float, how: str) -> str:
        """What the battery gives against what a sortie to `p` needs, and what to change: the
        usable energy (battery less reserve) and the take-off and landing's share of it; the
        least usable energy a sortie of p alone needs (`split.solo_need`: from its best
        depots, with `hover_s` of hover; `how` says which), and a larger battery or a depot
        nearer to p. No battery is named here: the battery that gives that one sortie is
        neither enough for a plan (the other sorties and the flights between depots may need
        more) nor needed by one (the split moves and shares the point: a smaller one may
        plan), and `why_not` ends with a battery that plans (`enough_battery`).

        Args:
            p: (2,) the point, m (planning map).
            hover_s: seconds of hover the sortie takes there.
            how: words after "a sortie to it alone" (e.g. " (no hover)").

        Returns:
            One clause, no trailing punctuation.
        """
        st = self.st
        need, a, b = solo_need(st, self.links, np.asarray(p, dtype=float)[None], [hover_s])
        reserve = float(self.m.battery_reserve)
        full = E.battery_for_usable_wh(st.usable_wh, reserve)
        have = (f"a sortie has {st.usable_wh:.2f} Wh usable (the battery's {full:.2f} Wh less "
                f"its {100 * reserve:g} % reserve), the take-off and landing alone "
                f"{st.vertical_wh:.2f} Wh of it")
        if not np.isfinite(need[0]):
            return f"{have}: a depot with a way to it (fleet.depots)"
        names = st.depot_names
        via = (f"depot '{names[a[0]]}' and back" if a[0] == b[0]
               else f"depot '{names[a[0]]}' to depot '{names[b[0]]}'")
        return (f"{have}, and a sortie to it alone{how} needs {need[0]:.2f} Wh (from {via}): "
                f"a larger battery, or a depot nearer to ({p[0]:.0f}, {p[1]:.0f}) "
                "(fleet.depots)")

    def cluster_first(self) -> FleetPlan | None:
        """Step 3: per depot a tour of its nearest sensors, the tours joined and split."""
        st = self.st
        S = self.model.sensors
        req = self.model.required
        dist = np.hypot(
            S[:, None, 0] - st.depots[None, :, 0], S[:, None, 1] - st.depots[None, :, 1]
        )
        owner = np.argmin(dist, axis=1)
        used = [d for d in range(len(st.depots)) if np.any((owner == d) & (req > 0))]
        if not used:
            return None
        # depots in nearest-neighbour order from the first start depot with sensors, else the
        # first start depot's nearest
        first = next((d for d in st.start_depots if d in used), None)
        if first is None:
            s0 = st.depots[st.start_depots[0]]
            first = min(used, key=lambda d: float(np.hypot(*(st.depots[d] - s0))))
        order = [first]
        left = [d for d in used if d != first]
        while left:
            here = st.depots[order[-1]]
            nxt = min(left, key=lambda d: float(np.hypot(*(st.depots[d] - here))))
            order.append(nxt)
            left.remove(nxt)
        P, T = [], []
        for k, d in enumerate(order):
            r = np.where(owner == d, req, 0.0)
            got = self.sub(st.depots[d], st.depots[d], r, _seed(self.config.seed, 1, k))
            if got is None:
                return None
            P.append(got[0])
            T.append(got[1])
        return self.split(np.vstack(P), np.concatenate(T))

    def replan(self, plan: FleetPlan, rnd: int) -> FleetPlan | None:
        """Each sortie planned again for its share of the data (module docstring, 4)."""
        st = self.st
        shares = collected_by_sortie(plan, self.model)
        req = self.model.required
        vs: list[list[Sortie]] = []
        k = 0
        changed = False
        for vsort in plan.vehicles:
            row = []
            for s in vsort:
                share = np.where(shares[k] > 1e-9 * np.maximum(req, 1.0), shares[k], 0.0)
                share = np.minimum(share, req)
                got = self.sub(
                    st.depots[s.start], st.depots[s.end], share, _seed(self.config.seed, 2, rnd, k)
                )
                k += 1
                if got is not None:
                    joined = self.links.join(*got)
                    cand = None
                    if joined is not None:
                        cand = Sortie(s.start, s.end, *joined)
                        ok = cand.f(st) < s.f(st) - 1e-9 and cand.energy(st) <= st.budget_wh(
                            len(cand.points)
                        )
                        if not ok:
                            cand = None
                    if cand is not None:
                        row.append(cand)
                        changed = True
                        continue
                row.append(s)
            vs.append(row)
        return self.lp(plan.replace(vs)) if changed else None

    def resplit(self, plan: FleetPlan) -> FleetPlan | None:
        """The vehicles' sorties joined into one tour (hover points only, vehicle by vehicle)
        and split again, in both directions: the better split."""
        pts = [s.points[s.times > 0] for s in plan.sorties]
        tms = [s.times[s.times > 0] for s in plan.sorties]
        if not pts:
            return None
        P, T = np.vstack(pts), np.concatenate(tms)
        out = [p for p in (self.split(P, T), self.split(P[::-1], T[::-1])) if p is not None]
        return min(out, key=lambda p: p.objective()) if out else None

    def merge(self, plan: FleetPlan, rnd: int) -> FleetPlan | None:
        """Two consecutive sorties of a vehicle planned again by the pipeline as one, from
        the first's depot to the second's, for both shares of the data (a swap and a landing
        saved when it fits the battery); the best such merge by the objective, or None."""
        st = self.st
        shares = collected_by_sortie(plan, self.model)
        req = self.model.required
        best = None
        k0 = 0
        for v, vs in enumerate(plan.vehicles):
            for k in range(len(vs) - 1):
                a, b = vs[k], vs[k + 1]
                share = np.minimum(shares[k0 + k] + shares[k0 + k + 1], req)
                share = np.where(share > 1e-9 * np.maximum(req, 1.0), share, 0.0)
                got = self.sub(
                    st.depots[a.start],
                    st.depots[b.end],
                    share,
                    _seed(self.config.seed, 3, rnd, k0 + k),
                )
                if got is None:
                    continue
                joined = self.links.join(*got)
                if joined is None:
                    continue
                one = Sortie(a.start, b.end, *joined)
                if one.energy(st) > st.budget_wh(len(one.points)):
                    continue
                rows = [list(x) for x in plan.vehicles]
                rows[v][k : k + 2] = [one]
                trial = self.lp(plan.replace(rows))
                if trial is not None and (best is None or trial.objective() < best.objective()):
                    best = trial
            k0 += len(vs)
        return best if best is not None and best.objective() < plan.objective() else None

    def _tour_cost(
        self, P: np.ndarray, T: np.ndarray, starts: tuple[int, ...]
    ) -> tuple[float, list[Sortie] | None]:
        """A vehicle's tour (hover points P, times T) joined and split: (its cost, sorties)."""
        st = self.st
        joined = self.links.join(P, T)
        if joined is None:
            return np.inf, None
        ss = split_tour(st, self.links, *joined, starts=starts)
        if ss is None:
            return np.inf, None
        each = [s.f(st) if st.goal == "total" else s.duration(st) for s in ss]
        return sum(each) + st.swap_s * (len(ss) - 1), ss

    def retour(self, plan: FleetPlan, rnd: int) -> FleetPlan | None:
        """Each vehicle's tour of hover points improved by seeded or-opt moves (a segment of
        1-3 points moved up to `TOUR_WINDOW` places, as it is or reversed), each scored by the
        optimal split of the changed tour (route first, cluster second with the tour itself
        searched: Prins 2004's evaluation of a giant tour by its split); at most
        `TOUR_TRIALS` moves per vehicle. The new plan, LP'd, or None when nothing improved."""
        rng = stream_rng(self.config.seed, "fleet", 4, rnd)
        rows = []
        changed = False
        for vs in plan.vehicles:
            P = np.vstack([s.points[s.times > 0] for s in vs])
            T = np.concatenate([s.times[s.times > 0] for s in vs])
            n = len(P)
            starts = (vs[0].start,) if len(plan.vehicles) > 1 else self.st.start_depots
            cost, best = self._tour_cost(P, T, starts)
            order = np.arange(n)
            for _ in range(TOUR_TRIALS if n >= 3 else 0):
                k = int(rng.integers(1, 4))
                i = int(rng.integers(0, max(n - k + 1, 1)))
                seg = order[i : i + k]
                rest = np.concatenate([order[:i], order[i + k :]])
                j = int(np.clip(i + rng.integers(-TOUR_WINDOW, TOUR_WINDOW + 1), 0, len(rest)))
                if j == i:
                    continue
                if rng.random() < 0.5:
                    seg = seg[::-1]
                trial = np.concatenate([rest[:j], seg, rest[j:]])
                c, ss = self._tour_cost(P[trial], T[trial], starts)
                if c < cost - 1e-9:
                    cost, best, order, changed = c, ss, trial, True
            rows.append(best if best is not None else list(vs))
        return self.lp(plan.replace(rows)) if changed else None

    def eliminate(self, plan: FleetPlan) -> FleetPlan | None:
        """The sorties of least energy, one at a time (at most 3), removed: each of their hover
        points put at its cheapest insertion into the sortie that still fits it (with the
        current hover times; else the cheapest of all), the LP across sorties then deciding;
        the first removal that improves the objective (a swap saved), else None."""
        st = self.st
        flat = [(v, k) for v in range(len(plan.vehicles)) for k in range(len(plan.vehicles[v]))]
        if len(flat) < 2:
            return None
        order = sorted(flat, key=lambda vk: plan.vehicles[vk[0]][vk[1]].energy(st))
        for va, ka in order[:3]:
            gone = plan.vehicles[va][ka]
            vs = [list(v) for v in plan.vehicles]
            vs[va].pop(ka)
            ok = True
            for i in np.flatnonzero(gone.times > 0):
                p, t = gone.points[i], gone.times[i]
                best_fit, best_any = None, None
                for vb in range(len(vs)):
                    for kb, dst in enumerate(vs[vb]):
                        inserted = self._insert(dst, p, t)
                        if inserted is None:
                            continue
                        added, new = inserted
                        key = (added, vb, kb)
                        if best_any is None or key < best_any[0]:
                            best_any = (key, new)
                        if new.energy(st) <= st.budget_wh(len(new.points)) and (
                            best_fit is None or key < best_fit[0]
                        ):
                            best_fit = (key, new)
                pick = best_fit or best_any
                if pick is None:
                    ok = False
                    break
                (_, vb, kb), new = pick
                vs[vb][kb] = new
            if not ok:
                continue
            trial = self.lp(plan.replace([v for v in vs if v]))
            if trial is not None and trial.objective() < plan.objective():
                return trial
        return None

    def _insert(self, dst: Sortie, p: np.ndarray, t: float) -> tuple[float, Sortie] | None:
        """`dst` with hover point `p` (`t` s) at its cheapest place (the least added length of
        its depot-to-depot path) and that added length (m); None when either new leg is
        blocked. O(points of dst) plus two leg checks."""
        path = dst.path(self.st)
        gain = (
            np.hypot(*(path[:-1] - p).T)
            + np.hypot(*(path[1:] - p).T)
            - np.hypot(*np.diff(path, axis=0).T)
        )
        pos = int(np.argmin(gain))
        legs = self.links.clear(np.vstack([path[pos], p]), np.vstack([p, path[pos + 1]]))
        if not bool(np.all(legs)):
            return None
        new = Sortie(dst.start, dst.end, np.insert(dst.points, pos, p, axis=0),
                     np.insert(dst.times, pos, t))  # fmt: skip
        return float(gain[pos]), new

    def transfer(self, plan: FleetPlan) -> FleetPlan:
        """Hover points moved one at a time to their cheapest insertion in a nearby sortie
        (module docstring, 4): a move is kept when the LP across sorties improves the
        objective."""
        st = self.st
        best = plan
        score = best.objective()
        flat = [(v, k) for v in range(len(best.vehicles)) for k in range(len(best.vehicles[v]))]
        a = -1
        while a + 1 < len(flat):  # `flat` is rebuilt, shorter, when a move empties a sortie
            a += 1
            va, ka = flat[a]
            if va >= len(best.vehicles) or ka >= len(best.vehicles[va]):
                continue
            src = best.vehicles[va][ka]
            centre = src.points.mean(axis=0) if len(src.points) else st.depots[src.start]
            others = []
            for vb, kb in flat:
                if (vb, kb) == (va, ka) or vb >= len(best.vehicles) or kb >= len(best.vehicles[vb]):
                    continue
                o = best.vehicles[vb][kb]
                c = o.points.mean(axis=0) if len(o.points) else st.depots[o.start]
                others.append((float(np.hypot(*(c - centre))), vb, kb))
            others.sort()
            for i in np.flatnonzero(src.times > 0):
                if va >= len(best.vehicles) or ka >= len(best.vehicles[va]):
                    break  # a kept move removed this sortie (or the one before it)
                src = best.vehicles[va][ka]
                if i >= len(src.points) or src.times[i] <= 0:
                    continue
                p = src.points[i]
                for _, vb, kb in others[:TRANSFER_NEIGHBOURS]:
                    inserted = self._insert(best.vehicles[vb][kb], p, src.times[i])
                    if inserted is None:
                        continue
                    new_dst = inserted[1]
                    keep = np.ones(len(src.points), dtype=bool)
                    keep[i] = False
                    new_src = Sortie(src.start, src.end, src.points[keep], src.times[keep])
                    if len(new_src.points) and not bool(
                        np.all(self.links.clear(new_src.path(st)[:-1], new_src.path(st)[1:]))
                    ):
                        continue
                    vs = [list(v) for v in best.vehicles]
                    vs[va][ka] = new_src
                    vs[vb][kb] = new_dst
                    if not np.any(new_src.times > 0):
                        vs[va].pop(ka)  # an empty sortie is no sortie (its swap saved)
                    trial = self.lp(best.replace([v for v in vs if v]))
                    if trial is not None and trial.objective() < score:
                        best, score = trial, trial.objective()
                        flat = [
                            (v, k)
                            for v in range(len(best.vehicles))
                            for k in range(len(best.vehicles[v]))
                        ]
                        break
        return best


def on_pads(plan: FleetPlan, links: Links) -> FleetPlan:
    """The plan flown from each vehicle's own pads (`FleetSettings.pads`; at each depot the
    vehicles using it take its pads in the order of their numbers,
    `planner_core.model.pads.pad_ranks`): each sortie takes off from and lands at its
    vehicle's pad at its depots, by the cheapest clear way of four (straight to the first
    point or through a 0-second corner at the depot, likewise back), its hover times kept.
    With the full `FleetSettings.pad_wh` kept back in the search, which pays for the dearest
    of the four (the legs from the pads to the depots and the corners there), every sortie
    keeps within its battery; with less, `_finish` re-times what does not. Cost: O(points)
    per sortie (its legs' clearance and energy, four times).

    Args:
        plan: a plan searched from the depots (settings with their pads and `pad_wh`).
        links: the planning map's `Links` (obstacle clearance of a leg).

    Returns:
        The plan on its pads, with settings `FleetSettings.on_pads` (the same plan when the
        fleet has one vehicle).

    Raises:
        RuntimeError: a sortie over its energy on its pads although the search kept
            `pad_wh` back for them (the allowance broken: a bug). Searched without it
            (`pad_wh` 0) a sortie may end over its energy: the caller re-times or re-plans.
    """
    from planner_core.model.pads import pad_ranks

    st = plan.settings
    if st.pads is None:
        return plan
    flown = st.on_pads()
    rank = pad_ranks((v, st.depot_names[d]) for v, vs in enumerate(plan.vehicles)
                     for s in vs for d in (s.start, s.end))  # fmt: skip
    vehicles = []
    for v, vs in enumerate(plan.vehicles):
        row = []
        for s in vs:
            ranks = (rank[(v, st.depot_names[s.start])], rank[(v, st.depot_names[s.end])])
            best = None
            for via_a in (False, True):
                for via_b in (False, True):
                    pts, ts = s.points, s.times
                    if via_a:
                        pts = np.vstack([st.depots[s.start], pts])
                        ts = np.concatenate([[0.0], ts])
                    if via_b:
                        pts = np.vstack([pts, st.depots[s.end]])
                        ts = np.concatenate([ts, [0.0]])
                    cand = Sortie(s.start, s.end, pts, ts, ranks)
                    path = cand.path(flown)
                    if not bool(np.all(links.clear(path[:-1], path[1:]))):
                        continue
                    e = cand.energy(flown) + flown._kept_wh(len(pts))
                    if best is None or e < best[0] - 1e-12:
                        best = (e, cand)
            if best is None:  # the depot corners at both ends are always clear: not reached
                raise RuntimeError(f"vehicle {v + 1}: no clear way from its pad")
            row.append(best[1])
        vehicles.append(row)
    out = FleetPlan(flown, vehicles, plan.evaluations, plan.notes)
    if st.pad_wh > 0.0 and not out.energy_ok():
        over = [k for k, x in enumerate(out.sorties) if x.energy(flown) > flown.usable_wh]
        raise RuntimeError(f"sorties {over} exceed the battery on their pads (pad_wh "
                           f"{st.pad_wh:.3f} Wh kept back)")  # fmt: skip
    return out


class _OffPads(Exception):
    """A plan searched with less than the pads' full allowance that no re-timing fits on its
    pads; `excess` the most Wh a sortie of it is over its battery there."""

    def __init__(self, excess: float) -> None:
        super().__init__(f"{excess:.4f} Wh over on the pads")
        self.excess = float(excess)


def _next_allowance(m: Any, goal: str | None, tried: list[tuple[float, float]],
                    uavs: int | None = None) -> float | None:
    """The pads' allowance (Wh kept back per sortie) to plan with next (`plan_fleet`,
    `route_first`): none first (a vehicle alone at its depots stands on them; a little slack
    often fits the others' pads); after a plan that did not fit its pads, a half again what
    its worst sortie was over there; then the full allowance (`FleetSettings.pad_wh`, which
    always fits); None after that.

    Args:
        m: the map.
        goal: the objective (for the settings).
        tried: (allowance planned with, Wh its worst sortie was over on its pads) so far.
        uavs: the vehicles the plan may fly (`FleetSettings.from_map`).

    Returns:
        Wh, or None when the full allowance was tried.
    """
    full = FleetSettings.from_map(m, goal, uavs).pad_wh
    if not tried:
        return 0.0
    last, excess = tried[-1]
    if last >= full:
        return None
    if len(tried) == 1:
        return min(full, last + 1.5 * excess)
    return full


def _finish(pl: _Planner, plan: FleetPlan, notes: list[str]) -> FleetPlan:
    """The plan on its vehicles' pads (`on_pads`), its notes and counts. Searched without the
    pads' allowance, a sortie the pads put over its battery has the hover times of the whole
    plan re-solved by the LP across sorties on the pads' routes (a sensor's data moved to
    other sorties); when that fails too, `_OffPads` (the caller plans again keeping the
    allowance back, which always fits)."""
    flown = on_pads(plan, pl.links)
    if not flown.energy_ok():
        st = flown.settings
        excess = max(x.energy(st) - st.usable_wh for x in flown.sorties)
        flown = pl.lp(flown)
        if flown is None:
            raise _OffPads(excess)
        notes = notes + ["hover times re-solved on the vehicles' pads"]
    return flown.replace(
        flown.vehicles,
        evaluations=pl.evaluations,
        notes=tuple(notes + [f"{pl.lps} LPs across sorties"]),
    )


def route_first(
    m: Any, config: Any, *, goal: str | None = None, sortie_budget: int = SORTIE_BUDGET,
    uavs: int | None = None,
) -> FleetResult:
    """Route first, cluster second (the benchmark's peer; module docstring, steps 1-2): the
    single-flight plan's tour cut into battery-sized sorties with returns to the depots,
    shared among the vehicles, hover times re-solved by the LP across sorties.

    Args:
        m: a loaded map with a battery (`planner_core.model.mapio.Map`).
        config: the single flight's `planner_core.pipeline.PlanConfig` (seed, budget, ...).
        goal: "total" or "makespan" (default the map's `objective.goal`).
        sortie_budget: unused here (the peer plans no sortie on its own); kept so both
            planners take the same arguments.
        uavs: the vehicles it may fly, at most the map's `fleet.uavs` (None: all).

    Returns:
        The `FleetResult` (its `peer` is None).

    Raises:
        ValueError: the map has no battery; or no split fits the battery (a point no depot
            reaches and returns from with its hover time), naming the problem.
    """
    tried: list[tuple[float, float]] = []
    while (pad_wh := _next_allowance(m, goal, tried, uavs)) is not None:
        pl = _Planner(m, config, goal, sortie_budget, pad_wh=pad_wh, uavs=uavs)
        single = pl.single()
        if single is None:
            raise ValueError("plan: the single flight found no feasible plan to cut into "
                             "sorties")  # fmt: skip
        plan = pl.split(*single)
        if plan is None:
            raise ValueError("uav.battery: the single flight cannot be cut into sorties that "
                             f"fit the battery from the depots: {pl.why_not(single, False)}")
        try:
            return FleetResult(_finish(pl, plan, ["route first, cluster second"]), single, None,
                               pl.lps)  # fmt: skip
        except _OffPads as off:
            tried.append((pl.st.pad_wh, off.excess))
    raise AssertionError("the full allowance always fits")


def plan_fleet(
    m: Any,
    config: Any,
    *,
    goal: str | None = None,
    sortie_budget: int = SORTIE_BUDGET,
    rounds: int = ROUNDS,
    progress: Callable[..., None] | None = None,
    uavs: int | None = None,
) -> FleetResult:
    """The sortie planner (module docstring): sorties and vehicles for a map with a battery.

    Args:
        m: a loaded map with a battery (`planner_core.model.mapio.Map`).
        config: the single flight's `planner_core.pipeline.PlanConfig` (seed, budget, ...);
            the sub-runs use its settings with their own seeds and `sortie_budget`.
        goal: "total" or "makespan" (default the map's `objective.goal`).
        sortie_budget: evaluations of each pipeline run on one sortie's or depot's sensors.
        rounds: improving rounds at most (0: the better start only).
        uavs: the vehicles the plan may fly, at most the map's `fleet.uavs` (None: all of
            them), each on its pad of the map's layout for the whole fleet (what its files
            and `verify` give it; `lamde_mission.plan_fleet` plans fewer vehicles where their
            staggered launches make the fleet finish sooner).
        progress: called with a line saying what the search does next, at each phase (the
            single flight, the starts, each round, the pads) and, with `step=True`, at each
            move of a round (a terminal shows those; a log needs only the phases); None:
            nothing said.

    Returns:
        The `FleetResult`: the plan (planning-map coordinates; hover times from the LP across
        sorties; each vehicle's sorties flown from its own pads, `on_pads`, searched first
        with no allowance for them and again with more only where they do not fit), the
        single flight, the route-first peer it started from.

    Raises:
        ValueError: one line: a sensor whose data needs more sorties than the planner shares
            one sensor's data among (`split.SHARE_MAX`; `lamde-mission check` says so too:
            SORTIE_LIMIT), or a battery the take-off and landing alone use up
            (ENERGY_VERTICAL), refused before any work; or no plan of sorties found that fits the
            battery, saying what failed (`_Planner.why_not`).
    """
    from planner_core.model.diagnose import fleet_findings

    # refused before any work, in `check`'s words: the planner's own limit, or a battery the
    # take-off and landing alone use up (no sortie of any plan can fly)
    limit = [f.message for f in fleet_findings(m)
             if f.kind in ("SORTIE_LIMIT", "ENERGY_VERTICAL", "PADS")]
    if limit:
        raise ValueError(limit[0])
    # searched from the depots as they stand, then flown from the vehicles' pads (`_finish`);
    # only when no re-timing fits them on their pads, planned again with the pads' allowance
    # kept back from every sortie's battery (`FleetSettings.pad_wh`), which always fits
    tried: list[tuple[float, float]] = []
    while (pad_wh := _next_allowance(m, goal, tried, uavs)) is not None:
        try:
            return _plan_fleet(m, config, goal, sortie_budget, rounds, pad_wh=pad_wh,
                               progress=progress, uavs=uavs)
        except _OffPads as off:
            tried.append((pad_wh, off.excess))
            if progress is not None:
                progress(f"planned again: the pads put a sortie {off.excess:.2f} Wh over its "
                         "battery")
    raise AssertionError("the full allowance always fits")


def _plan_fleet(m: Any, config: Any, goal: str | None, sortie_budget: int, rounds: int, *,
                pad_wh: float, progress: Callable[..., None] | None = None,
                uavs: int | None = None) -> FleetResult:
    """`plan_fleet`'s search with `pad_wh` kept back for the pads (`_Planner`), flying at
    most `uavs` vehicles (None: the map's)."""
    def say(line: str, step: bool = False) -> None:
        if progress is not None:
            progress(line, step=step)

    pl = _Planner(m, config, goal, sortie_budget, pad_wh=pad_wh, uavs=uavs)
    say(f"the single flight ({config.budget:,} evaluations)")
    single = pl.single()
    notes: list[str] = []
    say("cutting it into sorties (route first, cluster second)")
    peer = pl.split(*single) if single is not None else None
    best = peer
    say(f"cluster first (pipeline runs of {sortie_budget:,} evaluations)")
    cf = pl.cluster_first()
    if cf is not None and (best is None or cf.objective() < best.objective()):
        best = cf
        notes.append("start: cluster first")
    elif best is not None:
        notes.append("start: route first, cluster second")
    if best is None:
        raise ValueError("uav.battery: no plan of sorties found that fits the battery from the "
                         f"depots: {pl.why_not(single, True)}")
    try:
        peer_plan = (_finish(pl, peer, ["route first, cluster second"]) if peer is not None
                     else None)  # fmt: skip
    except _OffPads:  # the peer on its own, which keeps the allowance where it must
        peer_plan = route_first(m, config, goal=goal, sortie_budget=sortie_budget,
                                uavs=uavs).plan
    for rnd in range(int(rounds)):
        before = best.objective()
        say(f"round {rnd + 1} of at most {int(rounds)} (objective {before[0]:,.1f}, "
            f"{len(best.sorties)} sorties)")
        for step in ("replan", "merge", "eliminate", "transfer", "resplit", "retour"):
            say(f"round {rnd + 1}: {step} (objective {best.objective()[0]:,.1f})", step=True)
            if step == "replan":
                cand = pl.replan(best, rnd)
            elif step == "retour":
                cand = pl.retour(best, rnd)
            elif step == "merge":
                cand = pl.merge(best, rnd)
            elif step == "eliminate":
                cand = pl.eliminate(best)
            elif step == "transfer":
                cand = pl.transfer(best)
            else:
                cand = pl.resplit(best)
            if cand is not None and cand.objective() < best.objective():
                notes.append(
                    f"round {rnd + 1} {step}: {best.objective()[0]:.2f} -> "
                    f"{cand.objective()[0]:.2f}"
                )
                best = cand
        if not best.objective() < before:
            break
    say("each vehicle's sorties flown from its pads")
    done = _finish(pl, best, notes)
    say(f"done: objective {done.objective()[0]:,.1f} from the pads (the summary's figures are "
        "the simulator's, replayed on the stored missions)")
    return FleetResult(
        done,
        single if single is not None else (np.zeros((0, 2)), np.zeros(0)),
        peer_plan,
        pl.lps,
    )
