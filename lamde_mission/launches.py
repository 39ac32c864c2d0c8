"""Launch times of a fleet's vehicles: stagger them until no two meet in the air and no sensor
sends to two at once (the simulator's SEPARATION and LINKS, `sim.fleet_time`).

The sortie planner plans each vehicle's sorties as if it flew alone; vehicles sharing a depot
would take off together and fly the same first legs at the same altitude. Vehicle 1 launches
at 0; each next vehicle at the first multiple of `STEP_S` seconds at which it conflicts with
none launched before it (greedy, in vehicle order). A launch after every earlier vehicle has
landed conflicts with nothing, so the search ends. The operator launches each vehicle at its
time (fleet.json's `launch_s`, printed by `plan` and `upload --fleet`); the makespan counts it.

Cost: per vehicle, O(tries x (V x T / dt + J x T / dt)), tries <= (the earlier vehicles' longest
span) / STEP_S.
"""

from __future__ import annotations

from collections.abc import Sequence

from sim.fleet_time import SEPARATION_M, VehicleTrack, conflicts

__all__ = ["STEP_S", "stagger"]

#: s between two launch times tried
STEP_S = 10.0


def stagger(tracks: Sequence[VehicleTrack], *, separation: float = SEPARATION_M,
            step: float = STEP_S) -> list[float]:
    """Launch times (s) for the vehicles' tracks (each on its own clock, launch 0).

    Args:
        tracks: one per vehicle, in vehicle order, on one grid step.
        separation: m, the least distance in the air: the map's `fleet.separation_m`
            (`Map.separation_m`).
        step: s between launch times tried (a multiple of the tracks' grid step).

    Returns:
        One launch time per vehicle, the first 0.
    """
    placed: list[VehicleTrack] = []
    launches: list[float] = []
    for tr in tracks:
        latest = max((p.launch + p.span for p in placed), default=0.0)
        t = 0.0
        while True:
            cand = tr.at(t)
            if t > latest or all(_clear(cand, p, separation) for p in placed):
                break
            t += step
        placed.append(cand)
        launches.append(t)
    return launches


def _clear(a: VehicleTrack, b: VehicleTrack, separation: float) -> bool:
    d, _, _, _, shared = conflicts(a, b)
    return d >= separation and shared == 0
