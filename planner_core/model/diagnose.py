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

Findings that are no proof of infeasibility are notes: a sensor inside an obstacle or a no-fly
zone (served by radio from outside it: the best rate says how well), a sensor needing more than
one hover point. The checks are necessary conditions, not sufficient: a map that passes may
still be infeasible (hover points shared between sensors, C3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner_core.model.formulas import link_rates

__all__ = ["Finding", "Diagnosis", "diagnose"]


@dataclass(frozen=True)
class Finding:
    """One finding: `kind`, whether it rules every plan out (`fatal`), and a sentence."""

    kind: str
    fatal: bool
    message: str
    sensor: str | None = None


@dataclass(frozen=True)
class Diagnosis:
    """All findings, and the best rate (Mbit/s) and hover points needed per sensor id."""

    findings: tuple[Finding, ...]
    best_rate: dict[str, float] = field(default_factory=dict)
    points_needed: dict[str, int] = field(default_factory=dict)

    @property
    def feasible_so_far(self) -> bool:
        """No finding rules every plan out (necessary conditions only)."""
        return not any(f.fatal for f in self.findings)


def diagnose(m: Any) -> Diagnosis:
    """Diagnose `m` (a Map; its planning map is what is judged)."""
    import shapely
    from shapely.geometry import Point, box

    pm = m.planning_map()
    spec = pm.spec
    uav, radio = spec.uav, spec.radio
    from planner_core.model.mapio import _obstacle_polygons

    shapes = _obstacle_polygons(pm)  # inflated by the clearance
    real = _obstacle_polygons(m)  # as the map gives them
    obs = m.spec.obstacles
    labels = ([f"circle {k}" for k in range(len(obs.circles))]
              + [f"rectangle {k}" for k in range(len(obs.rectangles))]
              + [f"no-fly-zone {k}" for k in range(len(obs.no_fly_zones))]
              + [f"polygon {k}" for k in range(len(obs.polygons))])  # fmt: skip
    free = box(0.0, 0.0, pm.width, pm.height)
    if shapes:
        free = free.difference(shapely.union_all(shapes))
    start, end = Point(*pm.start), Point(*pm.end)
    pieces = list(getattr(free, "geoms", [free]))
    reach = min(pieces, key=lambda g: g.distance(start)) if pieces else free
    findings: list[Finding] = []
    if pieces and reach.distance(end) > 1e-6:
        findings.append(Finding("ENCLOSED", True, "end: the end point cannot be reached from "
                                "the start (obstacles wall one of them in)"))  # fmt: skip
    t_max, i_max = float(uav.max_hover_time), int(pm.max_hover_points)
    best: dict[str, float] = {}
    need: dict[str, int] = {}
    for sid, s, q, q_real in zip(pm.sensor_ids, pm.sensors, pm.required_data, m.required_data,
                                 strict=True):  # fmt: skip
        p = Point(*s)
        inside = [labels[k] for k, g in enumerate(real) if g.contains(p)]
        d = float(reach.distance(p)) if not reach.is_empty else math.inf
        r = 0.0
        if math.isfinite(d):
            r = float(link_rates(np.array([[s[0] + d, s[1]]]), np.array([s]), uav.altitude,
                                 radio.peak_rate, radio.decay)[0, 0])  # fmt: skip
            r = min(r, float(radio.bandwidth))
        best[sid] = r
        if inside:
            findings.append(Finding(
                "INSIDE", False, f"sensor '{sid}' lies inside {', '.join(inside)}: it can only "
                f"be served from outside, {d:.1f} m away at best ({r:.3g} Mbit/s)", sid))
        if q <= 0:
            need[sid] = 0
            continue
        if r <= 0.0:
            findings.append(Finding(
                "UNREACHABLE", True, f"sensor '{sid}': no reachable hover point gets any data "
                f"from it (nearest reachable point {d:.1f} m away, rate 0)", sid))
            need[sid] = i_max + 1
            continue
        k = math.ceil(q / (t_max * r) - 1e-12)
        need[sid] = k
        one = t_max * r
        if k > i_max:
            findings.append(Finding(
                "TOO_MUCH_DATA", True, f"sensor '{sid}' needs {q:g} Mbit (required "
                f"{q_real:g} plus the data margin); one hover point collects at most "
                f"{one:.4g} Mbit (T_max {t_max:g} s x {r:.3g} Mbit/s), so {k} hover points "
                f"would be needed, more than I_max = {i_max}", sid))
        elif k > 1:
            findings.append(Finding(
                "SEVERAL_POINTS", False, f"sensor '{sid}' needs {q:g} Mbit: one hover point "
                f"collects at most {one:.4g} Mbit (T_max {t_max:g} s x {r:.3g} Mbit/s), so at "
                f"least {k} of the {i_max} hover points must serve it", sid))
    return Diagnosis(findings=tuple(findings), best_rate=best, points_needed=need)
