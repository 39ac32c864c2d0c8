"""Verdicts on a replayed mission: the paper's constraints C1..C5, each with a margin.

With `radio.access` "scheduled" C3 judges the replay's allocation of the shared bandwidth (sum_j
D_ij <= R_lambda T_i, D_ij <= R_ij T_i) and C4 the data it allocates.

A margin is the worst slack in the constraint's unit: >= 0 when it holds, negative by how much it is
broken. Tolerances: `REL_TOL` (relative, on hover times, rate sums and collected data) is 1e-6,
about eight float32 steps (float32's relative precision is 2**-23 ~ 1.2e-7): a mission passes
through MAVLink's float32 parameters, so a finer tolerance would judge noise the file cannot carry.
It is no safety margin: a plan on the boundary that loses more than that when stored fails, which is
why missions are made storable before they are written (`lamde_mission.storage`). `GEOM_TOL` metres
for positions and overlap lengths. One extra verdict, ENDS, checks that the mission takes off at the
map's start and comes to rest at its end (the paper's fixed p_0 and p_{I+1}; a mission with neither
LAND nor RETURN_TO_LAUNCH fails: it holds at its last stop until a failsafe), and ALT that every
stop and the take-off are above the ground at home (the map is flat: a stop at or below 0 m is in
the ground). Two more judge the map's `safety` margins on the flown mission: CLEAR (every leg at
least `safety.clearance` from every obstacle, measured with shapely; near the start or end point the
clearance in force is what the map leaves there) and MARGIN (every sensor's collected data at least
(1 + `safety.data_margin`) x its requirement); `Verdicts.data_margins` holds the real margin per
sensor and `Verdicts.clearance` the real clearance. On a map with a battery (`uav.battery` or
`uav.endurance_s`; issue 33) one more, ENERGY, judges the mission as one sortie: the energy the sim
computes on its own (`sim.energy.mission_energy`) at most the usable energy, battery x (1 -
reserve); a map without a battery gets no ENERGY verdict.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import shapely

from planner_core.defaults import L_VIO_TOL
from sim import energy as sim_energy
from sim.mission import CMD
from sim.obstacles import (
    distances_to,
    flown_legs,
    leg_overlaps,
    obstacle_shapes,
    overlap_totals,
    points_inside,
)
from sim.replay import Timeline

__all__ = [
    "Verdict", "Verdicts", "verify", "c4_verdict", "margin_verdict", "REL_TOL", "GEOM_TOL",
    "C5_TOL", "ENDS_TOL", "CLEAR_TOL",
]  # fmt: skip

#: relative tolerance on hover times (C2), rate sums (C3) and collected data (C4): about
#: eight float32 steps (2**-23 ~ 1.2e-7 each), no finer than what a mission file carries
REL_TOL = 1e-6
#: metres: hover points on the area's edge (C1)
GEOM_TOL = 1e-6
#: metres: overlap length counted as zero (C5); the planner's own tolerance, so a positive
#: overlap beyond float rounding fails (paper C5; `planner_core.defaults.L_VIO_TOL`)
C5_TOL = L_VIO_TOL
#: metres: how far below the map's `safety.clearance` a stored mission may pass an obstacle (its
#: points lie on MAVLink's 1e-7 degree grid, ~1.1 cm; the planner pads the clearance by 5 cm)
CLEAR_TOL = 0.02
#: metres: take-off / final stop within this of the map's start / end (float32 MAVLink
#: parameters carry latitude to ~1 m, int32 MISSION_ITEM_INT to ~1 cm)
ENDS_TOL = 0.05


@dataclass(frozen=True)
class Verdict:
    """One constraint's outcome: passed, worst margin (unit), and where the worst case is."""

    name: str
    title: str
    passed: bool
    margin: float
    unit: str
    detail: str

    def to_dict(self) -> dict[str, Any]:
        """The verdict as a JSON-ready dict.

        Returns:
            The fields by name; a non-finite margin as None.
        """
        d = asdict(self)
        d["margin"] = self.margin if math.isfinite(self.margin) else None
        return d


