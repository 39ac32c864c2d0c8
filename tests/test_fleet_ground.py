"""SEPARATION counts vehicles on the ground (`sim.fleet_time.conflicts`): a vehicle not yet
launched stands at its first position, one after its last landing at its last, and a vehicle
landing on or taking off from the spot where another stands fails, also when their tracks
never overlap in time. Two vehicles both on the ground are not compared."""

from __future__ import annotations

import numpy as np
import pytest

from sim.fleet_time import AIRBORNE_M, VehicleTrack, conflicts, fleet_time_verdicts

P = (0.0, 0.0)  # the pad both vehicles use in the failing cases


def _tr(rows: list[tuple[float, float, float]], launch: float = 0.0, *, dt: float = 1.0,
        sending: bool = False) -> VehicleTrack:
    """A track from its samples (x, y, z) m, one per grid step; one sensor sending to it the
    whole time when `sending`."""
    a = np.asarray(rows, dtype=float)
    send = np.full((len(a) - 1, 1), sending)
    return VehicleTrack(float(launch), dt, a[:, :2], a[:, 2], send)


def _fly(p: tuple[float, float], q: tuple[float, float], z: float,
         steps: int) -> list[tuple[float, float, float]]:
    """`steps` samples at altitude z from p (excluded) to q (included), evenly spaced."""
    f = np.linspace(0.0, 1.0, steps + 1)[1:]
    return [(p[0] + (q[0] - p[0]) * u, p[1] + (q[1] - p[1]) * u, z) for u in f]


def _up(at: tuple[float, float], zs: tuple[float, ...]) -> list[tuple[float, float, float]]:
    """Samples standing / climbing / descending over one spot at the altitudes zs."""
    return [(at[0], at[1], z) for z in zs]


def _lands_at_p(sending: bool = False) -> VehicleTrack:
    """Vehicle A: launched at 0 from (-500, 0), flies to P at 40 m, drops onto P in one step
    (t = 55 s) and its track ends there: it stands on P for good."""
    q = (-500.0, 0.0)
    rows = _up(q, (0.0, 10.0, 20.0, 30.0, 40.0)) + _fly(q, P, 40.0, 50) + _up(P, (0.0,))
    return _tr(rows, 0.0, sending=sending)


def _takes_off(pad: tuple[float, float], launch: float, sending: bool = False) -> VehicleTrack:
    """Vehicle B: from `pad` (climbing slowly: 1 m one second after its launch), east 500 m
    at 40 m, and down."""
    far = (pad[0] + 500.0, pad[1])
    rows = (_up(pad, (0.0, 1.0, 5.0, 10.0, 20.0, 40.0)) + _fly(pad, far, 40.0, 50)
            + _up(far, (0.0,)))
    return _tr(rows, launch, sending=sending)


def test_taking_off_from_the_spot_where_a_landed_vehicle_stands_fails() -> None:
    """(1) A lands on P at 55 s and stays; B, launched at 200 s (the tracks never overlap in
    time: the old rule compared nothing), climbs off P: 1 m above A standing there."""
    a, b = _lands_at_p(sending=True), _takes_off(P, 200.0, sending=True)
    d, at, t_link, j, n = conflicts(a, b)
    assert d == pytest.approx(1.0) and at == 201.0
    # LINKS is unchanged: a vehicle on the ground receives nothing, the two never share a step
    assert np.isnan(t_link) and j == -1 and n == 0
    assert conflicts(b, a)[:2] == (d, at)  # either order
    sep, links = fleet_time_verdicts([a, b], ["s0"], separation=30.0)
    assert not sep.passed and sep.margin == pytest.approx(-29.0)
    assert sep.detail == "closest: vehicles 1 and 2 1.0 m apart at 201 s (vehicle 1 on the ground)"
    assert links.passed


def test_a_pad_more_than_the_separation_away_passes() -> None:
    """(2) B takes off from a pad 35 m east of P (where A stands): 35.01 m at its first climb
    step, cleared at 30 m; at 40 m it fails on the same approach."""
    a, b = _lands_at_p(), _takes_off((35.0, 0.0), 200.0)
    d, at, *_ = conflicts(a, b)
    assert d == pytest.approx(np.hypot(35.0, 1.0)) and at == 201.0
    sep, _ = fleet_time_verdicts([a, b], [], separation=30.0)
    assert sep.passed and sep.margin == pytest.approx(np.hypot(35.0, 1.0) - 30.0)
    assert "(vehicle 1 on the ground)" in sep.detail
    assert not fleet_time_verdicts([a, b], [], separation=40.0)[0].passed


