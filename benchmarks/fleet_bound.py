"""Issue 33: a plan-free lower bound on the total time of any sortie plan of a battery map, and
how far below route first, cluster second a plan can therefore go (docs/sorties.md, "How far
below route-first a plan can go").

The total of a one-UAV plan (what bench_fleet.py's records call `sim_total_s`) is
sum over its S sorties of (flight + hover + take-off and landing) + swap_s x (S - 1). Any plan
that meets C4 is bounded below by

    LB = F_LB + H_LB + S_min x t_vert + (S_min - 1) x swap_s

* H_LB, hover (s): the hover-time LP of `planner_core.model.bounds` (cells of side <= 25 m,
  each cell given, per sensor, the largest rate any point of the cell has, so every hover point
  of a real plan is dominated by its cell) with its caps dropped (a fleet plan may hold more than
  I_max points in all): min sum_c T_c s.t. sum_c Rbar_cj T_c >= Q_j, T >= 0. A relaxation of the
  hover part of every plan (data is collected only while hovering, paper Sec. 3; C3 and T_max
  dropped), so H_LB <= the plan's summed hover times. Q_j is the map's required data without
  the planning margin. And H_LB >= sum_j Q_j / R_lambda: a hover point of a feasible plan
  receives at most the bandwidth R_lambda in all (C3, "simultaneous": sum_j R_ij <= R_lambda;
  "scheduled": the slots share R_lambda), so the data of all sensors takes that long at least;
  the larger of the two is kept.
* F_LB, horizontal flight (s): one UAV flies its sorties one after the other, each taking off
  where the last landed, so their legs join into one walk from the start depot that comes within
  the radio reach r (the ground distance at which the rate falls to 0) of every sensor needing
  data. The walk spans the start and one such point per sensor, so it is at least the minimum
  spanning tree over {start} U {sensors} with edge lengths max(0, |a - b| - r_a - r_b) (r = 0
  at the start): each true edge is at least its shortened one. Every leg of length d takes at
  least d / v_max (Eq. 1), so F_LB = MST / v_max. Also F_LB >= 2 (d_far - r) / v_max, with d_far
  the largest over sensors of the distance to the nearest depot (some sortie reaches that
  sensor's disc and lands at a depot); the larger of the two is kept.
* S_min, sorties: each sortie spends at least E_vert (take-off and landing at P(0)) and all of
  them together at least P(0) H_LB + e_min x MST length (e_min: `energy.least_energy_per_metre_wh`,
  the least energy per metre of the power model at any speed up to v_max), and each may spend at
  most the usable energy U, so S (U - E_vert) >= P(0) H_LB / 3600 + e_min MST and
  S_min = ceil((P(0) H_LB / 3600 + e_min MST) / (U - E_vert)). t_vert: the Eq. 1 take-off and
  landing time of every sortie (`FleetSettings.vertical_s`).

LB is valid for every plan whatever its search (not an estimate); it is loose where the walk must
weave between sensor discs that overlap (MST edges of length 0). Cost: one LP of ~cells in range
(10^4-10^5 variables, HiGHS) and an O(J^2) MST: seconds per map.

    nice python benchmarks/fleet_bound.py --maps L01,L04,L07,L02 \\
        --records docs/sorties-runs/bench-25min.jsonl.gz
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


@dataclass(frozen=True)
class FleetBound:
    """LB and its parts (s, Wh), for one battery map (module docstring)."""

    lb: float
    flight_s: float
    hover_s: float
    sorties: int
    vertical_s: float
    swap_s: float
    mst_m: float
    energy_wh: float
    usable_wh: float


def hover_lb(m: Any) -> float:
    """H_LB (s): the cell LP of `planner_core.model.bounds` without caps (module docstring)."""
    import scipy.sparse as sp
    from scipy.optimize import linprog

    from planner_core.model.bounds import DEFAULT_SPACING, _cell_rates

    req = np.asarray(m.required_data, dtype=float)
    need = req > 0
    if not need.any():
        return 0.0
    rows, cols, vals, _ = _cell_rates(m, DEFAULT_SPACING)
    keep = need[rows]
    cells, col = np.unique(cols[keep], return_inverse=True)
    if not set(np.flatnonzero(need)) <= set(rows[keep].tolist()):
        return math.inf
    A = sp.csr_matrix((vals[keep] / req[rows[keep]], (rows[keep], col)),
                      shape=(len(req), len(cells)))[need]  # fmt: skip
    res = linprog(np.ones(len(cells)), A_ub=-A, b_ub=-np.ones(A.shape[0]),
                  bounds=(0, None), method="highs")  # fmt: skip
    if res.status != 0:
        return math.inf
    lp = max(float(res.fun) * (1.0 - 1e-7), 0.0)  # a hair below: the solver's tolerance
    return max(lp, float(req[need].sum()) / float(m.spec.radio.bandwidth))


def _mst_length(w: np.ndarray) -> float:
    """Length of the minimum spanning tree of the complete graph with weights w (Prim)."""
    n = len(w)
    inside = np.zeros(n, dtype=bool)
    best = np.full(n, np.inf)
    best[0] = 0.0
    total = 0.0
    for _ in range(n):
        k = int(np.argmin(np.where(inside, np.inf, best)))
        total += best[k]
        inside[k] = True
        best = np.minimum(best, w[k])
    return float(total)


def fleet_lower_bound(m: Any) -> FleetBound:
    """LB of the module docstring for a loaded battery map `m` (one UAV).

    Raises:
        ValueError: the map has no battery.
    """
    from planner_core.fleet.model import FleetSettings
    from planner_core.model import energy as E
    from planner_core.model.formulas import ModelParams, ground_reach

    st = FleetSettings.from_map(m, "total")
    if not math.isfinite(st.usable_wh):
        raise ValueError("map: no battery (uav.battery or uav.endurance_s)")
    mp = ModelParams.from_map(m)
    r = float(ground_reach(0.0, mp.altitude, mp.peak_rate, mp.decay))
    S = mp.sensors[np.asarray(mp.required, dtype=float) > 0]
    nodes = np.vstack([mp.start[None, :], S])
    rad = np.r_[0.0, np.full(len(S), r)]
    d = np.hypot(*(nodes[:, None, :] - nodes[None, :, :]).transpose(2, 0, 1))
    mst = _mst_length(np.maximum(d - rad[:, None] - rad[None, :], 0.0))
    far = 0.0
    if len(S):
        dd = np.hypot(*(S[:, None, :] - st.depots[None, :, :]).transpose(2, 0, 1)).min(axis=1)
        far = 2.0 * max(float(dd.max()) - r, 0.0)
    flight = max(mst, far) / mp.v_max
    hover = hover_lb(m)
    e_need = st.hover_w * hover / E.J_PER_WH + E.least_energy_per_metre_wh(mp.v_max, st.power) * mst
    per = st.usable_wh - st.vertical_wh
    n = max(1, math.ceil(e_need / per - 1e-12)) if per > 0 else math.inf
    lb = flight + hover + n * st.vertical_s + (n - 1) * st.swap_s
    return FleetBound(lb=lb, flight_s=flight, hover_s=hover, sorties=n,
                      vertical_s=st.vertical_s, swap_s=st.swap_s, mst_m=mst,
                      energy_wh=e_need, usable_wh=st.usable_wh)  # fmt: skip


def _records(path: Path) -> dict[str, list[dict[str, Any]]]:
    """map -> its one-UAV records of bench_fleet.py at `path` (JSON lines, .gz: compressed),
    the first of each seed; {} for /dev/null (no measured runs: docs/sorties.md's second
    table)."""
    from planner_core.textio import read_jsonl

    if Path(path) == Path(os.devnull):
        return {}
    out: dict[str, list[dict[str, Any]]] = {}
    seen = set()
    for r in read_jsonl(path):
        if r["uavs"] == 1 and (r["map"], r["seed"]) not in seen:
            seen.add((r["map"], r["seed"]))
            out.setdefault(r["map"], []).append(r)
    return out


def table(maps: list[str], records: Path | None, endurance: float) -> str:
    """The docs table: per map LB, the measured totals and what 5 % below route-first asks."""
    from bench_fleet import battery_map

    from planner_core.model.mapio import load_map

    recs = _records(records) if records else {}
    lines = [
        "| map | LB (s) | flight / hover / sorties in LB | route-first total (s) | ours "
        "total (s) | route-first above LB | 5 % below route-first | ours above LB | "
        "CPU (s) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name in maps:
        t = time.process_time()
        b = fleet_lower_bound(load_map(battery_map(ROOT / "examples/maps/large" / f"{name}.json",
                                                   endurance)))  # fmt: skip
        cpu = time.process_time() - t
        rs = recs.get(name, [])
        if rs:
            peer = float(np.mean([r["peer"]["sim_total_s"] for r in rs]))
            ours = float(np.mean([r["ours"]["sim_total_s"] for r in rs]))
            target = 0.95 * peer
            cols = (
                f"{peer:.0f} ({len(rs)} runs) | {ours:.0f} | "
                f"{100 * (peer / b.lb - 1):+.1f} % | "
                f"{target:.0f}: {'possible' if target >= b.lb else 'IMPOSSIBLE'} "
                f"(LB {100 * (b.lb / peer - 1):+.1f} % of route-first) | "
                f"{100 * (ours / b.lb - 1):+.1f} %"
            )
        else:
            cols = "- | - | - | - | -"
        lines.append(
            f"| {name} | {b.lb:.0f} | {b.flight_s:.0f} / {b.hover_s:.0f} / {b.sorties} "
            f"| {cols} | {cpu:.1f} |"
        )
    return "\n".join(lines)


#: the large suite's best-known plans (`--best-known`: another file of the same format, e.g. the
#: copy docs/scaling/best-known-0f5cc8d.json that tables measured before a refresh used)
BEST_KNOWN = ROOT / "examples/maps/large_best_known.json"


def single_flight_s(name: str, best_known: Path = BEST_KNOWN) -> float:
    """Flying and hovering (s) of the large map `name`'s best-known single flight (the plan in
    `best_known`): Eq. 1 leg times plus hover times on its planning map, detour corners as
    0-second stops."""
    import json

    from planner_core.model.corner_slots import problem_for
    from planner_core.model.mapio import load_map

    bk = json.loads(Path(best_known).read_text())["tasks"][name]
    m = load_map(ROOT / "examples/maps/large" / f"{name}.json")
    problem, _ = problem_for(m.planning_map(), variable_length=True, corner_slots="auto")
    b = problem.breakdown(problem.encode(np.asarray(bk["hover_points"], dtype=float),
                                         np.asarray(bk["hover_times"], dtype=float)))  # fmt: skip
    return float(b["t_fly"] + b["t_hover"])


def overhead_table(maps: list[str], records: Path, endurance: float,
                   best_known: Path = BEST_KNOWN) -> str:
    """Where 5 % below route-first must come from: per map, the flying and hovering of the
    sorties joined (a record's total less S take-offs and landings and S - 1 swaps), ours and
    route-first's, over the best-known single flight's (`single_flight_s`), and what ours may
    fly and hover, with its own sorties, at 0.95 x route-first's total. An estimate, not a
    bound: the best-known single flight is not the best possible one."""
    from bench_fleet import battery_map

    from planner_core.fleet.model import FleetSettings
    from planner_core.model.mapio import load_map

    recs = _records(records)
    lines = [
        "| map | runs | best single flight: flying + hovering (s) | route-first's sorties joined "
        "| ours joined | ours at 5 % below route-first (its sorties) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for name in maps:
        rs = recs.get(name, [])
        if not rs:
            continue
        st = FleetSettings.from_map(load_map(battery_map(
            ROOT / "examples/maps/large" / f"{name}.json", endurance)), "total")  # fmt: skip
        single = single_flight_s(name, best_known)

        n = {w: np.array([r[w]["sorties"] for r in rs], dtype=float) for w in ("ours", "peer")}
        tot = {w: np.array([r[w]["sim_total_s"] for r in rs], dtype=float) for w in n}
        peer, ours = (float(np.mean(tot[w] - n[w] * st.vertical_s - (n[w] - 1) * st.swap_s))
                      for w in ("peer", "ours"))  # fmt: skip
        s_ours = float(n["ours"].mean())
        allowed = 0.95 * float(tot["peer"].mean()) - s_ours * st.vertical_s \
            - (s_ours - 1) * st.swap_s
        lines.append(
            f"| {name} | {len(rs)} | {single:.0f} "
            f"| {peer:.0f} ({100 * (peer / single - 1):+.1f} %) "
            f"| {ours:.0f} ({100 * (ours / single - 1):+.1f} %) "
            f"| {allowed:.0f} ({100 * (allowed / single - 1):+.1f} %; {s_ours:.1f} sorties) |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="L01,L04,L07,L02")
    ap.add_argument("--records", type=Path, default=ROOT / "docs/sorties-runs/bench-25min.jsonl.gz")
    ap.add_argument("--endurance", type=float, default=1500.0)
    ap.add_argument("--overhead", action="store_true",
                    help="the sorties' flying and hovering against the best-known single flight "
                         "(the records' maps) instead of the lower bound")  # fmt: skip
    ap.add_argument("--best-known", type=Path, default=BEST_KNOWN,
                    help="the best-known plans --overhead measures against (default "
                         "examples/maps/large_best_known.json; a table measured before its "
                         "last refresh names the copy it used)")  # fmt: skip
    a = ap.parse_args()
    if a.overhead:
        print(overhead_table(a.maps.split(","), a.records, a.endurance, a.best_known))
    else:
        print(table(a.maps.split(","), a.records, a.endurance))


if __name__ == "__main__":
    main()