@dataclass(frozen=True)
class Verdicts:
    """All verdicts of one replay (C1..C5, CLEAR, MARGIN, ENDS, ALT, and ENERGY on a map with a
    battery), with the totals they were judged on: t_fly, t_hover and f in s."""

    items: tuple[Verdict, ...]
    t_fly: float
    t_hover: float
    f: float
    data_margins: dict[str, float] = field(default_factory=dict)
    clearance: float = math.inf
    #: maps with a battery only (else None): the mission's energy (Wh, the sim's own), the
    #: full battery (Wh) and what the mission may spend, battery x (1 - reserve)
    energy_wh: float | None = None
    battery_wh: float | None = None
    usable_wh: float | None = None

    @property
    def reserve_left_wh(self) -> float | None:
        """Energy left in the battery at landing (Wh): battery - energy, the reserve included.

        Returns:
            battery_wh - energy_wh, Wh; None without a battery.
        """
        if self.energy_wh is None or self.battery_wh is None:
            return None
        return self.battery_wh - self.energy_wh

    @property
    def above_reserve_wh(self) -> float | None:
        """Energy left at landing above the reserve (Wh): usable - energy, the slack ENERGY
        judges.

        Returns:
            usable_wh - energy_wh, Wh (negative: into the reserve); None without a battery.
        """
        if self.energy_wh is None or self.usable_wh is None:
            return None
        return self.usable_wh - self.energy_wh

    @property
    def passed(self) -> bool:
        """Whether every verdict passed.

        Returns:
            True when each of `items` passed (True for no verdicts).
        """
        return all(v.passed for v in self.items)

    @property
    def failed(self) -> list[str]:
        """Names of the verdicts that failed.

        Returns:
            Their names ("C4", "ENERGY", ...), in the order of `items`.
        """
        return [v.name for v in self.items if not v.passed]

    def __getitem__(self, name: str) -> Verdict:
        """The verdict named `name` ("C1", "ENERGY", ...).

        Raises:
            KeyError: no verdict of that name (ENERGY on a map without a battery).
        """
        for v in self.items:
            if v.name == name:
                return v
        raise KeyError(name)

    def __iter__(self) -> Iterator[Verdict]:
        return iter(self.items)

    def table(self) -> str:
        """A fixed-width text table, one row a verdict: check, PASS/FAIL, margin, detail.

        Returns:
            The table's lines joined by newlines (a header, a rule, then the rows).
        """
        rows = [("check", "result", "margin", "detail")]
        for v in self.items:
            m = f"{v.margin:.6g} {v.unit}" if math.isfinite(v.margin) else "-"
            rows.append((f"{v.name} {v.title}", "PASS" if v.passed else "FAIL", m, v.detail))
        w = [max(len(r[i]) for r in rows) for i in range(3)]
        lines = [f"{r[0]:<{w[0]}}  {r[1]:<{w[1]}}  {r[2]:>{w[2]}}  {r[3]}".rstrip() for r in rows]
        lines.insert(1, "-" * max(len(s) for s in lines))
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """The verdicts and totals as a JSON-ready dict (the report's `verdicts` block).

        Returns:
            passed, failed, t_fly, t_hover, f (s), clearance_m (None when infinite),
            data_margins (None for a sensor requiring no data) and each verdict's
            `Verdict.to_dict`; on a map with a battery also
            energy_wh, battery_wh, usable_wh, reserve_left_wh and above_reserve_wh (Wh).
        """
        out = {
            "passed": self.passed,
            "failed": self.failed,
            "t_fly": self.t_fly,
            "t_hover": self.t_hover,
            "f": self.f,
            "clearance_m": self.clearance if math.isfinite(self.clearance) else None,
            # a sensor requiring no data has margin +inf: null, as JSON has no infinity
            "data_margins": {k: (v if math.isfinite(v) else None)
                             for k, v in self.data_margins.items()},
            "verdicts": [v.to_dict() for v in self.items],
        }
        if self.energy_wh is not None:  # maps with a battery only: older reports unchanged
            out.update(energy_wh=self.energy_wh, battery_wh=self.battery_wh,
                       usable_wh=self.usable_wh, reserve_left_wh=self.reserve_left_wh,
                       above_reserve_wh=self.above_reserve_wh)
        return out


