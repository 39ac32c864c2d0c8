"""Dense fields of sensors (issue 31): a hover point inside a field of a dozen sensors hears
them all at once and breaks C3 (the summed link rate above R_lambda), so the constructive
plans serve such a field from its edge (ring sites within the sensors' reach), the seeder's
slide never trades a C3-clean position for a clear leg, and routes avoid graph corners that
break C3."""

from __future__ import annotations

import numpy as np
import pytest

from planner_core.model.problem import Problem
from planner_core.search import construct


def _fields_map(obstacles: dict | None = None) -> dict:
    """Two fields of 12 sensors each within ~60 m (R_c 10, xi 0.01, H 100: ~8.6 Mbit/s each
    at a field's centre, ~100 Mbit/s summed against R_lambda 25), 3 km apart."""
    rng = np.random.default_rng(5)
    sensors = []
    for cx, cy in ((1500.0, 2000.0), (4500.0, 2500.0)):
        for p in rng.uniform(-60, 60, (12, 2)):
            sensors.append({"id": f"S{len(sensors):02d}", "x": round(cx + p[0], 1),
                            "y": round(cy + p[1], 1)})
    return {"name": "two-fields", "area": {"width": 6000, "height": 4500},
            "start": [100.0, 100.0], "end": [5900.0, 4400.0], "sensors": sensors,
            "obstacles": obstacles or {}, "uav": {"max_hover_points": 20}}


@pytest.fixture(scope="module")
def fields() -> Problem:
    return Problem(_fields_map())


def test_no_point_inside_a_field_keeps_c3(fields: Problem) -> None:
    m = fields.model
    assert np.all(m.rates(m.sensors).sum(axis=1) > m.bandwidth)


def test_candidate_sites_keep_c3_and_cover_every_sensor(fields: Problem) -> None:
    sites = construct.candidate_sites(fields)
    m = fields.model
    assert np.all(m.rates(sites).sum(axis=1) <= construct.BANDWIDTH_USE * m.bandwidth)
    assert construct.covers(fields, sites, 0.9).any(axis=0).all()


def test_the_best_constructive_plan_is_feasible(fields: Problem) -> None:
    X, _ = construct.candidate_plans(fields, 0, 16)
    f, phi = fields.evaluate(X)
    assert (phi == 0).any(), phi


def test_without_the_rings_the_covers_break_c3(fields: Problem,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """What the rings fix: with none, each field's central sensors keep their own positions
    as sites and every greedy cover breaks C3."""
    monkeypatch.setattr(construct, "ring_sites", lambda s, lim: np.zeros((0, 2)))
    sites = construct.candidate_sites(fields)
    m = fields.model
    assert np.any(m.rates(sites).sum(axis=1) > m.bandwidth)


def test_routes_avoid_corners_that_break_c3() -> None:
    """A wall whose lower end lies 400 m from the first field: a blocked leg across it goes
    round the far (upper) end, whose corners keep C3, not round the near one, ~1.4 km
    shorter, whose corners hear the whole field."""
    wall = {"no_fly_zones": [{"vertices": [[1000, 1900], [1100, 1900], [1100, 4000],
                                           [1000, 4000]]}]}
    p = Problem(_fields_map(wall))
    seeder = p.seeder
    bad = p.model.rates(seeder.graph.nodes).sum(axis=1) > p.model.bandwidth
    assert bad.any() and not bad.all()
    M, centre = seeder.route(np.array([[500.0, 2500.0], [1600.0, 2500.0]]))
    corners = M[~centre]
    assert len(corners) and np.all(corners[:, 1] > 3900)  # round the upper end
    assert np.all(p.model.rates(corners).sum(axis=1) <= p.model.bandwidth)
    # without the charge the shorter way round the lower end is taken (the legs' corners,
    # kept for the charged weights, forgotten)
    seeder._route_weights, seeder._c3_bad = None, np.zeros_like(bad)
    seeder._legs.clear()
    M, centre = seeder.route(np.array([[500.0, 2500.0], [1600.0, 2500.0]]))
    assert np.all(M[~centre][:, 1] < 2000)
