"""ENU metres <-> WGS84 through a map origin (lamde_mission.geo)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lamde_mission.geo import enu_to_latlon, latlon_to_enu, origin_of
from planner_core.model.mapio import load_map

ORIGINS = [
    (22.3193, 114.1694, 0.0),  # the default origin (Hong Kong)
    (23.0493, 113.3975, 10.0),  # the suite's origin
    (-35.3632, 149.1652, 584.0),  # southern / eastern hemisphere, high ground
    (47.3977, -122.3, 20.0),  # western hemisphere
    (69.65, 18.96, 0.0),  # high latitude
]


@pytest.mark.parametrize("origin", ORIGINS)
def test_round_trip_over_a_10_km_map_within_a_millimetre(origin):
    g = np.linspace(-10_000.0, 10_000.0, 41)
    x, y = np.meshgrid(g, g)
    lat, lon = enu_to_latlon(x, y, origin)
    e, n = latlon_to_enu(lat, lon, origin)
    err = np.hypot(e - x, n - y)
    assert err.max() < 1e-3  # the requirement is 1 cm; the iteration gives ~1e-8 m
    assert lat.shape == x.shape and lon.shape == x.shape


def test_origin_maps_to_itself_and_axes_point_east_and_north():
    o = ORIGINS[0]
    lat, lon = enu_to_latlon(0.0, 0.0, o)
    assert float(lat) == pytest.approx(o[0], abs=1e-12)
    assert float(lon) == pytest.approx(o[1], abs=1e-12)
    lat_n, lon_n = enu_to_latlon(0.0, 1000.0, o)
    lat_e, lon_e = enu_to_latlon(1000.0, 0.0, o)
    # 1 km north is ~0.009 degrees of latitude; 1 km east ~0.009 / cos(lat) of longitude
    assert float(lat_n) - o[0] == pytest.approx(1000.0 / 110_750.0, rel=5e-3)
    assert float(lon_n) == pytest.approx(o[1], abs=1e-9)
    assert float(lon_e) - o[1] == pytest.approx(
        1000.0 / (111_320.0 * math.cos(math.radians(o[0]))), rel=5e-3
    )
    assert float(lat_e) == pytest.approx(o[0], abs=1e-6)  # east is a great circle, ~0 lat drift


def test_altitude_of_the_origin_does_not_move_points_much():
    o = np.array([22.0, 114.0])
    a = np.array(enu_to_latlon(5000.0, -3000.0, (*o, 0.0))) - o
    b = np.array(enu_to_latlon(5000.0, -3000.0, (*o, 2000.0))) - o
    # same horizontal metres on higher ground: the angles shrink by about h / R ~ 3e-4
    np.testing.assert_allclose(b / a, 1.0 - 2000.0 / 6.37e6, rtol=2e-5)


def test_scalars_and_arrays_broadcast():
    lat, lon = enu_to_latlon(np.array([0.0, 100.0, 200.0]), 50.0, ORIGINS[1])
    assert lat.shape == (3,) and lon.shape == (3,)
    e, n = latlon_to_enu(lat, lon, ORIGINS[1])
    np.testing.assert_allclose(e, [0.0, 100.0, 200.0], atol=1e-6)
    np.testing.assert_allclose(n, 50.0, atol=1e-6)


def test_origin_of_accepts_a_map_and_tuples():
    m = load_map({
        "origin": {"lat": 10.5, "lon": -20.25, "alt": 7.0},
        "area": {"width": 100, "height": 100}, "start": [0, 0], "end": [10, 10],
        "sensors": [{"id": "s", "x": 50, "y": 50}],
    })  # fmt: skip
    assert origin_of(m) == (10.5, -20.25, 7.0)
    assert origin_of(m.spec) == (10.5, -20.25, 7.0)
    assert origin_of((1.0, 2.0)) == (1.0, 2.0, 0.0)
    assert origin_of((1.0, 2.0, 3.0)) == (1.0, 2.0, 3.0)