def c4_verdict(collected: np.ndarray, required: np.ndarray, ids: Any, *,
               title: str = "Q_j >= Q_lambda", prefix: str = "",
               tightest: str = "tightest: sensor") -> Verdict:  # fmt: skip
    """C4, Q_j >= Q_lambda for every sensor, within `REL_TOL` (relative, at least 1 Mbit).

    Args:
        collected: (J,) the data each sensor delivered, Mbit.
        required: (J,) each sensor's requirement Q_lambda, Mbit.
        ids: the J sensor ids, in the same order.
        title: the verdict's title.
        prefix: put before the detail ("over 3 sorties: ").
        tightest: the detail's words before the tightest sensor's id when none is short.

    Returns:
        The C4 verdict: margin min_j (Q_j - Q_lambda) in Mbit; the detail names up to five
        short sensors and the worst, or the tightest one.
    """
    q = collected
    req = required
    slack = q - req
    tol = REL_TOL * np.maximum(req, 1.0)
    short = np.flatnonzero(slack < -tol)
    j = int(np.argmin(slack)) if len(slack) else 0
    if len(short):
        names = ", ".join(f"'{ids[k]}'" for k in short[:5]) + (" ..." if len(short) > 5 else "")
        detail = (f"{prefix}{len(short)} sensor(s) short: {names}; worst '{ids[j]}' "
                  f"{q[j]:.6g} of {req[j]:g} Mbit")  # fmt: skip
    else:
        detail = f"{prefix}{tightest} '{ids[j]}' {q[j]:.6g} of {req[j]:g} Mbit"
    return Verdict("C4", title, not len(short), float(slack[j]), "Mbit", detail)


def margin_verdict(collected: np.ndarray, required: np.ndarray, ids: Any, want: float, *,
                   suffix: str = "") -> tuple[Verdict, np.ndarray]:  # fmt: skip
    """MARGIN: every sensor's data at least (1 + `want`) x its requirement (`safety.data_margin`).

    Args:
        collected: (J,) the data each sensor delivered, Mbit.
        required: (J,) each sensor's requirement, Mbit (a sensor requiring 0 is not judged).
        ids: the J sensor ids, in the same order.
        want: the margin asked, a fraction (0.02: 2 %).
        suffix: put after the title ("data margin >= 2 %").

    Returns:
        The verdict (margin: the tightest sensor's collected / required - 1 - `want`, passing
        down to -`REL_TOL` (1 + `want`); +inf with "no data required") and each sensor's
        collected / required - 1 (J,), +inf where nothing is required.
    """
    title = f"data margin >= {100 * want:g} %{suffix}"
    served = required > 0
    frac = np.where(served, collected / np.where(served, required, 1.0) - 1.0, np.inf)
    if not np.any(served):
        return Verdict("MARGIN", title, True, math.inf, "", "no data required"), frac
    j = int(np.argmin(frac))
    m = float(frac[j] - want)
    ok = m >= -REL_TOL * (1.0 + want)
    side = "over" if frac[j] >= 0 else "below"  # "-80.44 % over" read as a typo
    detail = f"tightest: sensor '{ids[j]}' {100 * abs(frac[j]):.4g} % {side} Q_lambda"
    return Verdict("MARGIN", title, bool(ok), m, "", detail), frac


def _hover_label(i: int, seqs: tuple[int, ...]) -> str:
    return f"hover point {i + 1} (item {seqs[i]})"


#: offenders a C5 detail names of each kind (hover points inside, legs crossing) before
#: "and N more"
NAMED_OFFENDERS = 3


def _leg_label(g: int, timeline: Timeline) -> str:
    """Leg g of the flight (the legs of `timeline.path`, then the RTL return leg) named by
    its items, as verify names them: "take-off -> item 2", "item 2 -> item 3", "item 5 ->
    launch (RTL)"."""
    seqs = timeline.route.seqs
    n_path = len(timeline.path) - 1
    if g >= n_path:
        return f"item {seqs[-1]} -> launch (RTL)"
    return f"{'take-off' if g == 0 else f'item {seqs[g - 1]}'} -> item {seqs[g]}"


