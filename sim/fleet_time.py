"""Vehicles in the air at once (issue 33's fleets): their separation, and a sensor heard by two.

Each vehicle flies its sorties back to back from its launch time (fleet.json's `launch_s`,
seconds after the first vehicle's take-off), with a battery swap of `swap_s` on the ground
between them; a sortie's replay (`sim.replay.Timeline`: t, xy, z, data) places the vehicle on
the shared clock. On a grid of `dt` seconds, two verdicts:

- **SEPARATION**: two vehicles of which at least one is airborne (above `AIRBORNE_M`) are never
  closer than the map's `fleet.separation_m` (3D distance; the caller passes it in, default
  `SEPARATION_M`). A pair is judged over the span from the earlier of its two launches to the
  later of its two tracks' ends: a vehicle not yet launched stands on the ground at its first
  position (its track's xy[0], z = 0), and a vehicle after its last landing stands at its last
  position (xy[-1], z = 0); during a swap it stands where its track has it. Two vehicles both
  on the ground are not compared (they do not move). So vehicles taking off from one depot at
  once, flying the same legs at the same altitude, landing on one spot seconds apart, or
  landing on (taking off from) the spot where another stands waiting, swapping or done, fail
  it: in the field that is a collision on the pad.
- **LINKS**: no sensor sends to two vehicles at the same time. The link model (paper Sec. 3)
  gives a sensor one uplink at R_ij; two vehicles hovering in its range at once would each be
  credited the full rate, data the sensor cannot send. Judged only while both vehicles are on
  the clock (between their launches and last landings); a vehicle on the ground receives
  nothing.

Positions between samples are linear (the replay samples each phase at `dt` or finer). Like
the rest of the sim it imports of `planner_core` only the defaults table (`SEPARATION_M`'s
value); the map's separation comes in as an argument.
Cost: O(V^2 x T / dt) for SEPARATION and O(V^2 x K x T / dt) for LINKS, T the longest span
(a pair costs its two spans, never the time between them: before, between and after them
both stand still) and K the sensors two vehicles both hear (0 when they serve different
sensors); building a track O(sorties x J x T / dt).
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


def _steps(a: VehicleTrack, b: VehicleTrack) -> tuple[np.ndarray, int, int]:
    """The clock's grid steps on which a or b is inside its track (outside both, both stand
    on the ground), ascending, and each one's launch step. At most len(a.z) + len(b.z) steps
    however far apart the two are in time."""
    da = int(round(a.launch / a.dt))
    db = int(round(b.launch / b.dt))
    na, nb = len(a.z), len(b.z)
    lo, hi = min(da, db), max(da + na, db + nb)
    if hi - lo <= na + nb:  # the two tracks overlap or touch: one run of steps
        return np.arange(lo, hi), da, db
    (d0, n0), (d1, n1) = sorted(((da, na), (db, nb)))
    return np.concatenate([np.arange(d0, d0 + n0), np.arange(d1, d1 + n1)]), da, db


def _placed(tr: VehicleTrack, steps: np.ndarray, first: int) -> tuple[np.ndarray, np.ndarray]:
    """Where a vehicle launched at grid step `first` is at clock steps `steps`: its track's
    samples inside it; before, on the ground at its first position; after, at its last (index
    clamping: nothing is built for the time outside the track). xy (S, 2) m, z (S,) m."""
    k = steps - first
    i = np.clip(k, 0, len(tr.z) - 1)
    return tr.xy[i], np.where((k >= 0) & (k < len(tr.z)), tr.z[i], 0.0)


def _on_ground(tr: VehicleTrack, at: float) -> bool:
    """Is the vehicle on the ground at clock time `at` s (not yet launched, landed for good, or
    at most `AIRBORNE_M` up inside its track)?"""
    k = int(round(at / tr.dt)) - int(round(tr.launch / tr.dt))
    return not (0 <= k < len(tr.z) and tr.z[k] > AIRBORNE_M)


def conflicts(a: VehicleTrack, b: VehicleTrack) -> tuple[float, float, float, int, int]:
    """The closest approach of two vehicles, at least one in the air, and their first shared
    link (module docstring).

    SEPARATION's distance is taken over the span from the earlier launch to the later track's
    end: a vehicle not launched yet stands at its first position (xy[0], z = 0), one after its
    last landing at its last (xy[-1], z = 0); on grid steps where both are on the ground the
    two are not compared. So two tracks that never overlap in time are still compared (one
    landed on a spot the other takes off from later fails). LINKS only counts the steps where
    both are on the clock. Cost: O((len(a.z) + len(b.z)) x (1 + K)), K the sensors both hear:
    the steps inside either track, each track indexed (clamped) in place, never the time
    between the two tracks.

    Args:
        a, b: the tracks (same dt), each at its launch time.

    Returns:
        (least 3D distance m on the steps where at least one of them is airborne (inf if
        neither ever is), its clock time s (nan if inf; the first such step on a tie), the
        first clock time s at which a sensor sends to both (nan if never), that sensor's index
        into the map's sensors (-1 if none), how many grid steps some sensor sends to both (0
        if none)). The link entries are nan, -1, 0 when the two are never on the clock
        together.
    """
    steps, da, db = _steps(a, b)
    xa, za = _placed(a, steps, da)
    xb, zb = _placed(b, steps, db)
    air = (za > AIRBORNE_M) | (zb > AIRBORNE_M)
    d = np.where(air, np.sqrt(((xa - xb) ** 2).sum(axis=1) + (za - zb) ** 2), np.inf)
    i = int(np.argmin(d))
    least = float(d[i])
    at = float(steps[i]) * a.dt if np.isfinite(least) else np.nan
    w = _window(a, b)
    if w is None:
        return least, at, np.nan, -1, 0
    sa, sb = w
    base = max(a.launch, b.launch)
    ca, cb = a.columns(), b.columns()
    common, ia, ib = np.intersect1d(ca, cb, return_indices=True)
    if not len(common):  # no sensor heard by both, ever
        return least, at, np.nan, -1, 0
    ea = slice(sa.start, sa.stop - 1)
    eb = slice(sb.start, sb.stop - 1)
    both = a.sending[ea][:, ia] & b.sending[eb][:, ib]
    steps_both = np.flatnonzero(both.any(axis=1))
    if not len(steps_both):
        return least, at, np.nan, -1, 0
    s0 = int(steps_both[0])
    return least, at, base + s0 * a.dt, int(common[np.flatnonzero(both[s0])[0]]), \
        len(steps_both)


def fleet_time_verdicts(tracks: Sequence[VehicleTrack], sensor_ids: Sequence[str],
                        separation: float = SEPARATION_M,
                        numbers: Sequence[int] | None = None) -> list[Verdict]:
    """SEPARATION and LINKS over every pair of vehicles (module docstring): SEPARATION holds
    when no two vehicles, at least one airborne, come closer than `separation`, a vehicle
    standing at its first position before its launch and at its last after its last landing
    (`conflicts`); LINKS only while both are on the clock. Cost: O(V^2 x T / dt (1 + K)).

    Args:
        tracks: one per vehicle (vehicle k + 1 at index k), each at its launch time.
        sensor_ids: the map's sensors, in the order of the tracks' `sending` columns.
        separation: m, the least distance allowed: the map's `fleet.separation_m`
            (`Map.separation_m`), > 0.
        numbers: each track's vehicle number as the details name it (fleet.json's; a
            vehicle without a sortie has no track); default 1, 2, ... in order.

    Returns:
        [SEPARATION, LINKS]. SEPARATION's margin: least distance with at least one of the two
        airborne - separation, m (+inf when no vehicle is ever airborne, or fewer than two
        vehicles); its detail names the closest pair, when, and which one stood on the ground
        then if one did. LINKS's: minus the grid steps shared over every pair that shares a
        sensor, "steps" (0 when none does); its detail names the pair sharing the most steps
        (the first such pair in index order on a tie).
    """
    no = list(numbers) if numbers is not None else list(range(1, len(tracks) + 1))
    if len(no) != len(tracks):
        raise ValueError(f"numbers: {len(no)} for {len(tracks)} tracks")
    least, worst, shared, steps, pairs = np.inf, None, None, 0, 0
    for i in range(len(tracks)):
        for k in range(i + 1, len(tracks)):
            d, at, t_link, j, n = conflicts(tracks[i], tracks[k])
            if d < least:
                least, worst = d, (i, k, at)
            if n:
                steps, pairs = steps + n, pairs + 1
                if shared is None or n > shared[4]:
                    shared = (no[i], no[k], t_link, sensor_ids[j], n)
    if worst is None:
        sep = Verdict("SEPARATION", f"vehicles >= {separation:g} m apart", True, np.inf, "m",
                      "never a vehicle in the air beside another")
    else:
        i1, i2, at = worst
        down = [no[i] for i in (i1, i2) if _on_ground(tracks[i], at)]
        where = f" (vehicle {down[0]} on the ground)" if down else ""
        sep = Verdict("SEPARATION", f"vehicles >= {separation:g} m apart",
                      bool(least >= separation), float(least - separation), "m",
                      f"closest: vehicles {no[i1]} and {no[i2]} {least:.1f} m apart at "
                      f"{at:.0f} s{where}")
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
    conflicts is searched outward from their planned offset. SEPARATION is `conflicts`'s:
    at least one of the two airborne, a vehicle standing at its first position before its
    launch and at its last after its last landing, so two vehicles far apart in time still
    meet when one flies near where the other stands. Pairs that cannot meet are skipped: each
    vehicle's box holds every position of its track (airborne, and on the ground: its first
    and last, where it swaps), and a pair is skipped when the boxes are farther apart than
    `separation` and either no sensor is heard by both or the two tracks are more than 2 `cap`
    apart in time (LINKS needs both on the clock); time alone never skips a pair (a vehicle
    stands on the ground for ever before and after its flights). Sorties of one vehicle never
    fly at once. Cost: per pair of vehicles that can meet, at most 4 `cap` / dt + 1 shifts,
    each O((T_a + T_b) / dt) for T_a, T_b the two spans.

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
    # every position a vehicle is ever at: airborne, swapping, and standing before / after
    boxes = [(tr.xy.min(axis=0), tr.xy.max(axis=0)) for tr in tracks]
    widest = int(np.floor(2.0 * cap / dt))
    least = widest + 1  # the smallest conflicting relative shift found, in steps
    for i in range(len(tracks)):
        for k in range(i + 1, len(tracks)):
            a, b = tracks[i], tracks[k]
            gap = np.maximum(np.maximum(boxes[i][0] - boxes[k][1], boxes[k][0] - boxes[i][1]),
                             0.0)
            if float(np.hypot(*gap)) > separation and (
                    b.launch - (a.launch + a.span) > 2 * cap
                    or a.launch - (b.launch + b.span) > 2 * cap
                    or not len(np.intersect1d(a.columns(), b.columns()))):
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
    """Do two tracks, at their launches, come closer than `separation` with one of them in the
    air (`conflicts`: standing at their first / last positions outside their tracks) or share a
    sending sensor?"""
    d, _, _, _, n = conflicts(a, b)
    return d < separation or n > 0
