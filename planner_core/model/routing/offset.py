"""Convex polygons pushed out by a margin: the corners a route bends around."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planner_core.model.polygons import ring_area

__all__ = ["CIRCLE_SIDES", "offset_convex", "obstacle_polygons"]

#: sides of the polygon circumscribed about a circle (radius + margin)
CIRCLE_SIDES = 6
#: `obstacle_polygons` caps the mitre at needle-sharp corners with this least denominator
_NEEDLE = 0.08


def offset_convex(
    poly: np.ndarray, c: float, normals: np.ndarray | None = None, min_denominator: float = 0.0
) -> np.ndarray:
    """Vertices (n, 2) of a counter-clockwise polygon pushed out by c metres along the mitre, so
    each new vertex is c from both its edges' lines (at a reflex corner of a non-convex polygon
    the new vertex lies in the notch, c from both lines).

    Args:
        poly: (n, 2) counter-clockwise vertices, metres.
        c: the push, metres.
        normals: (n, 2) unit outward normals of the edges v_k -> v_k+1 when already known
            (computed from the vertices otherwise).
        min_denominator: > 0 caps the mitre at very sharp corners (the vertex then lies less
            than c from its edges' lines, still outside the polygon); 0: no cap.

    Returns:
        (n, 2) the pushed vertices, metres, in the same order.
    """
    poly = np.asarray(poly, dtype=float)
    if normals is None:
        e = np.roll(poly, -1, axis=0) - poly
        normals = np.stack([e[:, 1], -e[:, 0]], axis=1) / np.hypot(e[:, 0], e[:, 1])[:, None]
    n_prev = np.roll(normals, 1, axis=0)
    den = np.maximum(1.0 + np.sum(normals * n_prev, axis=1), min_denominator)
    return poly + c * ((normals + n_prev) / den[:, None])


def obstacle_polygons(obstacles: Any, margin: float) -> list[np.ndarray]:
    """Every obstacle of a `geometry.Obstacles` as a CCW polygon pushed out by `margin`: circles
    first (circumscribed `CIRCLE_SIDES`-gons), then the convex polygons in their order, then each
    region (a general polygon such as an L- or U-shaped footprint, packed as convex pieces) as
    its own exterior ring pushed out, not its pieces: its convex corners are where paths bend,
    also into a notch (a hull would hide the notch); its reflex corners give offset points in
    the notch that few tangent lines use. Holes are left out (a courtyard cannot be reached
    without crossing the building). Whether an edge is clear is decided on the real shape, where
    a leg along an internal cut between two pieces counts as inside
    (`planner_core.model.polygons`).

    Args:
        obstacles: a `geometry.Obstacles`.
        margin: the push, metres (a circle's polygon is circumscribed about radius + margin).

    Returns:
        The pushed polygons, (V, 2) counter-clockwise each, metres; mitres capped at
        needle-sharp corners (`_NEEDLE`).
    """
    polys: list[np.ndarray] = []
    ang = 2.0 * np.pi * (np.arange(CIRCLE_SIDES) + 0.5) / CIRCLE_SIDES
    for cx, cy, r in obstacles.circles:
        rad = (r + margin) / math.cos(math.pi / CIRCLE_SIDES)
        polys.append(np.column_stack([cx + rad * np.cos(ang), cy + rad * np.sin(ang)]))
    region = getattr(obstacles, "piece_region", None)
    for p in range(obstacles.n_polygons):
        if region is not None and region[p] >= 0:
            continue  # a piece of a region: the region's own ring stands in, below
        v = np.asarray(obstacles.polygon(p), dtype=float)
        n = obstacles.edge_normals[obstacles.poly_offsets[p] : obstacles.poly_offsets[p + 1]]
        polys.append(offset_convex(v, margin, n, _NEEDLE))
    for shell, _ in getattr(obstacles, "regions", ()):
        v = np.asarray(shell, dtype=float)
        if ring_area(v) < 0.0:
            v = v[::-1]  # counter-clockwise, so the normals point out
        polys.append(offset_convex(v, margin, min_denominator=_NEEDLE))
    return polys