def _nearest_leg(paths: list[np.ndarray], shape: Any) -> int:
    """The first flight (an index into the legs of `paths` in order) of the distinct leg
    nearest the shapely geometry `shape` (the first such leg flown on a tie). O(L log L) for L
    legs."""
    legs, _, first = flown_legs(paths)
    d = shapely.distance(shapely.linestrings(legs), shape)
    return int(first[int(np.argmin(d))])


def _more(shown: list[str], total: int) -> str:
    return ", ".join(shown) + (f" and {total - len(shown)} more" if total > len(shown) else "")


def _c5_offenders(timeline: Timeline, legs: list[np.ndarray], obstacles: list[Any]) -> str:
    """The part of a failed C5's detail naming what is at fault, by item as verify names
    items: each hover point inside an obstacle (with its hover time there) and the legs
    crossing, the worst first (most length inside, over all its flights), at most
    `NAMED_OFFENDERS` of each and a count of the rest. One line; empty when nothing is named.
    Time O(L log L + (L + O) log O) for L legs and O obstacles (`leg_overlaps`,
    `points_inside`)."""
    parts = []
    hp, seqs = timeline.hover_points, timeline.hover_seqs
    pi, oi = points_inside(hp, obstacles)
    if len(pi):
        # a DO_JUMP flies a hover item again: each item once, its hover times summed
        at: dict[tuple[int, int], float] = {}
        label: dict[int, str] = {}
        for p, o in zip(pi.tolist(), oi.tolist(), strict=True):
            key = (seqs[p], o)
            at[key] = at.get(key, 0.0) + float(timeline.hover_times[p])
            label.setdefault(seqs[p], _hover_label(p, seqs))
        worst = sorted(at.items(), key=lambda kv: -kv[1])
        shown = [f"{label[s]} inside {obstacles[o].label} for {t:.6g} s"
                 for (s, o), t in worst[:NAMED_OFFENDERS]]
        parts.append("; " + _more(shown, len(worst)))
    first, counts, li, oi, length = leg_overlaps(legs, obstacles, tol=C5_TOL)
    if len(li):
        per_leg = np.zeros(len(first))
        np.add.at(per_leg, li, length * counts[li])
        bad = np.flatnonzero(per_leg > 0)
        bad = bad[np.argsort(-per_leg[bad], kind="stable")]
        shown = []
        for u in bad[:NAMED_OFFENDERS]:
            sel = li == u
            order = np.argsort(-length[sel], kind="stable")
            where = _more([f"{obstacles[o].label} {d * counts[u]:.3g} m" for o, d in
                           zip(oi[sel][order][:NAMED_OFFENDERS], length[sel][order], strict=False)],
                          int(sel.sum()))  # fmt: skip
            times = f", flown {counts[u]} times" if counts[u] > 1 else ""
            shown.append(f"{_leg_label(int(first[u]), timeline)} ({per_leg[u]:.3g} m{times}: "
                         f"{where})")
        parts.append(f"; leg{'s' if len(bad) > 1 else ''} crossing: {_more(shown, len(bad))}")
    return "".join(parts)


