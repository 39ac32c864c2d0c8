"""The map's obstacles as shapely geometry, built from the map file alone.

Independent of the planner's fast evaluator (planner_core.model.geometry). Rectangles are rotated
from their centre, length and angle; no-fly zones and polygon obstacles (building footprints)
are shapely polygons of the given rings, holes included, whatever their shape (shapely measures
non-convex polygons directly; the planner cuts them into convex pieces); all measured by shapely
(exact predicates, closed shapes). Circles are measured exactly, as the roots of
|a + t (b - a) - c|^2 = r^2 clipped to the leg (a shapely buffer is an inscribed polygon that
would miss a leg cutting less than r * (1 - cos(pi / (4 * quad_segs))) deep, ~0.5 mm at
r = 100 m); their `shape` (a buffer with `CIRCLE_QUAD_SEGS` segments per quarter) is for
drawing and messages only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

__all__ = ["Obstacle", "obstacle_shapes", "overlap_lengths", "CIRCLE_QUAD_SEGS"]

CIRCLE_QUAD_SEGS = 256


@dataclass(frozen=True, eq=False)
class Obstacle:
    """One obstacle: `kind` circle/rectangle/no_fly_zone/polygon, its index in that list, its
    shape, and its name if the map gives one."""

    kind: str
    index: int
    shape: Polygon
    name: str | None = None
    circle: tuple[float, float, float] | None = None  # (cx, cy, r) m for circles, exact

    def clearance(self, lines: Any) -> float:
        """Metres from the shapely geometry `lines` to this obstacle (negative: inside a circle
        by that much); circles exact, not via their drawn polygon."""
        if self.circle is None:
            return float(shapely.distance(lines, self.shape))
        cx, cy, r = self.circle
        return float(shapely.distance(lines, Point(cx, cy))) - r

    @property
    def label(self) -> str:
        base = f"{self.kind.replace('_', '-')} {self.index}"
        return f"{base} '{self.name}'" if self.name else base


def _rectangle(x: float, y: float, length: float, width: float, angle_deg: float) -> Polygon:
    th = math.radians(angle_deg)
    along = np.array([math.cos(th), math.sin(th)])
    across = np.array([-math.sin(th), math.cos(th)])
    c = np.array([x, y])
    corners = [
        c + sa * 0.5 * length * along + sb * 0.5 * width * across
        for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))
    ]
    return Polygon(corners)


def obstacle_shapes(map: Any) -> list[Obstacle]:  # noqa: A002
    """Every obstacle of the map (circles, rectangles, no-fly zones, polygon obstacles) as a
    shapely polygon."""
    obs = map.spec.obstacles
    out = [
        Obstacle(
            "circle", k, Point(c.x, c.y).buffer(c.radius, quad_segs=CIRCLE_QUAD_SEGS),
            circle=(float(c.x), float(c.y), float(c.radius)),
        )  # fmt: skip
        for k, c in enumerate(obs.circles)
    ]
    out += [
        Obstacle("rectangle", k, _rectangle(r.x, r.y, r.length, r.width, r.angle_deg))
        for k, r in enumerate(obs.rectangles)
    ]
    for kind, items in (("no_fly_zone", obs.no_fly_zones), ("polygon", obs.polygons)):
        out += [Obstacle(kind, k, Polygon(z.vertices, z.holes), z.name)
                for k, z in enumerate(items)]  # fmt: skip
    return out


def overlap_lengths(path: np.ndarray, obstacles: list[Obstacle]) -> np.ndarray:
    """(L, O) metres of each leg of the polyline `path` (L + 1, 2) inside each obstacle.

    Legs are measured one by one (the paper sums per leg and per obstacle: a leg crossing two
    overlapping obstacles counts in both).
    """
    path = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(path) < 2 or not obstacles:
        return np.zeros((max(len(path) - 1, 0), len(obstacles)))
    out = np.zeros((len(path) - 1, len(obstacles)))
    polys = [k for k, o in enumerate(obstacles) if o.circle is None]
    if polys:
        legs = shapely.linestrings(np.stack([path[:-1], path[1:]], axis=1))
        shapes = np.array([obstacles[k].shape for k in polys], dtype=object)
        inter = shapely.intersection(legs[:, None], shapes[None, :])
        out[:, polys] = shapely.length(inter)
    a, d = path[:-1], path[1:] - path[:-1]
    qa = np.einsum("ij,ij->i", d, d)
    for k, o in enumerate(obstacles):
        if o.circle is None:
            continue
        cx, cy, r = o.circle
        f = a - np.array([cx, cy])
        qb = 2.0 * np.einsum("ij,ij->i", f, d)
        qc = np.einsum("ij,ij->i", f, f) - r * r
        disc = qb * qb - 4.0 * qa * qc
        hit = (qa > 0.0) & (disc > 0.0)
        root = np.sqrt(np.where(hit, disc, 0.0))
        den = np.where(hit, 2.0 * qa, 1.0)
        t0 = np.clip((-qb - root) / den, 0.0, 1.0)
        t1 = np.clip((-qb + root) / den, 0.0, 1.0)
        out[:, k] = np.where(hit, (t1 - t0) * np.sqrt(qa), 0.0)
    return out
