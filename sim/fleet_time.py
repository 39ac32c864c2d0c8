"""Vehicles in the air at once (issue 33's fleets): their separation, and a sensor heard by two.

Each vehicle flies its sorties back to back from its launch time (fleet.json's `launch_s`,
seconds after the first vehicle's take-off), with a battery swap of `swap_s` on the ground
between them; a sortie's replay (`sim.replay.Timeline`: t, xy, z, data) places the vehicle on
the shared clock. On a grid of `dt` seconds, two verdicts:

- **SEPARATION**: two vehicles both airborne (above `AIRBORNE_M`) are never closer than the
  map's `fleet.separation_m` (3D; the caller passes it in, default `SEPARATION_M`). Vehicles
  taking off from one depot at once, flying the same legs at the same altitude, or landing on
  one spot seconds apart fail it.
- **LINKS**: no sensor sends to two vehicles at the same time. The link model (paper Sec. 3)
  gives a sensor one uplink at R_ij; two vehicles hovering in its range at once would each be
  credited the full rate, data the sensor cannot send.

Positions between samples are linear (the replay samples each phase at `dt` or finer); a
vehicle on the ground (before its launch, during a swap, after its last landing) is not
airborne and receives nothing. Like the rest of the sim it imports of `planner_core` only the
defaults table (`SEPARATION_M`'s value); the map's separation comes in as an argument.
Cost: O(V^2 x T / dt) for SEPARATION and O(V^2 x K x T / dt) for LINKS, T the longest span
and K the sensors two vehicles both hear (0 when they serve different sensors); building a
track O(sorties x J x T / dt).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planner_core.defaults import MAP_DEFAULTS
from sim.checks import Verdict
from sim.replay import Timeline

__all__ = ["SEPARATION_M", "AIRBORNE_M", "VehicleTrack", "track", "conflicts",
           "fleet_time_verdicts", "timing_tolerance", "TOLERANCE_CAP_S"]  # fmt: skip

#: m, the least 3D distance between two vehicles in the air when the caller gives none: the
#: default of the map's `fleet.separation_m` (GNSS position error of a few metres each, the
#: 10 m obstacle clearance of the map's default, and rotor wash, with room)
SEPARATION_M: float = float(MAP_DEFAULTS["fleet.separation_m"].value)
#: m above home: a vehicle lower than this is on the ground (taking off or landed)
AIRBORNE_M = 0.5
#: Mbit per grid step below which a sensor is not sending (rounding of the replay's sums)
_SENDING = 1e-9


@dataclass(frozen=True)
class VehicleTrack:
    """One vehicle on the shared clock, sampled every `dt` s from time 0 (its launch at
    `launch` s): positions xy (N, 2) m, altitude z (N,) m (0 on the ground), and which sensors
    send to it in each step, `sending` (N - 1, K) bool for the K sensors `sensors` (indices
    into the map's; None: all J, K = J). Keeping only the sensors a vehicle ever hears makes
    two vehicles serving other sensors cost nothing to compare."""

    launch: float
    dt: float
    xy: np.ndarray
    z: np.ndarray
    sending: np.ndarray
    sensors: np.ndarray | None = None

    def at(self, launch: float) -> VehicleTrack:
        """The same track launched at another time (arrays shared, not copied).

        Args:
            launch: seconds after the first vehicle's take-off (fleet.json's `launch_s`).

        Returns:
            The moved track.
        """
        return VehicleTrack(float(launch), self.dt, self.xy, self.z, self.sending, self.sensors)

    def columns(self) -> np.ndarray:
        """The map's sensor indices of the `sending` columns.

        Returns:
            (K,) int: `sensors`, or 0..J-1 when it is None.
        """
        return (np.arange(self.sending.shape[1]) if self.sensors is None
                else np.asarray(self.sensors))  # fmt: skip

    @property
    def span(self) -> float:
        """The track's length in time.

        Returns:
            Seconds from the launch to the last landing, (samples - 1) x dt.
        """
        return (len(self.z) - 1) * self.dt


def track(sorties: Sequence[Timeline], swap_s: float, *, dt: float = 1.0) -> VehicleTrack:
    """One vehicle's sorties (replays, in flying order) on its own clock, launch at 0.

    Args:
        sorties: the replays; each starts at its take-off, on the ground at its depot.
        swap_s: seconds on the ground between two sorties.
        dt: grid step (s), > 0.

    Returns:
        The `VehicleTrack` (launch 0).

    Raises:
        ValueError: no sortie, or dt <= 0.
    """
    if not len(sorties):
        raise ValueError("sorties: a vehicle flies at least one sortie")
    if not dt > 0:
        raise ValueError("dt must be positive")
    J = len(sorties[0].sensor_ids)
    starts, clock = [], 0.0
    for k, tl in enumerate(sorties):
        starts.append(clock)
        clock += float(tl.totals.t_total) + (swap_s if k + 1 < len(sorties) else 0.0)
    n = int(np.floor(clock / dt)) + 1
    grid = np.arange(n) * dt
    xy = np.zeros((n, 2))
    z = np.zeros(n)
    # only the sensors this vehicle hears at all: the rest never send to it
    heard = np.flatnonzero(np.any([tl.data[-1] > _SENDING for tl in sorties], axis=0)) \
        if J else np.zeros(0, dtype=np.int64)
    data = np.zeros((n, len(heard)))
    for k, tl in enumerate(sorties):
        t0, t1 = starts[k], starts[k] + float(tl.totals.t_total)
        local = tl.t
        # on the ground before this sortie (its depot) and after it until the next one
        before = grid < t0
        inside = (grid >= t0) & (grid <= t1)
        after = grid > t1
        g = grid[inside] - t0
        for c in range(2):
            xy[inside, c] = np.interp(g, local, tl.xy[:, c])
        z[inside] = np.interp(g, local, tl.z)
        if k == 0:
            xy[before] = tl.xy[0]
        xy[after] = tl.xy[-1]
        z[after] = 0.0
        for c, j in enumerate(heard):
            data[inside, c] += np.interp(g, local, tl.data[:, j])
            data[after, c] += float(tl.data[-1, j])
    sending = np.diff(data, axis=0) > _SENDING
    return VehicleTrack(0.0, float(dt), xy, np.maximum(z, 0.0), sending, heard)


def _window(a: VehicleTrack, b: VehicleTrack) -> tuple[slice, slice] | None:
    """Index ranges of a and b covering the same clock times (both launched on the grid)."""
    da = int(round(a.launch / a.dt))
    db = int(round(b.launch / b.dt))
    lo = max(da, db)
    hi = min(da + len(a.z), db + len(b.z))
    if hi - lo < 2:
        return None
    return slice(lo - da, hi - da), slice(lo - db, hi - db)


def conflicts(a: VehicleTrack, b: VehicleTrack) -> tuple[float, float, float, int, int]:
    """The closest approach of two vehicles in the air and their first shared link.

    Args:
        a, b: the tracks (same dt), each at its launch time.

    Returns:
        (least distance m while both airborne (inf if never), its clock time s, the first
        clock time s at which a sensor sends to both (nan if never), that sensor's index into
        the map's sensors (-1 if none), how many grid steps some sensor sends to both (0 if
        none)). nan times and 0 steps when the two are never on the clock together.
    """
    w = _window(a, b)
    if w is None:
        return np.inf, np.nan, np.nan, -1, 0
    sa, sb = w
    base = max(a.launch, b.launch)
    air = (a.z[sa] > AIRBORNE_M) & (b.z[sb] > AIRBORNE_M)
    d = np.sqrt(((a.xy[sa] - b.xy[sb]) ** 2).sum(axis=1) + (a.z[sa] - b.z[sb]) ** 2)
    d = np.where(air, d, np.inf)
    i = int(np.argmin(d))
    least, at = float(d[i]), base + i * a.dt
    ca, cb = a.columns(), b.columns()
    common, ia, ib = np.intersect1d(ca, cb, return_indices=True)
    if not len(common):  # no sensor heard by both, ever
        return least, at, np.nan, -1, 0
    ea = slice(sa.start, sa.stop - 1)
    eb = slice(sb.start, sb.stop - 1)
    both = a.sending[ea][:, ia] & b.sending[eb][:, ib]
    steps = np.flatnonzero(both.any(axis=1))
    if not len(steps):
        return least, at, np.nan, -1, 0
    s0 = int(steps[0])
    return least, at, base + s0 * a.dt, int(common[np.flatnonzero(both[s0])[0]]), len(steps)


def fleet_time_verdicts(tracks: Sequence[VehicleTrack], sensor_ids: Sequence[str],
                        separation: float = SEPARATION_M) -> list[Verdict]:
    """SEPARATION and LINKS over every pair of vehicles (module docstring).

    Args:
        tracks: one per vehicle (vehicle k + 1 at index k), each at its launch time.
        sensor_ids: the map's sensors, in the order of the tracks' `sending` columns.
        separation: m, the least distance allowed: the map's `fleet.separation_m`
            (`Map.separation_m`), > 0.

    Returns:
        [SEPARATION, LINKS]. SEPARATION's margin: least airborne distance - separation, m
        (+inf when no two are in the air at once). LINKS's: minus the grid steps shared over
        every pair that shares a sensor, "steps" (0 when none does); its detail names the
        pair sharing the most steps (the first such pair in index order on a tie).
    """
    least, worst, shared, steps, pairs = np.inf, None, None, 0, 0
    for i in range(len(tracks)):
        for k in range(i + 1, len(tracks)):
            d, at, t_link, j, n = conflicts(tracks[i], tracks[k])
            if d < least:
                least, worst = d, (i + 1, k + 1, at)
            if n:
                steps, pairs = steps + n, pairs + 1
                if shared is None or n > shared[4]:
                    shared = (i + 1, k + 1, t_link, sensor_ids[j], n)
    if worst is None:
        sep = Verdict("SEPARATION", f"vehicles >= {separation:g} m apart", True, np.inf, "m",
                      "never two vehicles in the air at once")
    else:
        v1, v2, at = worst
        sep = Verdict("SEPARATION", f"vehicles >= {separation:g} m apart",
                      bool(least >= separation), float(least - separation), "m",
                      f"closest: vehicles {v1} and {v2} {least:.1f} m apart at {at:.0f} s")
    if shared is None:
        links = Verdict("LINKS", "a sensor sends to one vehicle at a time", True, 0.0, "steps",
                        "no sensor heard by two vehicles at once")
    else:
        v1, v2, t_link, sid, n = shared
        more = f"; {steps} steps over {pairs} pairs of vehicles" if pairs > 1 else ""
        links = Verdict("LINKS", "a sensor sends to one vehicle at a time", False, -float(steps),
                        "steps", f"sensor '{sid}' sends to vehicles {v1} and {v2} at once "
                        f"from {t_link:.0f} s ({n} steps of the grid{more})")  # fmt: skip
    return [sep, links]


#: s, the widest take-off slip `timing_tolerance` looks for (each sortie early or late by up
#: to it): beyond two minutes a crew re-plans rather than flies the schedule
TOLERANCE_CAP_S = 120.0


def timing_tolerance(tracks: Sequence[VehicleTrack], separation: float = SEPARATION_M, *,
                     cap: float = TOLERANCE_CAP_S) -> float:
    """How far each sortie may take off from its planned time with SEPARATION and LINKS
    still holding: the largest W (s, a multiple of the grid step, at most `cap`) such that
    every sortie taking off anywhere within +-W s of its time, each independently, keeps
    every two vehicles in the air `separation` apart and no sensor sending to two at once.

    Two sorties of different vehicles then fly shifted against each other by up to 2 W. A
    conflict is between two sorties, so it is enough to shift one vehicle's whole track
    against the other's by every such amount: the smallest shift at which a pair of vehicles
    conflicts is searched outward from their planned offset (pairs that cannot meet are
    skipped: flights more than 2 `cap` apart in time, or airborne boxes farther apart than
    `separation` with no sensor heard by both). Sorties of one vehicle never fly at once; a
    vehicle on the ground is not checked (as in `conflicts`). Cost: per pair of vehicles that
    can meet, at most 4 `cap` / dt + 1 shifts, each O(T / dt) for T the shorter span.

    Args:
        tracks: one per vehicle, each at its launch time, on one grid step.
        separation: m, the least distance allowed (the map's `fleet.separation_m`).
        cap: s, the largest tolerance looked for (> 0).

    Returns:
        W in s: 0 when the planned times themselves conflict (or only those), `cap` when no
        slip within it does.

    Raises:
        ValueError: cap not positive.
    """
    if not cap > 0:
        raise ValueError("cap must be positive")
    if not tracks:
        return float(cap)
    dt = tracks[0].dt
    boxes = []
    for tr in tracks:
        up = tr.z > AIRBORNE_M
        xy = tr.xy[up] if np.any(up) else tr.xy[:1]
        boxes.append((xy.min(axis=0), xy.max(axis=0)))
    widest = int(np.floor(2.0 * cap / dt))
    least = widest + 1  # the smallest conflicting relative shift found, in steps
    for i in range(len(tracks)):
        for k in range(i + 1, len(tracks)):
            a, b = tracks[i], tracks[k]
            if (b.launch - (a.launch + a.span) > 2 * cap
                    or a.launch - (b.launch + b.span) > 2 * cap):
                continue
            gap = np.maximum(np.maximum(boxes[i][0] - boxes[k][1], boxes[k][0] - boxes[i][1]),
                             0.0)
            if float(np.hypot(*gap)) > separation and not len(
                    np.intersect1d(a.columns(), b.columns())):
                continue
            for s in range(least):
                shifts = (s,) if s == 0 else (s, -s)
                if any(_conflict(a, b.at(b.launch + shift * dt), separation)
                       for shift in shifts):
                    least = s
                    break
    if least > widest:
        return float(cap)
    # conflicting at a relative shift of `least` steps: each sortie may slip (least - 1) / 2
    return float(max(least - 1, 0) // 2) * dt


def _conflict(a: VehicleTrack, b: VehicleTrack, separation: float) -> bool:
    """Do two tracks, at their launches, come closer than `separation` in the air or share a
    sending sensor?"""
    d, _, _, _, n = conflicts(a, b)
    return d < separation or n > 0