def verify(timeline: Timeline, map: Any, *,  # noqa: A002
           end_names: tuple[str, str] = ("start", "end")) -> Verdicts:
    """Judge a replayed mission against the map: C1..C5 of the paper (Sec. 3), CLEAR and
    MARGIN (the map's `safety`), ENDS, ALT (when the route has a stop or a take-off) and, on a
    map with a battery, ENERGY (`sim.energy.mission_energy`); module docstring.

    Args:
        timeline: the replay (`sim.replay.Timeline`).
        map: the loaded map the mission was planned for (area, sensors' required data,
            obstacles, start and end, `safety`, battery).
        end_names: what ENDS's detail calls the map's start and end (a sortie's are the pads of
            its depots: "its pad at 'home'").

    Returns:
        The verdicts in that order, with the replay's totals, each sensor's data margin,
        the real clearance (m) and, with a battery, the energies (Wh).
    """
    spec = map.spec
    hp, ht, seqs = timeline.hover_points, timeline.hover_times, timeline.hover_seqs
    n = len(ht)
    out: list[Verdict] = []

    # C1: hover points inside the area [0, W] x [0, H]
    W, H = spec.area.width, spec.area.height
    if n:
        slack = np.minimum.reduce([hp[:, 0], W - hp[:, 0], hp[:, 1], H - hp[:, 1]])
        i = int(np.argmin(slack))
        m = float(slack[i])
        detail = f"closest to the edge: {_hover_label(i, seqs)}"
        if m < -GEOM_TOL:
            detail = f"{_hover_label(i, seqs)} at ({hp[i, 0]:.1f}, {hp[i, 1]:.1f}) is outside"
        out.append(Verdict("C1", "hover points in area", m >= -GEOM_TOL, m, "m", detail))
    else:
        out.append(Verdict("C1", "hover points in area", True, math.inf, "m", "no hover points"))

    # C2: 0 <= T_i <= T_max
    t_max = spec.uav.max_hover_time
    if n:
        slack = np.minimum(ht, t_max - ht)
        i = int(np.argmin(slack))
        m = float(slack[i])
        ok = m >= -REL_TOL * t_max
        detail = f"tightest: {_hover_label(i, seqs)}, T = {ht[i]:.6g} s of T_max {t_max:g} s"
        out.append(Verdict("C2", "0 <= T <= T_max", bool(ok), m, "s", detail))
    else:
        out.append(Verdict("C2", "0 <= T <= T_max", True, math.inf, "s", "no hover points"))

    # C3: sum_j R_ij <= R_lambda at each hover point; in scheduled access (`radio.access`)
    # the sensors share R_lambda by time slots instead: the allocation's sum_j D_ij <=
    # R_lambda T_i and D_ij <= R_ij T_i (the sim's own LP, `sim.replay.scheduled_allocation`)
    bw = spec.radio.bandwidth
    if timeline.allocation is not None and n:
        D = timeline.allocation
        used = D.sum(axis=1)
        slack = np.where(ht > 0, bw - used / np.where(ht > 0, ht, 1.0), bw)
        over = float(np.max(D - timeline.rates * ht[:, None], initial=0.0))
        i = int(np.argmin(slack))
        m = float(slack[i])
        ok = m >= -REL_TOL * bw and over <= REL_TOL * max(float(D.max(initial=0.0)), 1.0)
        # an allocation that fills a point's bandwidth leaves a rounding residue (-7e-15
        # Mbit/s was printed as a PASS's margin): within the tolerance it is on the limit
        m = max(m, 0.0) if m >= -REL_TOL * bw else m
        detail = (f"scheduled: tightest {_hover_label(i, seqs)}, {bw - m:.6g} of {bw:g} "
                  "Mbit/s shared by time slots")  # fmt: skip
        # the margin is a rate (the bandwidth left at the tightest point), so the formula too
        out.append(Verdict("C3", "sum_j D_ij / T_i <= R_lambda", bool(ok), m, "Mbit/s", detail))
    elif n:
        slack = bw - timeline.rates.sum(axis=1)
        i = int(np.argmin(slack))
        m = float(slack[i])
        ok = m >= -REL_TOL * bw
        detail = f"tightest: {_hover_label(i, seqs)}, {bw - m:.6g} of {bw:g} Mbit/s"
        out.append(Verdict("C3", "sum_j R_ij <= R_lambda", bool(ok), m, "Mbit/s", detail))
    else:
        out.append(
            Verdict("C3", "sum_j R_ij <= R_lambda", True, math.inf, "Mbit/s", "no hover points")
        )

    # C4: Q_j >= Q_lambda for every sensor
    q = timeline.collected
    req = np.asarray(map.required_data, dtype=float)
    ids = timeline.sensor_ids
    out.append(c4_verdict(q, req, ids))

    # C5: L_vio = 0 over the flown horizontal path (and an RTL return leg, if any)
    obstacles = obstacle_shapes(map)
    path = timeline.path
    legs = [path]
    if timeline.return_leg is not None:
        legs.append(timeline.return_leg)
    # each distinct leg against the obstacles near it only (a DO_JUMP loop or a map at the
    # obstacle limit would make a table of every leg against every obstacle too large)
    if not obstacles or not any(len(p) >= 2 for p in legs):
        out.append(Verdict("C5", "L_vio = 0", True, math.inf, "m", "no obstacles"))
    else:
        per_obstacle = overlap_totals(legs, obstacles)
        l_vio = float(per_obstacle.sum())
        if l_vio > C5_TOL:
            hit = np.flatnonzero(per_obstacle > C5_TOL)
            order = hit[np.argsort(-per_obstacle[hit])]
            names = ", ".join(f"{obstacles[k].label} {per_obstacle[k]:.3g} m" for k in order[:4])
            extra = " (includes the RTL return leg)" if timeline.return_leg is not None else ""
            detail = (f"path inside obstacles for {l_vio:.6g} m: {names}{extra}"
                      f"{_c5_offenders(timeline, legs, obstacles)}")  # fmt: skip
            out.append(Verdict("C5", "L_vio = 0", False, -l_vio, "m", detail))
        else:
            # circles exact: from their centre less the radius (`Obstacle.clearance`)
            geoms = np.array([shapely.points(o.circle[:2]) if o.circle is not None else o.shape
                              for o in obstacles], dtype=object)  # fmt: skip
            radii = np.array([o.circle[2] if o.circle is not None else 0.0 for o in obstacles])
            dist = distances_to(legs, geoms) - radii
            k = int(np.argmin(dist))
            detail = f"clearance {float(dist[k]):.3f} m from {obstacles[k].label}"
            out.append(Verdict("C5", "L_vio = 0", True, float(dist[k]), "m", detail))

    # CLEAR and MARGIN: the map's safety margins, measured on the flown mission
    sf = getattr(spec, "safety", None)
    want_c = float(getattr(sf, "clearance", 0.0))
    want_q = float(getattr(sf, "data_margin", 0.0))
    clearance = math.inf
    if obstacles:
        shapes = np.array([o.shape for o in obstacles], dtype=object)
        dist = distances_to(legs, shapes)
        ends = shapely.points([map.start, map.end])
        # near the start or end point the clearance is what the map leaves there
        near = np.min(shapely.distance(ends[:, None], shapes[None, :]), axis=0)
        force = np.minimum(want_c, near)
        k = int(np.argmin(dist - force))
        clearance = float(dist.min())
        m = float(dist[k] - force[k])
        leg = _leg_label(_nearest_leg(legs, shapes[k]), timeline)
        detail = (f"closest {dist[k]:.3f} m from {obstacles[k].label} on the leg {leg} "
                  f"(clearance in force there {force[k]:.3f} m)")  # fmt: skip
        # where the start or end leaves less room, the row says so: the margin is measured
        # against the clearance in force there, not the asked one
        title = f"clearance >= {want_c:g} m" + (
            " (less by the start/end)" if bool(np.any(force < want_c)) else "")
        if -CLEAR_TOL <= m < 0.0:  # a PASS beside a negative margin says why (a reviewer)
            detail += (f"; within the {100 * CLEAR_TOL:g} cm a stored mission may pass inside "
                       "it (positions on the 1e-7 degree grid)")
        out.append(Verdict("CLEAR", title, m >= -CLEAR_TOL, m, "m", detail))
    else:
        out.append(Verdict("CLEAR", f"clearance >= {want_c:g} m", True, math.inf, "m",
                           "no obstacles"))  # fmt: skip
    margin, frac = margin_verdict(q, req, ids, want_q)
    margins = {ids[k]: float(frac[k]) for k in range(len(ids))}
    out.append(margin)

    out.append(_ends_verdict(timeline, map, end_names))

    # ALT: every stop and the take-off above the ground at home (a flat map: the paper's model
    # has no terrain); the LAND item itself comes down
    route = timeline.route
    alts = [(float(z), seq) for z, seq, cmd in zip(route.altitudes, route.seqs, route.commands,
                                                    strict=True) if cmd != CMD.LAND]  # fmt: skip
    if route.takeoff_altitude is not None:
        alts.append((float(route.takeoff_altitude), "take-off"))
    if alts:
        low, where = min(alts, key=lambda a: a[0])
        label = where if isinstance(where, str) else f"item {where}"
        detail = (f"lowest: {label} at {low:.2f} m above home" if low > 0.0 else
                  f"{label} at {low:.2f} m above home: at or below the ground it took off from")
        out.append(Verdict("ALT", "altitude > 0 m", low > 0.0, low, "m", detail))

    energy = _energy_verdict(timeline, map)
    if energy is not None:
        out.append(energy[0])
    t = timeline.totals
    return Verdicts(items=tuple(out), t_fly=t.t_fly, t_hover=t.t_hover, f=t.f,
                    data_margins=margins, clearance=clearance,
                    **(energy[1] if energy is not None else {}))  # fmt: skip