def test_landing_on_the_spot_where_a_vehicle_waits_to_launch_fails() -> None:
    """(3) A lands on P, swaps for 20 s, climbs off P (2 m one step after) and ends far away;
    B stands on P, launched only at 300 s, after A's track ended: A on top of it."""
    q, r = (-500.0, 0.0), (0.0, 500.0)
    rows = (_up(q, (0.0, 20.0, 40.0)) + _fly(q, P, 40.0, 30) + _up(P, (0.0,) * 20)
            + _up(P, (2.0, 10.0, 40.0)) + _fly(P, r, 40.0, 30) + _up(r, (0.0,)))
    a = _tr(rows)
    takeoff = 3 + 30 + 20  # A's first step off P again
    assert a.span < 300.0
    b = _takes_off(P, 300.0)  # east of P: never near A's last position r
    d, at, *_ = conflicts(a, b)
    assert d == pytest.approx(2.0) and at == float(takeoff)
    sep, _ = fleet_time_verdicts([a, b], [])
    assert not sep.passed
    assert sep.detail == (f"closest: vehicles 1 and 2 2.0 m apart at {takeoff} s "
                          "(vehicle 2 on the ground)")


def test_two_vehicles_only_on_the_ground_together_are_not_compared() -> None:
    """(4) Two vehicles standing on one spot the whole time, overlapping in time or not: no
    vehicle in the air, nothing to compare (inf, nan), SEPARATION passes."""
    a = _tr(_up(P, (0.0,) * 40))
    for launch in (0.0, 10.0, 100.0):
        b = _tr(_up(P, (0.0, 0.3, 0.5, 0.0)), launch)  # 0.5 m: not above AIRBORNE_M
        d, at, *_ = conflicts(a, b)
        assert d == np.inf and np.isnan(at)
        sep, _ = fleet_time_verdicts([a, b], [])
        assert sep.passed and sep.margin == np.inf
        assert sep.detail == "never a vehicle in the air beside another"


def test_two_vehicles_in_the_air_are_judged_as_before() -> None:
    """(5) Crossing at the same time, both airborne, pads 500 m apart: 10 m at the crossing,
    the same as both-airborne over the shared window, and no vehicle on the ground named."""
    west, east, south, north = (-500.0, 0.0), (500.0, 0.0), (0.0, -500.0), (0.0, 500.0)
    a = _tr(_up(west, (0.0, 50.0)) + _fly(west, east, 50.0, 100) + _up(east, (0.0,)))
    b = _tr(_up(south, (0.0, 60.0)) + _fly(south, north, 60.0, 100) + _up(north, (0.0,)))
    d, at, *_ = conflicts(a, b)
    both = (a.z > AIRBORNE_M) & (b.z > AIRBORNE_M)
    old = np.where(both, np.sqrt(((a.xy - b.xy) ** 2).sum(axis=1) + (a.z - b.z) ** 2), np.inf)
    assert d == pytest.approx(10.0) == pytest.approx(old.min())
    assert at == float(np.argmin(old)) == 51.0
    sep, _ = fleet_time_verdicts([a, b], [], separation=30.0)
    assert not sep.passed and sep.detail == "closest: vehicles 1 and 2 10.0 m apart at 51 s"


def _where(tr: VehicleTrack, step: int) -> tuple[float, float, float]:
    """A vehicle's (x, y, z) at a clock step by the rule, one step at a time."""
    k = step - int(round(tr.launch / tr.dt))
    if k < 0:
        return float(tr.xy[0, 0]), float(tr.xy[0, 1]), 0.0
    if k >= len(tr.z):
        return float(tr.xy[-1, 0]), float(tr.xy[-1, 1]), 0.0
    return float(tr.xy[k, 0]), float(tr.xy[k, 1]), float(tr.z[k])


def _least_by_reference(a: VehicleTrack, b: VehicleTrack) -> float:
    """Every clock step from the earlier launch to the later track's end, each vehicle where
    the rule puts it, compared when at least one is above AIRBORNE_M."""
    first = min(int(round(a.launch / a.dt)), int(round(b.launch / b.dt)))
    last = max(int(round(a.launch / a.dt)) + len(a.z) - 1,
               int(round(b.launch / b.dt)) + len(b.z) - 1)
    least = np.inf
    for step in range(first, last + 1):
        pa, pb = _where(a, step), _where(b, step)
        if pa[2] > AIRBORNE_M or pb[2] > AIRBORNE_M:
            least = min(least, float(np.sqrt(sum((u - v) ** 2 for u, v in zip(pa, pb,
                                                                               strict=True)))))
    return least


