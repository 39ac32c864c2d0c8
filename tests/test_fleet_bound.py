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
