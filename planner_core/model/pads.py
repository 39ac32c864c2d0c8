"""Landing pads: where each vehicle of a fleet takes off and lands at each depot (issue 33).

Several vehicles use one depot: they wait there to launch, land there and stand there through
a battery swap. Sharing one point, a vehicle would land on, or take off beside, another one
standing on the ground; the simulator's SEPARATION counts a vehicle on the ground and fails
that (`sim.fleet_time`). So each vehicle k (0-based) has its own pad at each depot:

* pad 0 is the depot itself, so a single vehicle flies exactly where it did before;
* the other pads are points of a hexagonal lattice of step `spacing` around the depot (the
  map's `fleet.separation_m` + `PAD_MARGIN_M`), taken nearest first (ties by angle from east,
  counter-clockwise), each at least `spacing` from every pad already given (any depot's) and
  accepted by the caller's test (inside the area, clear of the planning map's inflated
  obstacles, reached from its depot by a clear straight leg).

Deterministic for a map. Cost: O(D x C) tests for D depots and C lattice points looked at
(C grows with the square of the rings needed: about 1.1 V for V vehicles on open ground),
plus the caller's test (one batch per depot).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["PAD_MARGIN_M", "MAX_RINGS", "CLEAR_M", "pad_layout"]

#: m added to `fleet.separation_m` between two pads: a vehicle's landing error (GNSS, a few
#: metres) on top of the separation the simulator asks of a vehicle landing beside another
PAD_MARGIN_M = 5.0
#: lattice rings looked at around a depot before giving up: 100 vehicles need 6 on open ground
MAX_RINGS = 12
#: m of a leg inside obstacles at or below which the leg is clear (the routing's `CLEAR`)
CLEAR_M = 1e-9


def _lattice(rings: int) -> np.ndarray:
    """Hexagonal lattice points of step 1 within `rings` rings of the origin, origin left out,
    nearest first (ties by angle from east, counter-clockwise).

    Returns:
        (n, 2) unit-step offsets.
    """
    pts = []
    for q in range(-rings, rings + 1):
        for r in range(max(-rings, -q - rings), min(rings, -q + rings) + 1):
            if q == 0 and r == 0:
                continue
            pts.append((q + 0.5 * r, r * np.sqrt(3.0) / 2.0))
    a = np.array(pts, dtype=float)
    dist = np.round(np.hypot(a[:, 0], a[:, 1]), 9)
    ang = np.round(np.mod(np.arctan2(a[:, 1], a[:, 0]), 2.0 * np.pi), 9)
    return a[np.lexsort((ang, dist))]


def pad_layout(
    depots: np.ndarray,
    vehicles: int,
    spacing: float,
    free: Callable[[np.ndarray, np.ndarray], np.ndarray],
    names: tuple[str, ...] | None = None,
) -> np.ndarray:
    """Each vehicle's pad at each depot (module docstring).

    Args:
        depots: (D, 2) depot positions, m (local ENU).
        vehicles: V >= 1, the fleet's vehicles.
        spacing: m, the least distance between two pads, > 0.
        free: free(depot (2,), pads (n, 2)) -> (n,) bool: whether each candidate pad may be
            used (inside the area, clear of obstacles, a clear leg from the depot).
        names: the depots' names for messages (default "depot k").

    Returns:
        (V, D, 2) pads, m; [0] is `depots` itself.

    Raises:
        ValueError: a depot without room for V pads within `MAX_RINGS` lattice steps, naming
            it, the pads found and the spacing.
    """
    dep = np.asarray(depots, dtype=float).reshape(-1, 2)
    V, D = int(vehicles), len(dep)
    if V < 1:
        raise ValueError("vehicles must be at least 1")
    if not spacing > 0:
        raise ValueError("spacing must be positive")
    out = np.repeat(dep[None], V, axis=0)
    if V == 1:
        return out
    offsets = _lattice(MAX_RINGS) * float(spacing)
    taken = [p for p in dep]  # every depot is pad 0 of its own
    for d in range(D):
        cand = dep[d] + offsets
        ok = np.asarray(free(dep[d], cand), dtype=bool)
        k = 1
        for c, good in zip(cand, ok, strict=True):
            if k == V:
                break
            if not good:
                continue
            if min(float(np.hypot(*(c - t))) for t in taken) < spacing - 1e-9:
                continue
            out[k, d] = c
            taken.append(c)
            k += 1
        if k < V:
            who = names[d] if names is not None else f"depot {d}"
            raise ValueError(f"fleet: depot '{who}' has room for {k} of the {V} vehicles' "
                             f"pads ({spacing:g} m apart, fleet.separation_m + "
                             f"{PAD_MARGIN_M:g} m) within {MAX_RINGS * spacing:g} m clear of "
                             "obstacles and inside the area: move the depot into the open, "
                             "add a depot, fly fewer UAVs or lower fleet.separation_m")  # fmt: skip
    out.flags.writeable = False
    return out
