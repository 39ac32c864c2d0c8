"""benchmarks/fleet_bound.py: the plan-free lower bound on a sortie plan's total time holds
below the plans the planner and its route-first peer make (docs/sorties.md)."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "examples" / "maps" / "fleet-demo.json"


def _module():
    spec = importlib.util.spec_from_file_location("fleet_bound", ROOT / "benchmarks" /
                                                  "fleet_bound.py")  # fmt: skip
    mod = importlib.util.module_from_spec(spec)
    sys.modules["fleet_bound"] = mod
    spec.loader.exec_module(mod)
    return mod


def test_mst_by_hand():
    fb = _module()
    # a unit square's four corners: MST = 3
    p = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    w = np.hypot(*(p[:, None] - p[None]).transpose(2, 0, 1))
    assert fb._mst_length(w) == pytest.approx(3.0)


@pytest.mark.slow
def test_bound_below_both_plans():
    from planner_core.fleet import plan_fleet
    from planner_core.model.mapio import load_map
    from planner_core.pipeline import PlanConfig

    fb = _module()
    m = load_map(DEMO)
    b = fb.fleet_lower_bound(m)
    assert math.isfinite(b.lb) and b.lb > 0 and b.sorties >= 1
    # hover: at least every sensor's data through the bandwidth
    assert b.hover_s >= m.required_data.sum() / m.spec.radio.bandwidth * (1 - 1e-6)
    r = plan_fleet(m, PlanConfig(seed=0, budget=600), goal="total", sortie_budget=200, rounds=1)
    for p in (r.plan, r.peer):
        assert b.lb <= p.total_time
        assert len(p.sorties) >= b.sorties


def test_overhead_table_arithmetic(tmp_path):
    """--overhead: the best-known single flight's flying + hovering is 2 f / ... with alpha
    0.5 (f = alpha t_fly + (1 - alpha) t_hover, phi 0); a record's sorties joined are its
    total less S take-offs and landings and S - 1 swaps; 5 % below route-first leaves ours
    0.95 x route-first's total less its own sorties' vertical phases and swaps."""
    import json

    from planner_core.fleet.model import FleetSettings
    from planner_core.model.mapio import load_map

    fb = _module()  # puts benchmarks/ on the path
    from bench_fleet import battery_map

    bk = json.loads((ROOT / "examples/maps/large_best_known.json").read_text())["tasks"]["L04"]
    single = fb.single_flight_s("L04")
    assert single == pytest.approx(2.0 * bk["f"], rel=1e-9)
    # another best-known file of the same format (the copy tables before a refresh used)
    old = ROOT / "docs/scaling/best-known-0f5cc8d.json"
    was = json.loads(old.read_text())["tasks"]["L04"]
    assert fb.single_flight_s("L04", old) == pytest.approx(2.0 * was["f"], rel=1e-9)
    st = FleetSettings.from_map(load_map(battery_map(ROOT / "examples/maps/large/L04.json")),
                                "total")  # fmt: skip
    rec = {"map": "L04", "seed": 0, "uavs": 1,
           "ours": {"sorties": 3, "sim_total_s": 3500.0},
           "peer": {"sorties": 4, "sim_total_s": 3900.0}}  # fmt: skip
    path = tmp_path / "r.jsonl"
    path.write_text(json.dumps(rec) + "\n")
    row = fb.overhead_table(["L04"], path, 1500.0).splitlines()[-1]
    peer = 3900.0 - 4 * st.vertical_s - 3 * st.swap_s
    ours = 3500.0 - 3 * st.vertical_s - 2 * st.swap_s
    allowed = 0.95 * 3900.0 - 3 * st.vertical_s - 2 * st.swap_s
    assert row == (f"| L04 | 1 | {single:.0f} | {peer:.0f} ({100 * (peer / single - 1):+.1f} %) "
                   f"| {ours:.0f} ({100 * (ours / single - 1):+.1f} %) "
                   f"| {allowed:.0f} ({100 * (allowed / single - 1):+.1f} %; 3.0 sorties) |")
