"""The map's obstacles as shapely geometry, built from the map file alone.

Independent of the planner's fast evaluator (planner_core.geometry): circles are buffered
points with `CIRCLE_QUAD_SEGS` segments per quarter (inscribed polygon: an overlap deeper
than r * (1 - cos(pi / (4 * CIRCLE_QUAD_SEGS))), ~0.5 mm at r = 100 m, is always found),
rectangles are rotated from their centre, length and angle, no-fly zones and polygon obstacles
(building footprints) are shapely polygons of the given rings, holes included, whatever their
shape (shapely measures non-convex polygons directly; the planner cuts them into convex pieces).
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
        Obstacle("circle", k, Point(c.x, c.y).buffer(c.radius, quad_segs=CIRCLE_QUAD_SEGS))
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
    legs = shapely.linestrings(np.stack([path[:-1], path[1:]], axis=1))
    shapes = np.array([o.shape for o in obstacles], dtype=object)
    inter = shapely.intersection(legs[:, None], shapes[None, :])
    return np.asarray(shapely.length(inter), dtype=float)