def _ends_verdict(timeline: Timeline, map: Any,  # noqa: A002
                  end_names: tuple[str, str] = ("start", "end")) -> Verdict:
    """ENDS: the mission takes off at the map's start and comes down at its end (module
    docstring). A mission with neither LAND nor RETURN_TO_LAUNCH fails whatever its last stop:
    the vehicle holds there until a failsafe (the battery's, or the operator's) brings it
    down; its margin is -inf. Without a TAKEOFF item the take-off is the sim's assumption (a
    climb at the map's start: `sim.mission.items_to_route` notes what each autopilot does),
    said in the detail. O(1)."""
    route = timeline.route
    d0 = float(np.linalg.norm(route.launch - map.start))
    d1 = float(np.linalg.norm(timeline.path[-1] - map.end))
    start, end = end_names
    take_off = (f"take-off {d0:.3f} m from {start}" if route.takeoff_altitude is not None else
                f"no TAKEOFF item: take-off assumed at {'the ' if start == 'start' else ''}{start}")
    if route.finish == "none":
        detail = (f"the mission does not land (no LAND or RETURN_TO_LAUNCH item): it holds at "
                  f"its last stop, item {route.seqs[-1]}, {d1:.3f} m from {end}, until a "
                  f"failsafe; {take_off}")  # fmt: skip
        return Verdict("ENDS", "start -> end", False, -math.inf, "m", detail)
    worst = max(d0, d1)
    worst = 0.0 if worst < GEOM_TOL else worst  # round-off of the lat/lon round trip
    detail = f"{take_off}, last stop {d1:.3f} m from {end} (within {ENDS_TOL:g} m)"
    # the margin is the slack, as for every check: >= 0 exactly when it holds
    return Verdict("ENDS", "start -> end", worst <= ENDS_TOL, ENDS_TOL - worst, "m", detail)


def _energy_verdict(timeline: Timeline, map: Any) -> tuple[Verdict, dict[str, float]] | None:  # noqa: A002
    """ENERGY for a map with a battery (None without one): the mission's energy, the sim's
    own (`sim.energy`), at most battery x (1 - reserve); the margin is the usable energy left
    (Wh). Tolerance `REL_TOL` of the usable energy (float32 parameters), so 1 % over fails."""
    bat = sim_energy.battery(map)
    if bat is None:
        return None
    full, reserve = bat
    usable = full * (1.0 - reserve)
    used = sim_energy.mission_energy(timeline, map).total
    m = usable - used
    left = full - used
    detail = (f"{used:.5g} Wh of {usable:.5g} Wh usable (battery {full:.5g} Wh, reserve "
              f"{100 * reserve:g} %): {left:.4g} Wh ({100 * left / full:.3g} %) left at "
              "landing")  # fmt: skip
    v = Verdict("ENERGY", "energy <= usable", m >= -REL_TOL * usable, m, "Wh", detail)
    return v, {"energy_wh": used, "battery_wh": full, "usable_wh": usable}
