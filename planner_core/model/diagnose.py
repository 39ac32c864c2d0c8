"""A fast feasibility diagnosis of a map: what no plan can meet, found before any optimisation.

On the map the planner works on (`Map.planning_map()`: obstacles inflated by the clearance,
required data raised by the data margin) and with shapely:

- the free airspace is the area less every obstacle; the part the UAV can reach is the piece
  holding the start point. The end point outside that piece: no plan (ENCLOSED).
- for each sensor j the best rate R_j any reachable hover point gets (the paper's
  R = max(R_c - xi * sqrt(d^2 + H^2), 0) at the reachable point nearest the sensor, at most
  R_lambda); R_j = 0: the sensor cannot be served at all (UNREACHABLE).
- one hover point collects at most T_max * R_j from it, so the plan needs at least
  ceil(Q_j / (T_max * R_j)) hover points for it; more than I_max: no plan (TOO_MUCH_DATA).
- a hover point hears only the sensors within the link's ground reach r of it, so sensors
  pairwise more than 2 r apart each need a hover point of their own: a greedy set of such
  sensors larger than I_max (times the flights without a battery) proves no plan (SPREAD).

- C3 (the paper's simultaneous uplink, `radio.access` "simultaneous"): a hover point receives
  from every sensor in range at once and their summed rate must stay within R_lambda; in a
  dense field of sensors every point near enough to collect may break it. `bandwidth_bound`
  proves over the whole area (cells bounding the rates from both sides, and the hover-time
  LP over them) which sensors no C3-respecting point receives from (C3_NO_POINT) or that no
  plan can serve within I_max x T_max of hover time at such points (C3_HOVER_TIME: a sensor
  that alone needs more is named alone, else each line names the others of the set that
  together need it). In scheduled access C3 does not apply and the test is skipped.

Batteries and fleets (issue 33; only on maps that give `uav.battery` / `uav.endurance_s` or
`fleet`, so other maps are diagnosed exactly as before). A sortie takes off and lands at a
depot (`fleet.depots`; without them the map's start, and the map's end for landing) in the
same free piece of airspace, flies at most v_max and spends at least
`energy.least_energy_per_metre_wh` per metre, the vertical take-off and landing, and P(0) per
hover second; a sensor is heard only within `ground_reach` of it. A vehicle takes off where
its last sortie landed (its first: any depot, or the start without depots), so it moves only
among the sites that flights within one battery join, transitively (a group). Straight-line
distances bound the flight from below, so:

- a battery whose usable energy the take-off to the flight altitude and the landing alone
  use up: no sortie can fly, one fatal finding instead of one per sensor and depot
  (ENERGY_VERTICAL: the vertical phases' energy, the usable energy, and the battery or
  `uav.endurance_s` a sortie needs more than);
- a sensor that no sortie from a group a vehicle can take off in can reach (its radio range
  and back within the usable energy, battery x (1 - reserve)) can get no data at all
  (ENERGY_RANGE, naming the sensor, the energy needed and the usable energy, and a site within
  reach that no vehicle gets to, such as the map's end);
- sensors that only different groups reach, more of them than `fleet.uavs` (a greedy set of
  sensors whose groups are disjoint: each needs a vehicle of its own; VEHICLES);
- a sensor whose data needs more sorties than the sortie planner shares one sensor's data
  among (`planner_core.fleet.split.SHARE_MAX`): the planner's own limit, not a proof that no
  plan exists (SORTIE_LIMIT; the planner refuses such a map up front);
- a depot from which no sortie can leave: no sensor is heard from its piece of airspace (it is
  walled in), or every sensor is out of a battery's reach from it. A vehicle's first sortie
  may leave any depot, so it is a note while another depot can be left (DEPOT_UNUSED, naming
  the depot and those plans leave from), fatal only when none can (DEPOT, naming each);
- a depot without room for every vehicle's own pad (`fleet.separation_m` + 5 m apart, clear
  of obstacles, inside the area: `planner_core.model.pads`; PADS, naming the depot);
- a sensor's data may be split across sorties (C4 sums them), so a sensor one sortie cannot
  serve alone from its best depot is a note (ENERGY_SPLIT: the energy serving it alone needs,
  the usable energy, and how many sorties at least must share it); with several sorties the
  per-flight limits I_max and I_max x T_max (TOO_MUCH_DATA, C3_HOVER_TIME) bound each sortie,
  not the plan: fatal only beyond what `fleet.uavs` flights without a battery can hold, notes
  with a battery (as many sorties as needed). Each finding that counts the sorties a
  sensor's data needs at least also gives the most any finding of that sensor proves
  (`_agreed`).

Findings that are no proof of infeasibility are notes: a sensor inside an obstacle or a no-fly
zone (served by radio from outside it: the best rate says how well; where the sensor is CANNOT,
its first CANNOT line says where it lies instead), a sensor needing more than
one hover point, a bandwidth test that found no plan on its grid but could not prove it
(C3_GRID). The checks are necessary conditions, not sufficient: a map that passes may still be
infeasible (obstacles between the C3-respecting points, the flight between them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

# numbers in plain digits (90000 Wh, not 9e+04 Wh), rounded as the `:.4g` they replace
from planner_core.defaults import number_text as _num
from planner_core.model.formulas import ground_reach, link_rates
from planner_core.textio import counted, first_few, for_count

__all__ = ["BandwidthBound", "Finding", "Diagnosis", "bandwidth_bound", "diagnose"]


@dataclass(frozen=True)
class Finding:
    """One finding: `kind`, whether it rules every plan out (`fatal`), and a sentence."""

    kind: str
    fatal: bool
    message: str
    sensor: str | None = None
    #: the depot a DEPOT finding names (issue 33)
    depot: str | None = None
    #: the sorties at least that must share the sensor's data, where the finding proves a
    #: number (SEVERAL_SORTIES, ENERGY_SPLIT, SORTIE_LIMIT, a C3_HOVER_TIME note of one sensor)
    sorties: int | None = None


@dataclass(frozen=True)
class Diagnosis:
    """All findings, and the best rate (Mbit/s) and hover points needed per sensor id."""

    findings: tuple[Finding, ...]
    best_rate: dict[str, float] = field(default_factory=dict)
    points_needed: dict[str, int] = field(default_factory=dict)
    #: what the bandwidth test (`bandwidth_bound`) found; None in scheduled access (no C3)
    bandwidth: BandwidthBound | None = None

    @property
    def feasible_so_far(self) -> bool:
        """No finding rules every plan out (necessary conditions only).

        Returns:
            True when no finding is fatal.
        """
        return not any(f.fatal for f in self.findings)


def diagnose(m: Any) -> Diagnosis:
    """Diagnose `m` (a Map; its planning map is what is judged).

    Args:
        m: a `planner_core.model.mapio.Map`.

    Returns:
        The `Diagnosis` (findings in order: the end point, per sensor, then the bandwidth
        test's).
    """
    import shapely
    from shapely.geometry import Point

    from planner_core.model.mapio import _obstacle_polygons

    pm = m.planning_map()
    spec = pm.spec
    uav, radio = spec.uav, spec.radio
    hear = _hear(pm)
    real = _obstacle_polygons(m)  # as the map gives them
    labels = m.obstacle_labels
    start, end = Point(*pm.start), Point(*pm.end)
    pieces = _airspace(pm, real if pm is m else None)  # no margins: the same shapes
    reach = min(pieces, key=lambda g: g.distance(start)) if pieces else None
    findings: list[Finding] = []
    if pieces and reach.distance(end) > 1e-6:
        findings.append(Finding("ENCLOSED", True, "end: the end point cannot be reached from "
                                "the start (obstacles wall one of them in)"))  # fmt: skip
    t_max, i_max = float(uav.max_hover_time), int(pm.max_hover_points)
    # flights the plan may use (issue 33): one (the paper's), fleet.uavs without a battery,
    # as many as needed with one; the per-flight limits below bound the plan by that many
    flights = math.inf if m.has_battery else float(m.uavs)
    best: dict[str, float] = {}
    need: dict[str, int] = {}
    # every sensor at once (one tree query, one distance call: J x obstacles shapely calls
    # one by one were most of `diagnose` on maps of a thousand obstacles)
    points = shapely.points(np.asarray(pm.sensors, dtype=float).reshape(-1, 2))
    holds: list[list[int]] = [[] for _ in range(len(points))]  # obstacles holding sensor j
    held: dict[str, str] = {}  # sensor id -> the obstacles holding it, as messages name them
    if real:
        j_in, k_in = shapely.STRtree(real).query(points, predicate="within")
        for j, k in sorted(zip(j_in.tolist(), k_in.tolist(), strict=True)):  # map order
            holds[j].append(k)
    dist = (shapely.distance(reach, points) if reach is not None
            else np.full(len(points), math.inf))  # fmt: skip
    for j, (sid, s, q, q_real) in enumerate(zip(pm.sensor_ids, pm.sensors, pm.required_data,
                                                m.required_data, strict=True)):  # fmt: skip
        inside = [labels[k] for k in holds[j]]
        d = float(dist[j])
        r = 0.0
        if math.isfinite(d):
            r = float(link_rates(np.array([[s[0] + d, s[1]]]), np.array([s]), uav.altitude,
                                 radio.peak_rate, radio.decay)[0, 0])  # fmt: skip
            r = min(r, float(radio.bandwidth))
        best[sid] = r
        if inside:
            held[sid] = ", ".join(inside)
            findings.append(Finding(
                "INSIDE", False, f"sensor '{sid}' lies inside {held[sid]}: it can only "
                f"be served from outside, {d:.1f} m away at best ({_num(r, 3)} Mbit/s)", sid))
        if q <= 0:
            need[sid] = 0
            continue
        if r <= 0.0:
            overhead = float(radio.peak_rate) - float(radio.decay) * float(uav.altitude)
            if overhead <= 0.0:  # the link model reaches no ground point at this altitude
                why = (f"even overhead the link rate R_c - xi H = {radio.peak_rate:g} - "
                       f"{radio.decay:g} x {uav.altitude:g} m is {_num(overhead, 4)} Mbit/s <= 0 "
                       "(radio.peak_rate, radio.decay, uav.altitude)")
            else:
                why = (f"the nearest reachable hover point is {d:.1f} m away, beyond the "
                       f"link's ground reach of {hear:.1f} m (rate 0)")
            findings.append(Finding(
                "UNREACHABLE", True, f"sensor '{sid}': no reachable hover point gets any data "
                f"from it: {why}", sid))
            need[sid] = i_max + 1
            continue
        k = math.ceil(q / (t_max * r) - 1e-12)
        need[sid] = k
        one = t_max * r
        if k > i_max and flights > 1:  # several flights (issue 33)
            why = (f"sensor '{sid}' needs {_num(q)} Mbit (required {_num(q_real)} plus the "
                   f"data margin); one hover point collects at most {_num(one, 4)} Mbit (T_max "
                   f"{t_max:g} s x {_num(r, 3)} Mbit/s), so {k} hover points are "
                   "needed")  # fmt: skip
            if k > i_max * flights:
                findings.append(Finding(
                    "TOO_MUCH_DATA", True, f"{why}, more than I_max = {i_max} in each of "
                    f"the {m.uavs} flights (fleet.uavs, no battery: one flight each)", sid))
            else:
                findings.append(Finding(
                    "SEVERAL_SORTIES", False, f"{why}, more than one flight's I_max = "
                    f"{i_max}: at least {math.ceil(k / i_max)} sorties must share it", sid,
                    sorties=math.ceil(k / i_max)))  # fmt: skip
        elif k > i_max:
            findings.append(Finding(
                "TOO_MUCH_DATA", True, f"sensor '{sid}' needs {_num(q)} Mbit (required "
                f"{_num(q_real)} plus the data margin); one hover point collects at most "
                f"{_num(one, 4)} Mbit (T_max {t_max:g} s x {_num(r, 3)} Mbit/s), so {k} hover "
                f"points would be needed, more than I_max = {i_max}", sid))
        elif k > 1:
            findings.append(Finding(
                "SEVERAL_POINTS", False, f"sensor '{sid}' needs {_num(q)} Mbit: one hover "
                f"point collects at most {_num(one, 4)} Mbit (T_max {t_max:g} s x "
                f"{_num(r, 3)} Mbit/s), so at least {k} of the {i_max} hover points must serve "
                "it", sid))
    if math.isfinite(flights):
        findings.extend(_spread_findings(pm, hear, i_max, flights, m.uavs))
    access = getattr(radio, "access", "simultaneous")
    bound = None
    if access == "simultaneous":
        fatal = {f.sensor for f in findings if f.fatal}
        req = np.array([0.0 if sid in fatal else q for sid, q in
                        zip(pm.sensor_ids, pm.required_data, strict=True)])  # fmt: skip
        # fleet.uavs flights without a battery hold that many flights' hover time
        i_plan = i_max * int(flights) if math.isfinite(flights) else i_max
        bound = bandwidth_bound(
            pm.sensors, req, list(pm.sensor_ids), width=pm.width, height=pm.height,
            altitude=uav.altitude, peak_rate=radio.peak_rate, decay=radio.decay,
            bandwidth=radio.bandwidth, t_max=t_max, i_max=i_plan,
        )  # fmt: skip
        found = _bandwidth_findings(bound, float(radio.bandwidth), t_max, i_plan)
        if not math.isfinite(flights):  # a battery: sorties share the hover time
            found = [f if f.kind != "C3_HOVER_TIME" else _shared_hover(f, bound)
                     for f in found]  # fmt: skip
        findings.extend(found)
    if m.has_battery or m.has_fleet:
        findings.extend(_energy_findings(m, pm, pieces, hear))
        findings.extend(_pad_findings(m))
    findings = _inside_into_cannot(findings, held)
    return Diagnosis(findings=tuple(_agreed(findings)), best_rate=best, points_needed=need,
                     bandwidth=bound)  # fmt: skip


def _inside_into_cannot(findings: list[Finding], held: dict[str, str]) -> list[Finding]:
    """The findings, where a sensor inside an obstacle (INSIDE, a note: "it can only be served
    from outside, ... at best") is also CANNOT, without that note, its first fatal finding
    saying where the sensor lies instead (a note of how it can be served beside a line saying
    it cannot read as a contradiction); `held` maps each such sensor's id to the obstacles
    holding it (`Map.obstacle_labels`' words). Cost: O(findings)."""
    first: dict[str, int] = {}  # sensor -> index of its first fatal finding
    for i, f in enumerate(findings):
        if f.fatal and f.sensor in held:
            first.setdefault(f.sensor, i)
    out = []
    for i, f in enumerate(findings):
        if f.kind == "INSIDE" and f.sensor in first:
            continue
        if f.sensor is not None and first.get(f.sensor) == i:
            who = "it" if f.message.startswith(f"sensor '{f.sensor}'") else f"sensor '{f.sensor}'"
            f = replace(f, message=f"{f.message}; {who} lies inside {held[f.sensor]}")
        out.append(f)
    return out


def _shared_hover(f: Finding, b: BandwidthBound) -> Finding:
    """A C3_HOVER_TIME finding on a map with a battery: a note (it bounds one sortie, and
    sorties share the hover time), saying how many sorties at least its hover time needs."""
    if f.sensor in b.short and b.alone:
        need = b.alone[b.short.index(f.sensor)]
        k = math.ceil(need / b.cap * (1.0 - C3_TOL))
        return Finding("C3_HOVER_TIME", False, f"{f.message}; that bounds one sortie: at least "
                       f"{k} sorties must share its hover time", f.sensor, sorties=k)
    k = math.ceil(b.v_low / b.cap * (1.0 - C3_TOL))
    return Finding("C3_HOVER_TIME", False, f"{f.message}; that bounds one sortie: at least {k} "
                   "sorties must share their hover time", f.sensor)


#: what each finding that counts sorties counts them for (`_agreed`)
SORTIES_FOR = {"SEVERAL_SORTIES": "for its hover points", "ENERGY_SPLIT": "for the battery",
               "SORTIE_LIMIT": "for the battery",
               "C3_HOVER_TIME": "for its hover time at hover points that keep C3"}


def _agreed(findings: list[Finding]) -> list[Finding]:
    """The findings, each that says how many sorties at least must share a sensor's data
    (`Finding.sorties`) also giving the most any finding of that sensor proves, and what for
    ("at least 16 sorties must share it, and at least 184 for the battery (below)"): each
    bound is true, but a line saying 16 beside one saying 184 read as a contradiction.

    Cost: O(findings)."""
    most: dict[str, tuple[int, int]] = {}  # sensor -> (sorties, index of the finding)
    for i, f in enumerate(findings):
        if f.sensor is not None and f.sorties is not None and f.sorties > most.get(
                f.sensor, (0, -1))[0]:  # fmt: skip
            most[f.sensor] = (f.sorties, i)
    out = []
    for i, f in enumerate(findings):
        k, at = most.get(f.sensor, (0, -1)) if f.sensor is not None else (0, -1)
        if f.sorties is not None and f.sorties < k:
            where = "below" if at > i else "above"
            f = Finding(f.kind, f.fatal, f"{f.message}, and at least {k} "
                        f"{SORTIES_FOR[findings[at].kind]} ({where})", f.sensor, f.depot,
                        f.sorties)  # fmt: skip
        out.append(f)
    return out


def _hear(pm: Any) -> float:
    """The link's ground reach, m: beyond it a hover point hears a sensor at rate 0."""
    uav, radio = pm.spec.uav, pm.spec.radio
    return float(ground_reach(0.0, uav.altitude, radio.peak_rate, radio.decay))


def _airspace(pm: Any, shapes: list[Any] | None = None) -> list[Any]:
    """The free airspace of the planning map `pm` (the area less every inflated obstacle), as
    its connected pieces (shapely Polygons; none when obstacles cover the area); `shapes`:
    `pm`'s obstacle polygons when the caller has them already."""
    import shapely
    from shapely.geometry import box

    from planner_core.model.mapio import _obstacle_polygons

    if shapes is None:
        shapes = _obstacle_polygons(pm)  # inflated by the clearance
    free = box(0.0, 0.0, pm.width, pm.height)
    if shapes:
        free = free.difference(shapely.union_all(shapes))
    return [g for g in getattr(free, "geoms", [free]) if not g.is_empty]


def fleet_findings(m: Any) -> list[Finding]:
    """The battery and depot findings alone (ENERGY_VERTICAL, ENERGY_RANGE, VEHICLES, DEPOT,
    DEPOT_UNUSED, ENERGY_SPLIT, SORTIE_LIMIT, PADS: the module docstring), as `diagnose` makes
    them, for a map with a battery or a fleet (else none); the sortie planner refuses a map
    with a SORTIE_LIMIT, ENERGY_VERTICAL or PADS up front.

    Args:
        m: a `planner_core.model.mapio.Map`.

    Returns:
        The findings, in `diagnose`'s order.
    """
    if not (m.has_battery or m.has_fleet):
        return []
    pm = m.planning_map()
    return _energy_findings(m, pm, _airspace(pm), _hear(pm)) + _pad_findings(m)


def _pad_findings(m: Any) -> list[Finding]:
    """PADS: a sortie site without room for every vehicle's own pad (`Map.vehicle_pads`:
    `fleet.separation_m` + 5 m apart, clear of obstacles, inside the area), two sites nearer
    than that or a listed pad that breaks the rules; no plan of the fleet can be flown from
    it. SEPARATION_ALTITUDE (a note): a separation above the flight altitude, which a vehicle
    flying near another on the ground breaks. Cost: `planner_core.model.pads.pad_layout`'s."""
    try:
        m.pads_for(int(m.uavs))
    except ValueError as exc:
        return [Finding("PADS", True, str(exc))]
    sep, h = float(m.separation_m), float(m.spec.uav.altitude)
    if int(m.uavs) > 1 and sep > h:
        # SEPARATION counts a vehicle on the ground: one flying over it at the altitude
        # comes within sep of it inside this radius, and the planner does not route round it
        r = math.sqrt(sep * sep - h * h)
        return [Finding("SEPARATION_ALTITUDE", False, (
            f"fleet.separation_m {sep:g} m is more than the flight altitude (uav.altitude "
            f"{h:g} m): a vehicle flying within {r:.0f} m of another standing on its pad comes "
            "nearer than that, which the planner does not route around, so a plan may fail "
            "SEPARATION; fly higher or lower fleet.separation_m"))]
    return []


def spread_sensors(sensors: np.ndarray, need: np.ndarray, reach: float) -> list[int]:
    """A greedy set of sensors pairwise more than 2 x `reach` apart (each index in turn, kept
    when it is that far from every one kept), among those with need > 0: no hover point
    hears two of them, so a plan needs at least one hover point per sensor of the set.

    Args:
        sensors: (J, 2) positions, m.
        need: (J,) required data, Mbit (sensors needing 0 are left out).
        reach: the link's ground reach r, m (`formulas.ground_reach` at rate 0).

    Returns:
        The indices of the set, in index order.

    Cost: O(J x |set|).
    """
    kept: list[int] = []
    far = (2.0 * reach) ** 2
    pts = np.asarray(sensors, dtype=float)
    for j in np.flatnonzero(np.asarray(need) > 0.0):
        if not kept or np.min(np.sum((pts[kept] - pts[j]) ** 2, axis=1)) > far:
            kept.append(int(j))
    return kept


def _spread_findings(pm: Any, reach: float, i_max: int, flights: float,
                     uavs: int) -> list[Finding]:  # fmt: skip
    """SPREAD: more sensors pairwise beyond twice the radio reach (m) than hover points."""
    spread = spread_sensors(pm.sensors, pm.required_data, reach)
    if len(spread) <= i_max * flights:
        return []
    names = ", ".join(f"'{pm.sensor_ids[j]}'" for j in spread[:3])
    each = f" in each of the {uavs} flights" if flights > 1 else ""
    return [Finding(
        "SPREAD", True, f"sensors: at least {len(spread)} hover points are needed: "
        f"{len(spread)} sensors ({names}, ...) lie more than twice the radio reach "
        f"({2.0 * reach:.0f} m) from one another and a hover point hears only those within "
        f"{reach:.0f} m of it; more than I_max = {i_max}{each}")]


def _energy_findings(m: Any, pm: Any, pieces: list[Any], hear: float) -> list[Finding]:
    """Batteries and depots (issue 33; the module docstring): ENERGY_VERTICAL alone when the
    take-off and landing use up the usable energy; else ENERGY_RANGE, VEHICLES, DEPOT and
    SORTIE_LIMIT (fatal), ENERGY_SPLIT and DEPOT_UNUSED (notes), from straight-line lower
    bounds on each sortie's flight; `hear` the link's ground reach (m).

    Sites are the sortie planner's (`Map.sortie_sites`): the map's depots, each a take-off
    site, or without them 'home' at the start (where every vehicle
    takes off) and the map's end (a landing site). A vehicle takes off where its last sortie
    landed, so it only ever stands at sites joined to its first by flights within one battery
    (ferries; a lower bound: take-off, landing and the straight line in the same airspace),
    transitively: a group. Sensors are judged from the groups a vehicle can take off in (a
    group holding a take-off site); with fewer vehicles than the groups the sensors need
    (disjoint sets, counted greedily: a lower bound), VEHICLES.

    Cost: O(J x D + D^2) distances for J sensors and D sites, plus 400 radii per sensor for the
    note."""
    import shapely
    from shapely.geometry import Point

    from planner_core.model import energy as en
    from planner_core.model.formulas import slant_rates

    uav = pm.spec.uav
    v_max, acc, h = float(uav.max_speed), float(uav.acceleration), float(uav.altitude)
    power = m.power
    usable = m.usable_energy_wh
    cap = math.inf if usable is None else float(usable)
    vertical = en.vertical_energy_wh(h, float(uav.climb_speed), float(uav.descent_speed), acc,
                                     power)
    if vertical >= cap:  # one fact rules out every sortie: no sensor or depot is the cause
        return [_vertical_finding(m, vertical, cap)]
    per_m = en.least_energy_per_metre_wh(v_max, power)
    hover_wh = en.hover_power_w(power) / en.J_PER_WH  # Wh per hover second
    given = bool(m.has_fleet and m.spec.fleet.depots)
    names, where_xy, starts = m.sortie_sites
    # (label in messages, name, position)
    if given:
        sites = [(f"depot '{n}'", n, np.asarray(xy, dtype=float))
                 for n, xy in zip(names, where_xy, strict=True)]  # fmt: skip
    else:  # every vehicle leaves the start; a sortie may land at the map's end
        sites = [(f"depot '{names[0]}' (the start)", names[0], pm.start)]
        sites += [(f"the map's end ({xy[0]:g}, {xy[1]:g})", None, np.asarray(xy, dtype=float))
                  for xy in where_xy[1:]]  # fmt: skip

    def piece_of(xy: np.ndarray) -> int:
        if not pieces:
            return -1
        d = [g.distance(Point(*xy)) for g in pieces]
        k = int(np.argmin(d))
        return k if d[k] <= 1e-6 else -1

    where = [piece_of(xy) for _, _, xy in sites]
    n_sites = len(sites)
    xy_all = np.array([xy for _, _, xy in sites], dtype=float).reshape(-1, 2)
    apart = np.hypot(xy_all[:, None, 0] - xy_all[None, :, 0],
                     xy_all[:, None, 1] - xy_all[None, :, 1])
    # the least energy of a flight from one site to another (inf across walls)
    same = np.array([[where[a] >= 0 and where[a] == where[b] for b in range(n_sites)]
                     for a in range(n_sites)], dtype=bool).reshape(n_sites, n_sites)  # fmt: skip
    ferry = np.where(same, vertical + per_m * apart, math.inf)
    group = list(range(n_sites))  # union-find: sites a vehicle can move between

    def root(i: int) -> int:
        while group[i] != i:
            group[i] = group[group[i]]
            i = group[i]
        return i

    for a_ in range(n_sites):
        for b_ in range(a_ + 1, n_sites):
            if math.isfinite(ferry[a_, b_]) and ferry[a_, b_] <= cap:  # not across walls
                group[root(a_)] = root(b_)
    comp = [root(i) for i in range(n_sites)]
    takeoff = {comp[i] for i in starts if where[i] >= 0}
    members: dict[int, list[int]] = {}
    for i in range(n_sites):
        if where[i] >= 0:
            members.setdefault(comp[i], []).append(i)
    groups = {c: v for c, v in members.items() if c in takeoff}  # where vehicles may stand
    stranded = {c: v for c, v in members.items() if c not in takeoff}
    sensors, req, ids = pm.sensors, pm.required_data, pm.sensor_ids
    # per sensor and group: how close the group's airspace comes to it
    pts = shapely.points(np.asarray(sensors, dtype=float))
    near_piece = {k: np.asarray(shapely.distance(pieces[k], pts), dtype=float)
                  for k in {where[i] for v in members.values() for i in v}}  # fmt: skip
    near = {c: near_piece[where[v[0]]] for c, v in members.items()}
    dist = np.array([[float(np.hypot(*(s - xy))) for _, _, xy in sites] for s in sensors])
    dist = dist.reshape(len(sensors), n_sites)

    def cheapest(j: int, among: dict[int, list[int]]) -> tuple[float, str, float, int]:
        """The cheapest sortie from a group of `among` that hears sensor j at all, to the edge
        of its radio range and back: (energy, site label, its distance, group)."""
        best = (math.inf, "", 0.0, -1)
        for c, v in among.items():
            if near[c][j] >= hear:
                continue
            i = min(v, key=lambda i: dist[j, i])
            e = vertical + 2.0 * per_m * max(dist[j, i] - hear, 0.0)
            best = min(best, (e, sites[i][0], dist[j, i], c))
        return best

    out: list[Finding] = []
    serves: dict[int, set[int]] = {}  # sensor -> the take-off groups whose sorties reach it
    for j, sid in enumerate(ids):
        if req[j] <= 0:
            continue
        serves[j] = {c for c in groups if near[c][j] < hear
                     and vertical + 2.0 * per_m * max(min(dist[j, i] for i in groups[c])
                                                      - hear, 0.0) < cap}  # fmt: skip
        if not math.isfinite(cap):
            continue
        e_any, name, d_site, _ = cheapest(j, groups)
        if e_any >= cap:
            how = ("no depot's airspace comes within its radio range" if not name else
                   f"from the nearest, {name}, {d_site:.0f} m away, a sortie needs at "
                   f"least {_num(e_any, 4)} Wh to come within its radio range ({hear:.0f} m) "
                   "and back")  # fmt: skip
            e_far, far, d_far, c_far = cheapest(j, stranded)
            also = ""
            if e_far < cap:  # a site within reach of it that no vehicle can get to
                a_, b_ = min(((a_, b_) for c in groups for a_ in groups[c]
                              for b_ in stranded[c_far]), key=lambda ab: ferry[ab],
                             default=(None, None))  # fmt: skip
                why = ("obstacles wall it off" if a_ is None or not math.isfinite(ferry[a_, b_])
                       else f"the shortest flight there, {apart[a_, b_]:.0f} m from "
                       f"{sites[a_][0]}, needs at least {_num(ferry[a_, b_], 4)} Wh")
                also = (f"; {far}, {d_far:.0f} m away, is within a sortie's reach of it, but "
                        f"no vehicle gets there to take off: {why}")
            out.append(Finding(
                "ENERGY_RANGE", True, f"sensor '{sid}': no sortie can collect any of its "
                f"data: {how}, more than the {_num(cap, 4)} Wh usable (battery "
                f"{_num(m.battery_wh, 4)} Wh less the {100 * m.battery_reserve:g} % reserve)"
                f"{also}", sid))  # fmt: skip
            continue
        note = _split_note(j, sid, groups, near, dist, sites, hear, req[j], cap, vertical,
                           per_m, hover_wh, pm, slant_rates)  # fmt: skip
        if note is not None:
            out.append(note)
    out += _vehicle_findings(m, serves, groups, sites, ferry, apart, ids, cap)
    if given:
        out += _depot_findings(sites, where, comp, members, near, dist, req, ids, hear, cap,
                               vertical, per_m)  # fmt: skip
    return out


def _depot_findings(sites: list, where: list[int], comp: list[int],
                    members: dict[int, list[int]], near: dict[int, np.ndarray],
                    dist: np.ndarray, req: np.ndarray, ids: Any, hear: float, cap: float,
                    vertical: float, per_m: float) -> list[Finding]:  # fmt: skip
    """DEPOT: the map's depots (`fleet.depots`, every one a take-off site) that no sortie can
    leave: inside an obstacle's clearance, walled in (no sensor heard from its piece of
    airspace, `near` m per group and sensor against the radio reach `hear` m), or whose
    cheapest sortie (to a sensor's radio range and on to a depot of its group, straight-line
    lower bounds: `vertical` Wh and `per_m` Wh a metre) needs more than the usable `cap` Wh.
    A vehicle's first sortie may leave any depot, so such a depot is harmless while another
    one can be left: a note (DEPOT_UNUSED, naming the depots plans leave from); fatal only when
    no depot is left that a sortie can leave.

    Returns:
        One finding per depot no sortie can leave, in the map's order.

    Cost: O(D x J) for D depots and J sensors.
    """
    why: dict[int, str] = {}
    for i in range(len(sites)):
        if where[i] < 0:
            why[i] = "it lies inside an obstacle's clearance"
            continue
        heard = [j for j in range(len(ids)) if req[j] > 0 and near[comp[i]][j] < hear]
        if not heard:
            why[i] = (f"no sensor is heard from the airspace around it (obstacles wall it in; "
                      f"the radio range is {hear:.0f} m)")
            continue
        if not math.isfinite(cap):
            continue
        back = {j: min(dist[j, b] for b in members[comp[i]]) for j in heard}
        costs = [(vertical + per_m * (max(dist[j, i] - hear, 0.0) + max(back[j] - hear, 0.0)),
                  j) for j in heard]  # fmt: skip
        e, j = min(costs)
        if e >= cap:
            why[i] = (f"the cheapest, to sensor '{ids[j]}' ({dist[j, i]:.0f} m away) and on to "
                      f"a depot, needs at least {_num(e, 4)} Wh, more than the "
                      f"{_num(cap, 4)} Wh usable")
    left = [sites[i][1] for i in range(len(sites)) if i not in why]
    out = []
    for i, reason in why.items():
        label, name, xy = sites[i]
        line = (f"fleet.depots: {label} at ({xy[0]:g}, {xy[1]:g}): no sortie can leave it: "
                f"{reason}")
        if left:
            others = " or ".join(f"'{n}'" for n in left)
            out.append(Finding("DEPOT_UNUSED", False, f"{line}; no plan uses it (plans leave "
                               f"from depot {others})", depot=name))  # fmt: skip
        else:
            also = ", and no other depot can be left either" if len(sites) > 1 else ""
            out.append(Finding("DEPOT", True, f"{line}{also}", depot=name))
    return out


def _vertical_finding(m: Any, vertical: float, usable: float) -> Finding:
    """ENERGY_VERTICAL: the take-off to the flight altitude and the landing from it alone
    (`energy.vertical_energy_wh`, `vertical`) need at least the `usable` energy, so no sortie
    can fly (each sensor and depot would be CANNOT for this one cause): the figures, and the
    battery a sortie needs more than (the vertical energy plus the reserve, as
    uav.battery.energy_wh and as uav.endurance_s; more again to fly to a sensor and hover)."""
    from planner_core.model import energy as en

    uav = m.spec.uav
    reserve = float(m.battery_reserve)
    t = en.vertical_time_s(float(uav.altitude), float(uav.climb_speed), float(uav.descent_speed),
                           float(uav.acceleration))  # fmt: skip
    least = en.battery_for_usable_wh(vertical, reserve)
    # the least a battery must exceed, printed so that "more than" stays true
    wh = math.floor(least * 100.0) / 100.0
    seconds = math.floor(float(en.hover_endurance_s(least, m.power)))
    return Finding(
        "ENERGY_VERTICAL", True, f"uav: no sortie can fly: the take-off to {uav.altitude:g} m and "
        f"the landing alone need {_num(vertical, 4)} Wh ({t:.1f} s at hover power), more than the "
        f"{_num(usable, 4)} Wh usable (battery {_num(m.battery_wh, 4)} Wh less the "
        f"{100 * reserve:g} % reserve); a battery of more than {wh:.2f} Wh "
        f"(uav.battery.energy_wh; or uav.endurance_s more than {seconds:d}) is needed, and "
        "more to fly to the sensors and hover there (or a lower uav.altitude, faster "
        "uav.climb_speed and uav.descent_speed)")


def _vehicle_findings(m: Any, serves: dict[int, set[int]], groups: dict[int, list[int]],
                      sites: list, ferry: np.ndarray, apart: np.ndarray, ids: Any,
                      cap: float) -> list[Finding]:  # fmt: skip
    """VEHICLES: sensors whose take-off groups (`serves`: sensor -> groups of sites a sortie
    reaching it may leave) are pairwise disjoint each need a vehicle of their own, since a
    vehicle never leaves its group; more such sensors than `fleet.uavs` (a greedy set: fewest
    groups first) rule every plan out."""
    uavs = int(m.uavs)
    if len({c for v in serves.values() for c in v}) <= uavs:
        return []
    picked: list[int] = []
    used: set[int] = set()
    for j in sorted((j for j in serves if serves[j]), key=lambda j: (len(serves[j]), j)):
        if not serves[j] & used:
            picked.append(j)
            used |= serves[j]
    if len(picked) <= uavs:
        return []

    def where(j: int) -> str:
        names = [sites[i][0] for c in sorted(serves[j]) for i in groups[c]]
        return " or ".join(names[:2]) + (" ..." if len(names) > 2 else "")

    shown = "; ".join(f"sensor '{ids[j]}' only from {where(j)}" for j in picked[:3])
    more = f" and {len(picked) - 3} more" if len(picked) > 3 else ""
    pairs = [(a, b) for x in picked for y in picked if x < y for ca in serves[x]
             for cb in serves[y] if ca != cb for a in groups[ca] for b in groups[cb]]
    a, b = min(pairs, key=lambda ab: ferry[ab])
    why = (f"the shortest, {sites[a][0]} to {sites[b][0]}, {apart[a, b]:.0f} m, needs at "
           f"least {_num(ferry[a, b], 4)} Wh, more than the {_num(cap, 4)} Wh usable"
           if math.isfinite(ferry[a, b]) else "obstacles wall them apart")
    return [Finding(
        "VEHICLES", True, f"fleet.uavs: {counted(uavs, 'UAV')} cannot serve "
        f"{counted(len(picked), 'sensor')} that each need a vehicle of their own: {shown}{more}. "
        f"A vehicle takes off where its last sortie landed, and no flight joins these depots "
        f"({why})",
        str(ids[picked[0]]))]


def _split_note(j: int, sid: str, groups: dict[int, list[int]], near: dict[int, np.ndarray],
                dist: np.ndarray, sites: list, hear: float, q: float, cap: float,
                vertical: float, per_m: float, hover_wh: float, pm: Any,
                slant_rates: Any) -> Finding | None:  # fmt: skip
    """ENERGY_SPLIT: serving sensor j alone in one sortie (fly to a point rho metres from it,
    hover Q_j / R(rho), fly back) needs more than the usable energy, a lower bound minimised
    over rho on 400 intervals (flight falls and hover grows with rho, so on [rho_k, rho_k+1]
    flight(rho_k+1) + hover(rho_k) bounds it); and how many sorties at least must share it
    (the most data one sortie can take: R(rho) x its energy left for hover / P(0), at most
    I_max x T_max of hover)."""
    radio, uav = pm.spec.radio, pm.spec.uav
    t_cap = float(uav.max_hover_time) * int(pm.max_hover_points)
    need, most, at = math.inf, 0.0, ""
    for k, members in groups.items():
        lo = float(near[k][j])
        if lo >= hear:
            continue
        i = min(members, key=lambda i: dist[j, i])
        rho = np.linspace(lo, hear, 401)
        rate = np.minimum(np.maximum(slant_rates(rho * rho, uav.altitude, radio.peak_rate,
                                                 radio.decay), 0.0), radio.bandwidth)  # fmt: skip
        fly = vertical + 2.0 * per_m * np.maximum(dist[j, i] - rho, 0.0)
        r_hi, fly_lo = rate[:-1], fly[1:]  # the bounds on each interval
        with np.errstate(divide="ignore"):
            e = fly_lo + np.where(r_hi > 0, hover_wh * q / np.where(r_hi > 0, r_hi, 1.0),
                                  np.inf)  # fmt: skip
        if float(e.min()) < need:
            need, at = float(e.min()), sites[i][0]
        left = np.minimum(np.maximum(cap - fly_lo, 0.0) / hover_wh, t_cap)
        most = max(most, float(np.max(r_hi * left)))
    if need <= cap or most <= 0.0:
        return None
    sorties = math.ceil(q / most - 1e-12)
    from planner_core.defaults import SHARE_MAX

    if sorties > SHARE_MAX:
        return Finding(
            "SORTIE_LIMIT", True, f"sensor '{sid}': the sortie planner cannot plan it: one "
            f"sortie takes at most {_num(most, 4)} Mbit of its {_num(q)} Mbit (from the best site, "
            f"{at}), so at least {sorties} sorties must share its data, more than the "
            f"{SHARE_MAX} the planner shares one sensor's data among "
            "(planner_core.fleet.split.SHARE_MAX)", sid, sorties=sorties)  # fmt: skip
    return Finding(
        "ENERGY_SPLIT", False, f"sensor '{sid}': one sortie cannot serve it alone: from the "
        f"best site, {at}, that needs at least {_num(need, 4)} Wh (the flight and {_num(q)} "
        f"Mbit of hover), more than the {_num(cap, 4)} Wh usable; its data must be shared by "
        f"at least {sorties} sorties", sid, sorties=sorties)  # fmt: skip


def _bandwidth_findings(b: BandwidthBound, bw: float, t_max: float, i_max: int) -> list[Finding]:
    """One line per sensor the bandwidth test proves unservable; a note when inconclusive."""
    out = []
    how = f"proven over the whole area on cells down to {_num(b.cell, 3)} m"
    for sid in b.no_point:
        out.append(Finding(
            "C3_NO_POINT", True, f"sensor '{sid}': every hover point that receives from it "
            f"breaks C3: the sensors in range there send more than R_lambda = {bw:g} Mbit/s "
            f"at once ({how})", sid))  # fmt: skip
    keep = (f"hover time at hover points that keep C3 (sum of rates <= R_lambda = {bw:g} "
            f"Mbit/s), more than I_max x T_max = {i_max} x {t_max:g} s = {_num(b.cap)} s ({how})")
    for k, sid in enumerate(b.short):
        if b.alone:  # each of them alone needs more: no other sensor is to blame
            out.append(Finding("C3_HOVER_TIME", True, f"sensor '{sid}': it alone needs at "
                               f"least {_num(b.alone[k], 6)} s of {keep}", sid))
            continue
        others = [f"'{o}'" for o in b.short if o != sid]
        named = f"{for_count(len(others), 'sensor')} {first_few(others)}"
        out.append(Finding("C3_HOVER_TIME", True, f"sensor '{sid}': with {named} it needs at "
                           f"least {_num(b.v_low, 6)} s of {keep}", sid))
    if not b.proven and b.v_grid > b.cap:
        need = "no plan at all" if not math.isfinite(b.v_grid) else f"{_num(b.v_grid, 6)} s"
        out.append(Finding(
            "C3_GRID", False, f"no hover points of a {_num(b.cell, 3)} m grid that keep C3 (sum of "
            f"rates <= R_lambda = {bw:g} Mbit/s) serve every sensor within I_max x T_max = "
            f"{_num(b.cap)} s (they need {need}; at least {_num(b.v_low, 6)} s is proven): the "
            "map is likely infeasible"))
    return out


# ----------------------------------------------------------------------------- C3: bandwidth

#: the bandwidth test's first cells: the radio reach / `C3_CELLS_PER_REACH` a side, coarser
#: when the area would need more than `C3_GRID` cells along its larger side (bounded time and
#: memory for any map: at most ~C3_GRID^2 cells, each paired with the sensors within reach)
C3_CELLS_PER_REACH = 8
C3_GRID = 256
#: refinement rounds (each splits the cells the relaxation uses in four) and the most cells
C3_ROUNDS = 10
C3_MAX_CELLS = 200_000
#: relative slack: a cell breaks C3 only when its least rate sum exceeds R_lambda by more, and
#: CANNOT needs the least hover time to exceed I_max x T_max by more (the sim's REL_TOL)
C3_TOL = 1e-6
#: refinement stops when a round raised the proven least hover time by less than this share
#: of what it still lacks to the cap (the proof is not coming)
C3_STALL = 0.01


@dataclass(frozen=True)
class BandwidthBound:
    """What the bandwidth test (`bandwidth_bound`) proved or measured.

    `no_point`: ids of sensors no hover point that keeps C3 receives from (proven over the
    whole area); `short`: ids of sensors that together need more hover time at C3-respecting
    points than I_max x T_max allows (proven), `v_low` s that least time (a lower bound);
    `alone` s, one per sensor of `short`, where each of them alone needs more than the cap
    (its data over the best rate any C3-respecting point can get from it), `short` then only
    those (empty: `short` is a set that needs it together);
    `v_grid` s: the least hover time using only the test's grid points (an upper estimate of
    what the continuum needs; inf when the grid serves no plan), `cell` m the finest cell
    side, `cap` s = I_max x T_max, `proven` whether a CANNOT is proven (`no_point` or `short`;
    False with v_grid > cap: the test stopped with v_low <= cap < v_grid, inconclusive),
    `rounds` the refinement rounds run (0: the points overhead the sensors sufficed)."""

    no_point: tuple[str, ...] = ()
    short: tuple[str, ...] = ()
    alone: tuple[float, ...] = ()
    v_low: float = 0.0
    v_grid: float = 0.0
    cell: float = 0.0
    cap: float = 0.0
    proven: bool = True
    rounds: int = 0


def _pairs(
    box: np.ndarray, sensors: np.ndarray, reach: float, tree: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Cell-sensor pairs within radio reach: cell index, sensor index, and the squared ground
    distances (m^2) from the sensor to the nearest and the farthest point of the cell.
    `box` (n, 4) holds x0, y0, x1, y1 per cell (m)."""
    cx, cy = 0.5 * (box[:, 0] + box[:, 2]), 0.5 * (box[:, 1] + box[:, 3])
    half = 0.5 * np.hypot(box[:, 2] - box[:, 0], box[:, 3] - box[:, 1])
    lists = tree.query_ball_point(np.column_stack([cx, cy]), reach + half + 1e-9)
    counts = np.fromiter((len(v) for v in lists), dtype=np.int64, count=len(lists))
    ci = np.repeat(np.arange(len(box)), counts)
    sj = (np.concatenate([np.asarray(v, dtype=np.int64) for v in lists])
          if counts.sum() else np.zeros(0, dtype=np.int64))  # fmt: skip
    sx, sy = sensors[sj, 0], sensors[sj, 1]
    x0, y0, x1, y1 = box[ci, 0], box[ci, 1], box[ci, 2], box[ci, 3]
    dx = np.maximum.reduce([x0 - sx, np.zeros_like(sx), sx - x1])
    dy = np.maximum.reduce([y0 - sy, np.zeros_like(sy), sy - y1])
    fx = np.maximum(np.abs(sx - x0), np.abs(sx - x1))
    fy = np.maximum(np.abs(sy - y0), np.abs(sy - y1))
    return ci, sj, dx * dx + dy * dy, fx * fx + fy * fy


def bandwidth_bound(
    sensors: np.ndarray,
    required: np.ndarray,
    ids: tuple[str, ...] | list[str],
    *,
    width: float,
    height: float,
    altitude: float,
    peak_rate: float,
    decay: float,
    bandwidth: float,
    t_max: float,
    i_max: int,
) -> BandwidthBound:
    """Prove, over every point of the area, what C3 leaves of the sensors' data (paper C3, C4).

    Under the paper's simultaneous uplink a hover point p receives from every sensor in range
    at once, R_pj = max(R_c - xi sqrt(|p - s_j|^2 + H^2), 0), and C3 asks sum_j R_pj <=
    R_lambda. The area is cut into cells; R_pj is monotone in the distance, so over a cell it
    lies between its values at the cell's farthest and nearest points. A cell whose least rate
    sum exceeds R_lambda holds no point that keeps C3; in the others a C3-respecting point gets
    at most UB_cj = min(max_cell R_pj, R_lambda - sum_{k != j} min_cell R_pk) from sensor j.
    Any plan's hover points lie in cells; with tau_c the plan's hover time in cell c and D_cj
    the data its points there take from sensor j, D_cj <= UB_cj tau_c and, by C3 itself,
    sum_j D_cj <= R_lambda tau_c. So the scheduled-access hover-time LP over the cells
    (`planner_core.model.hoverlp.scheduled_lp`, rates UB, T_max unbounded)
        min sum_c tau_c  s.t.  D_cj <= UB_cj tau_c, sum_j D_cj <= R_lambda tau_c,
                               sum_c D_cj >= Q_j (all j),  tau_c, D_cj >= 0
    is a lower bound V_low on every plan's total hover time, which is at most I_max x T_max.
    V_low above that (or a sensor no kept cell reaches) proves that no plan exists; the
    sensors with positive duals are a set that alone needs it. The simultaneous hover-time LP
    (`hover_lp_sparse`) over the cells' centres (real points, C3 checked exactly) gives
    V_grid >= what the relaxation can ever reach (a plan of more points, perhaps): at
    most I_max x T_max and nothing can be proven. In between, the cells the relaxation uses
    are split in four and both are solved again (`C3_ROUNDS` at most).

    Args:
        sensors: (J, 2) m.
        required: (J,) Mbit (Q_j, the planning map's).
        ids: (J,) sensor ids.
        width: m (the area, C1).
        height: m (the area, C1).
        altitude: m (H).
        peak_rate: Mbit/s (R_c).
        decay: Mbit/s per m (xi).
        bandwidth: Mbit/s (R_lambda).
        t_max: s (T_max).
        i_max: I_max.

    Returns:
        A `BandwidthBound`.
    """
    from planner_core.model.formulas import ground_reach, link_rates, slant_rates
    from planner_core.model.hoverlp import hover_lp

    sensors = np.ascontiguousarray(sensors, dtype=float).reshape(-1, 2)
    req = np.asarray(required, dtype=float).reshape(-1)
    J = len(sensors)
    cap = float(i_max) * float(t_max)
    reach = float(ground_reach(0.0, altitude, peak_rate, decay))
    if J == 0 or not np.any(req > 0) or peak_rate - decay * altitude <= 0.0:
        return BandwidthBound(cap=cap)  # nothing to serve, or no link at all (UNREACHABLE)
    # round 0, dense and light (no scipy: `check` stays quick): the points overhead each
    # sensor that keep C3; a plan within the cap there ends the test
    inside = ((sensors[:, 0] >= 0) & (sensors[:, 0] <= width) & (sensors[:, 1] >= 0)
              & (sensors[:, 1] <= height))  # fmt: skip
    R0 = link_rates(sensors[inside], sensors, altitude, peak_rate, decay)
    R0 = R0[R0.sum(axis=1) <= bandwidth]
    lp0 = hover_lp(R0, req, math.inf) if len(R0) else None
    v0 = math.inf if lp0 is None else lp0[1]
    if v0 <= cap:
        return BandwidthBound(cap=cap, v_grid=v0)

    import scipy.sparse as sp
    from scipy.spatial import cKDTree

    from planner_core.model.hoverlp import hover_lp_sparse, scheduled_lp

    bw = float(bandwidth) * (1.0 + C3_TOL)
    tree = cKDTree(sensors)

    def rate(d2: np.ndarray) -> np.ndarray:
        return np.maximum(slant_rates(d2, altitude, peak_rate, decay), 0.0)

    def grid_value(box: np.ndarray) -> float:
        """V_grid: the hover-time LP over the cells' centres that keep C3 (exact rates)."""
        c = np.column_stack([0.5 * (box[:, 0] + box[:, 2]), 0.5 * (box[:, 1] + box[:, 3])])
        pt = np.zeros((len(c), 4))
        pt[:, 0], pt[:, 1], pt[:, 2], pt[:, 3] = c[:, 0], c[:, 1], c[:, 0], c[:, 1]
        ci, sj, d2, _ = _pairs(pt, sensors, reach, tree)
        r = rate(d2)
        ok = np.bincount(ci, r, len(c)) <= bandwidth  # exactly C3 at the point
        keep = ok[ci] & (r > 0)
        R = sp.csr_matrix((r[keep], (ci[keep], sj[keep])), shape=(len(c), J))
        sol = hover_lp_sparse(R, req, math.inf)
        return math.inf if sol is None else sol[1]

    side = max(reach / C3_CELLS_PER_REACH, max(width, height) / C3_GRID, 1e-3)
    nx, ny = max(math.ceil(width / side), 1), max(math.ceil(height / side), 1)
    gx, gy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    gx, gy = gx.ravel().astype(float), gy.ravel().astype(float)
    box = np.column_stack([gx * side, gy * side, np.minimum((gx + 1) * side, width),
                           np.minimum((gy + 1) * side, height)])  # fmt: skip
    near, _ = tree.query(np.column_stack([0.5 * (box[:, 0] + box[:, 2]),
                                          0.5 * (box[:, 1] + box[:, 3])]),
                         distance_upper_bound=reach + side)  # fmt: skip
    box = box[np.isfinite(near)]
    cell = side
    v_low, v_grid, short, no_point, alone = 0.0, v0, (), (), ()
    rounds = 0
    for rounds in range(1, C3_ROUNDS + 1):  # noqa: B007 - reported
        # the cells' centres first (cheap): a plan within the cap there ends the test
        v_grid = min(v_grid, grid_value(box))
        if v_grid <= cap:
            break
        ci, sj, dmin2, dmax2 = _pairs(box, sensors, reach, tree)
        hi, lo = rate(dmin2), rate(dmax2)
        least = np.bincount(ci, lo, len(box))
        ok = least <= bw
        ub = np.minimum(hi, bw - (least[ci] - lo))
        keep = ok[ci] & (ub > 0) & (req[sj] > 0)
        R = sp.csr_matrix((ub[keep], (ci[keep], sj[keep])), shape=(len(box), J))
        linked = np.zeros(J, dtype=bool)
        linked[sj[keep]] = True
        lost = np.flatnonzero((req > 0) & ~linked)
        if len(lost):
            no_point = tuple(ids[j] for j in lost)
            break
        sol = scheduled_lp(R, req, bw, math.inf)
        if sol is None:  # every sensor that needs data has a link: HiGHS itself failed
            break
        tau, _, v, y = sol
        if v > cap * (1.0 + C3_TOL):
            v_low = v
            short = _binding(R, req, bw, y, cap, ids)
            # a sensor alone: its data over the best rate a kept cell can give it (at most
            # R_lambda); those that alone need more than the cap are named alone
            best = np.minimum(np.asarray(R.max(axis=0).todense()).reshape(-1), bw)
            with np.errstate(divide="ignore"):
                need = np.where(best > 0, req / np.where(best > 0, best, 1.0), math.inf)
            over = [j for j in range(J) if ids[j] in short and need[j] > cap * (1.0 + C3_TOL)]
            if over:
                short = tuple(ids[j] for j in over)
                alone = tuple(float(need[j]) for j in over)
            break
        stalled = rounds > 2 and v - v_low < C3_STALL * (cap - v_low)
        v_low = max(v_low, v)
        if stalled or len(box) >= C3_MAX_CELLS:
            break
        used = tau > 0.0
        if not used.any():
            break
        split = box[used]
        mx, my = 0.5 * (split[:, 0] + split[:, 2]), 0.5 * (split[:, 1] + split[:, 3])
        kids = np.vstack([
            np.column_stack([split[:, 0], split[:, 1], mx, my]),
            np.column_stack([mx, split[:, 1], split[:, 2], my]),
            np.column_stack([split[:, 0], my, mx, split[:, 3]]),
            np.column_stack([mx, my, split[:, 2], split[:, 3]]),
        ])  # fmt: skip
        box = np.vstack([box[~used], kids])
        cell = min(cell, float(np.max(split[:, 2] - split[:, 0])) / 2)
    proven = bool(no_point or short)
    return BandwidthBound(no_point=no_point, short=short, alone=alone, v_low=v_low,
                          v_grid=v_grid, cell=cell, cap=cap, proven=proven,
                          rounds=rounds)  # fmt: skip


def _binding(
    R: Any, req: np.ndarray, bw: float, y: np.ndarray, cap: float,
    ids: tuple[str, ...] | list[str],
) -> tuple[str, ...]:
    """The sensors with positive duals, when alone they need more than `cap` s (an LP's
    binding rows carry its optimum); else every sensor that needs data."""
    from planner_core.model.hoverlp import scheduled_lp

    tight = y > 1e-12
    if tight.any():
        sol = scheduled_lp(R, np.where(tight, req, 0.0), bw, math.inf)
        if sol is None or sol[2] > cap * (1.0 + C3_TOL):
            return tuple(ids[j] for j in np.flatnonzero(tight))
    return tuple(ids[j] for j in np.flatnonzero(req > 0))
