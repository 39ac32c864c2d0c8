"""Landing pads: where each vehicle of a fleet takes off and lands at each depot (issue 33).

Several vehicles use one depot: they wait there to launch, land there and stand there through
a battery swap. Sharing one point, a vehicle would land on, or take off beside, another one
standing on the ground; the simulator's SEPARATION counts a vehicle on the ground and fails
that (`sim.fleet_time`). So each depot has pads, one for each vehicle that uses it:

* pad 1 (index 0 of a layout, `pad_layout`'s first row) is the depot itself, so a single
  vehicle flies exactly where it did before, and of the vehicles a plan sends to a depot the
  lowest-numbered stands on it (`pad_ranks`: the vehicles using a depot take its pads in the
  order of their numbers). Pads are numbered from 1 wherever a person reads them (`check`,
  the map's `fleet.depots[].pads`, which lists pads 2, 3, ...); the code indexes them from 0;
* the other pads (2, 3, ...: indices 1, 2, ...) are points of a square lattice of step
  `spacing` (the map's `fleet.separation_m` + `PAD_MARGIN_M`) aligned with east and north
  around the depot, so a crew lays each out as whole steps east or west and north or south
  of the depot ("35 m E", "35 m N, 35 m E"); taken nearest first (ties: east, north, west,
  south, then counter-clockwise), each at least `spacing` from every pad already given (any
  depot's) and accepted by the caller's test (`FREE`, or why not: outside the area, within
  `PAD_CLEAR_M` or the map's clearance of an obstacle, no clear straight leg from the depot).

Deterministic for a map. Cost: O(D x C) tests for D depots and C lattice points looked at
(C grows with the square of the rings needed: V for V vehicles on open ground), each a vector
operation over the pads given so far (at most D x V), plus the caller's test (one batch per
depot): a reviewer's 91 depots x 100 vehicles took 1.2 s of CPU (`Map.pads_for`), 87 s when
each distance was a Python call.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

# m of a leg inside obstacles at or below which the leg is clear (the routing's, one place)
from planner_core.model.routing.graph import CLEAR as CLEAR_M

__all__ = ["PAD_MARGIN_M", "PAD_CLEAR_M", "MAX_RINGS", "CLEAR_M", "FREE", "OUTSIDE", "NEAR",
           "BEHIND", "INSIDE", "pad_layout", "offset_words", "pad_ranks"]

#: m added to `fleet.separation_m` between two pads: a vehicle's landing error (GNSS, a few
#: metres) on top of the separation the simulator asks of a vehicle landing beside another
PAD_MARGIN_M = 5.0
#: m a pad keeps from every obstacle at least (the map's clearance where larger): a vehicle
#: standing there, its rotors and its landing error, clear of a wall
PAD_CLEAR_M = 5.0
#: lattice rings looked at around a depot before giving up: 100 vehicles need 5 on open ground
MAX_RINGS = 12
#: why a lattice point is no pad (the caller's test): it may be one; outside the area; within
#: the pad clearance of an obstacle; no clear straight leg from the depot; inside an obstacle
FREE, OUTSIDE, NEAR, BEHIND, INSIDE = 0, 1, 2, 3, 4


def _lattice(rings: int) -> np.ndarray:
    """Square lattice points of step 1 within `rings` rings of the origin (a square), origin
    left out, nearest first (ties by angle from east, counter-clockwise).

    Returns:
        (n, 2) unit-step offsets (east, north).
    """
    q, r = np.meshgrid(np.arange(-rings, rings + 1), np.arange(-rings, rings + 1))
    a = np.column_stack([q.ravel(), r.ravel()]).astype(float)
    a = a[np.any(a != 0, axis=1)]
    dist = np.round(np.hypot(a[:, 0], a[:, 1]), 9)
    ang = np.round(np.mod(np.arctan2(a[:, 1], a[:, 0]), 2.0 * np.pi), 9)
    return a[np.lexsort((ang, dist))]


def offset_words(dx: float, dy: float) -> str:
    """A pad's place from its depot as a crew paces it: "35 m E", "35 m N, 35 m E", "70 m S,
    35 m W" (north-south first; whole metres); "the depot itself" within half a metre.

    Args:
        dx: metres east of the depot (negative: west).
        dy: metres north of the depot (negative: south).

    Returns:
        The words.
    """
    parts = []
    if abs(dy) >= 0.5:
        parts.append(f"{abs(dy):.0f} m {'N' if dy > 0 else 'S'}")
    if abs(dx) >= 0.5:
        parts.append(f"{abs(dx):.0f} m {'E' if dx > 0 else 'W'}")
    return ", ".join(parts) if parts else "the depot itself"


def pad_ranks(uses: Iterable[tuple[int, str]]) -> dict[tuple[int, str], int]:
    """Which pad of each depot each vehicle uses: the vehicles that take off or land at a
    depot, in the order of their numbers, take its pads by index 0, 1, ... (index 0 is pad 1,
    the depot itself),
    so a vehicle alone at a depot stands on the depot. The planner (`fleet.search.on_pads`),
    the writer and `verify` all count them from the plan's sorties, so they agree.

    Args:
        uses: (vehicle number, depot name) for every take-off and landing of the plan.

    Returns:
        {(vehicle, depot): pad index}.
    """
    by_depot: dict[str, set[int]] = {}
    for v, d in uses:
        by_depot.setdefault(d, set()).add(int(v))
    return {(v, d): k for d, vs in by_depot.items() for k, v in enumerate(sorted(vs))}


def pad_layout(
    depots: np.ndarray,
    vehicles: int,
    spacing: float,
    free: Callable[[np.ndarray, np.ndarray], np.ndarray],
    names: tuple[str, ...] | None = None,
    given: list[list[tuple[float, float]]] | None = None,
) -> np.ndarray:
    """Each vehicle's pad at each depot (module docstring).

    Args:
        depots: (D, 2) depot positions, m (local ENU).
        vehicles: V >= 1, the fleet's vehicles.
        spacing: m, the least distance between two pads, > 0.
        free: free(depot (2,), pads (n, 2)) -> (n,) int: `FREE` where a candidate pad may be
            used, else why not (`OUTSIDE`, `INSIDE`, `NEAR`, `BEHIND`); a bool array reads
            True as `FREE` and False as `NEAR`.
        names: the depots' names for messages (default "depot k").
        given: per depot, its pads 1, 2, ... as the map lists them (`Depot.pads`), taken
            before the lattice's; each must pass `free` and keep `spacing` from every other
            pad and depot.

    Returns:
        (V, D, 2) pads, m; [0] is `depots` itself.

    Raises:
        ValueError: with two vehicles or more, two depots nearer than `spacing`, naming
            them; a depot without room for V pads within `MAX_RINGS` lattice steps, naming
            it, the spacing and what kept the nearest spots out; or a listed pad (any of
            them, also beyond the V - 1 used) that is not free or is too near another pad or
            depot, naming both.
    """
    dep = np.asarray(depots, dtype=float).reshape(-1, 2)
    V, D = int(vehicles), len(dep)
    if V < 1:
        raise ValueError("vehicles must be at least 1")
    if not spacing > 0:
        raise ValueError("spacing must be positive")
    label = [names[d] if names is not None else f"depot {d}" for d in range(D)]
    rule = f"{spacing:g} m (fleet.separation_m + {PAD_MARGIN_M:g} m)"
    out = np.repeat(dep[None], V, axis=0)
    # every spot a vehicle may stand on (the first `n` rows of `spots`), with its words: each
    # depot is its own pad 1 (index 0); an array, so that a candidate's distance to all of them
    # is one vector operation (91 depots x 100 vehicles: 9,191 spots)
    spots = np.empty((D + (V - 1) * D + sum(len(g) for g in (given or [])), 2))
    spots[:D] = dep
    words = [f"depot '{label[d]}'" for d in range(D)]
    n = D
    if V > 1:
        for a in range(D):
            for b in range(a + 1, D):
                apart = float(np.hypot(*(dep[a] - dep[b])))
                if apart < spacing - 1e-9:
                    raise ValueError(
                        f"fleet: depots '{label[a]}' and '{label[b]}' are {apart:.1f} m apart, "
                        f"nearer than {rule}: a vehicle landing at one passes that near "
                        "another standing on the other; move one, or give one depot for both")
    offsets = _lattice(MAX_RINGS) * float(spacing)
    for d in range(D):
        who = label[d]
        k = 1
        # every pad the map lists is held to the rules, those beyond the vehicles' too
        for i, xy in enumerate(given[d] if given is not None else []):
            c = np.asarray(xy, dtype=float)
            got = np.asarray(free(dep[d], c[None]))
            why_not = (FREE if got[0] else NEAR) if got.dtype == bool else int(got[0])
            # listed pads are pads 2, 3, ... (pad 1 is the depot), as `check` numbers them
            where = (f"fleet.depots[{d}].pads[{i}]: pad {i + 2} of depot '{who}' at "
                     f"({c[0]:g}, {c[1]:g})")  # fmt: skip
            if why_not == OUTSIDE:
                raise ValueError(f"{where} lies outside the area")
            if why_not == INSIDE:
                raise ValueError(f"{where} lies inside an obstacle or no-fly zone")
            if why_not == NEAR:
                raise ValueError(f"{where} lies within {PAD_CLEAR_M:g} m (or the map's "
                                 "safety.clearance, where larger) of an obstacle or no-fly "
                                 "zone")  # fmt: skip
            if why_not == BEHIND:
                raise ValueError(f"{where}: the straight leg from the depot crosses an "
                                 "obstacle or its clearance")
            dist = np.hypot(*(spots[:n] - c).T)
            nearest = int(np.argmin(dist))  # the first of least distance, as the list's min
            if dist[nearest] < spacing - 1e-9:
                raise ValueError(f"{where} lies {float(dist[nearest]):.1f} m from "
                                 f"{words[nearest]}, nearer than {rule}")
            spots[n] = c
            words.append(f"pad {i + 2} at ({c[0]:g}, {c[1]:g}) of depot '{who}'")
            n += 1
            if k < V:
                out[k, d] = c
                k += 1
        if V == 1 or k == V:
            continue
        cand = dep[d] + offsets
        why = np.asarray(free(dep[d], cand))
        if why.dtype == bool:
            why = np.where(why, FREE, NEAR)
        looked = 0
        crowded = 0
        for c, w in zip(cand, why, strict=True):
            if k == V:
                break
            looked += 1
            if w != FREE:
                continue
            if np.hypot(*(spots[:n] - c).T).min() < spacing - 1e-9:
                crowded += 1
                continue
            out[k, d] = c
            spots[n] = c
            words.append(f"pad {k + 1} at ({c[0]:g}, {c[1]:g}) of depot '{who}'")
            n += 1
            k += 1
        if k < V:
            counts = {code: int(np.sum(why == code))
                      for code in (OUTSIDE, INSIDE, NEAR, BEHIND)}  # fmt: skip
            kept = "; ".join(text for text in (
                f"{counts[OUTSIDE]} outside the area" if counts[OUTSIDE] else "",
                f"{counts[INSIDE]} inside an obstacle" if counts[INSIDE] else "",
                f"{counts[NEAR]} within {PAD_CLEAR_M:g} m (or the map's clearance) of an "
                "obstacle" if counts[NEAR] else "",
                f"{counts[BEHIND]} with no clear straight leg from the depot"
                if counts[BEHIND] else "",
                f"{crowded} nearer than {spacing:g} m to another depot's pad" if crowded else "",
            ) if text)  # fmt: skip
            raise ValueError(
                f"fleet: depot '{who}' has room for {k} of the {V} vehicles' pads ({spacing:g} m "
                f"apart: fleet.separation_m + {PAD_MARGIN_M:g} m; every depot holds a pad for "
                f"each vehicle) on the {looked} nearest spots of a {spacing:g} m grid around it, "
                f"out to {MAX_RINGS * spacing:g} m ({kept}): move the depot into the open, fly "
                "fewer UAVs or lower fleet.separation_m")
    out.flags.writeable = False
    return out
