"""Launch times of a fleet's vehicles: stagger them until no two meet in the air and no sensor
sends to two at once (the simulator's SEPARATION and LINKS, `sim.fleet_time`).

The sortie planner plans each vehicle's sorties as if it flew alone; vehicles sharing a depot
would take off together and fly the same first legs at the same altitude. Vehicle 1 launches
at 0; each next vehicle at the first multiple of `STEP_S` seconds at which it conflicts with
none launched before it (greedy, in vehicle order), also when either is shifted against the
other by up to twice the map's `fleet.launch_tolerance_s`: each sortie may then take off that
much early or late (a crew launches to the half minute, not the second; verify's TIMING). The
search ends at the first step more than twice the tolerance after every earlier vehicle has
landed, and takes it even when it is not clear: from there on no sensor can send to two at
once, but SEPARATION counts a vehicle standing on the ground (at its first position before its
launch, at its last after its last landing: `sim.fleet_time.conflicts`), so a vehicle taking
off from, or landing on, the spot where another stands conflicts at every launch. No delay
clears that; only distinct pads do (the planner's), and verify's SEPARATION fails the plan
meanwhile. The operator launches each sortie at its time (fleet.json's `takeoff_s`, printed by
`plan` and `upload --fleet`); the makespan counts the launch.

Cost: per vehicle, O(tries' new offsets x V x T / dt (+ J x T / dt)): each offset against each
earlier vehicle is judged once (`conflicts`, O(the two spans / dt) however far apart in time),
and the tries (<= (the earlier vehicles' longest span + 2 tolerance) / STEP_S + 1) move by
STEP_S, so each brings STEP_S / dt new offsets.
"""

from __future__ import annotations

from collections.abc import Sequence

from sim.fleet_time import SEPARATION_M, VehicleTrack, conflicts

__all__ = ["STEP_S", "stagger"]

#: s between two launch times tried
STEP_S = 10.0


def stagger(tracks: Sequence[VehicleTrack], *, separation: float = SEPARATION_M,
            step: float = STEP_S, tolerance: float = 0.0) -> list[float]:
    """Launch times (s) for the vehicles' tracks (each on its own clock, launch 0).

    Args:
        tracks: one per vehicle, in vehicle order, on one grid step.
        separation: m, the least distance in the air: the map's `fleet.separation_m`
            (`Map.separation_m`).
        step: s between launch times tried (a multiple of the tracks' grid step).
        tolerance: s each sortie may take off early or late (the map's
            `fleet.launch_tolerance_s`): a launch is taken only when the vehicle is also
            clear of every earlier one shifted against it by up to twice this, on the grid
            (`sim.fleet_time.timing_tolerance` then finds at least `tolerance`); 0: clear at
            the planned times only.

    Returns:
        One launch time per vehicle, the first 0. A vehicle that no launch clears (one taking
        off from or landing on where an earlier one stands: module docstring) gets the first
        step more than 2 `tolerance` after every earlier vehicle has landed, not clear.
    """
    placed: list[VehicleTrack] = []
    launches: list[float] = []
    for tr in tracks:
        latest = max((p.launch + p.span for p in placed), default=0.0)
        slip = int(round(2.0 * tolerance / tr.dt))  # relative slip, grid steps
        seen: dict[tuple[int, int], bool] = {}

        def clear(k: int, at: int, tr: VehicleTrack = tr,
                  seen: dict[tuple[int, int], bool] = seen) -> bool:
            if (k, at) not in seen:
                seen[(k, at)] = _clear(tr.at(at * tr.dt), placed[k], separation)
            return seen[(k, at)]

        t = 0.0
        while True:
            at = int(round(t / tr.dt))
            if t - 2.0 * tolerance > latest or all(
                    clear(k, at + d) for k in range(len(placed)) for d in range(-slip, slip + 1)):
                break
            t += step
        placed.append(tr.at(t))
        launches.append(t)
    return launches


def _clear(a: VehicleTrack, b: VehicleTrack, separation: float) -> bool:
    d, _, _, _, shared = conflicts(a, b)
    return d >= separation and shared == 0