def _random_track(rng: np.random.Generator, dt: float) -> VehicleTrack:
    """A short track with ground phases (z <= 0.5, some exactly 0) between flying ones, in a
    100 m box, launched on the grid somewhere in the first 60 steps."""
    n = int(rng.integers(2, 25))
    xy = rng.uniform(0.0, 100.0, size=(n, 2))
    z = rng.uniform(0.0, 40.0, size=n)
    down = rng.random(n) < 0.4
    z[down] = rng.choice([0.0, 0.3, 0.5], size=int(down.sum()))
    if rng.random() < 0.15:
        z[:] = 0.0  # never airborne
    return VehicleTrack(float(rng.integers(0, 60)) * dt, dt, xy, z,
                        np.zeros((n - 1, 0), dtype=bool))


@pytest.mark.parametrize("dt", [1.0, 2.0])
def test_the_fast_path_equals_a_step_by_step_reference(dt: float) -> None:
    """(6) 50 random pairs (launches near and far apart in time, ground phases, vehicles never
    airborne): `conflicts`'s least distance is the reference's, and its time is a step where
    the reference sees that distance with one of the two airborne."""
    rng = np.random.default_rng(59)
    kinds = set()
    for _ in range(50):
        a, b = _random_track(rng, dt), _random_track(rng, dt)
        if rng.random() < 0.1:  # neither ever airborne
            a, b = (VehicleTrack(t.launch, dt, t.xy, np.zeros_like(t.z), t.sending)
                    for t in (a, b))
        want = _least_by_reference(a, b)
        d, at, *_ = conflicts(a, b)
        assert d == pytest.approx(want)
        if np.isinf(want):
            assert np.isnan(at)
            kinds.add("none")
            continue
        step = int(round(at / dt))
        pa, pb = _where(a, step), _where(b, step)
        assert max(pa[2], pb[2]) > AIRBORNE_M
        assert np.sqrt(sum((u - v) ** 2 for u, v in zip(pa, pb, strict=True))) == \
            pytest.approx(d)
        apart = (a.launch + a.span < b.launch) or (b.launch + b.span < a.launch)
        kinds.add("apart" if apart else "overlap")
    assert kinds == {"none", "apart", "overlap"}  # each case drawn at least once


def test_timing_tolerance_finds_a_vehicle_standing_outside_its_airborne_box() -> None:
    """A waits on its pad P until 500 s, then leaves it sideways (its first airborne sample
    100 m east: its airborne box starts there) for 1 km east; B, launched at 0 far west,
    passes 20 m from P at 10 m and is down long before A launches. The pair is far apart in
    time and their airborne boxes 120 m apart, yet B flies 22.4 m from A standing on P, at
    every shift: `timing_tolerance` 0 (a prefilter on airborne boxes, or on time, skipped
    the pair: `cap`)."""
    from sim.fleet_time import timing_tolerance

    east, west = (1000.0, 0.0), (-200.0, 0.0)
    a = _tr([(0.0, 0.0, 0.0)] + _fly((0.0, 0.0), east, 40.0, 10) + _up(east, (0.0,)), 500.0)
    near = (-20.0, 0.0)
    b = _tr(_up(west, (0.0, 10.0)) + _fly(west, near, 10.0, 9) + _fly(near, west, 10.0, 9)
            + _up(west, (0.0,)))
    d, at, *_ = conflicts(a, b)
    assert d == pytest.approx(np.hypot(20.0, 10.0)) and at == 10.0
    sep, _ = fleet_time_verdicts([a, b], [], separation=30.0)
    assert not sep.passed and sep.detail.endswith("(vehicle 1 on the ground)")
    assert timing_tolerance([a, b], separation=30.0, cap=20.0) == 0.0
    # pads and paths 40 m farther apart: no shift within the cap meets
    b_far = VehicleTrack(b.launch, b.dt, b.xy - [40.0, 0.0], b.z, b.sending)
    assert timing_tolerance([a, b_far], separation=30.0, cap=20.0) == 20.0
