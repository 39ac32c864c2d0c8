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
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

from planner_core.defaults import obstacle_label

__all__ = [
    "Obstacle",
    "obstacle_shapes",
    "overlap_lengths",
    "overlap_totals",
    "unique_legs",
    "distinct_rows",
    "distances_to",
    "flown_legs",
    "leg_overlaps",
    "points_inside",
    "CIRCLE_QUAD_SEGS",
]

CIRCLE_QUAD_SEGS = 256
#: at most this many (leg, obstacle) pairs held at once by `overlap_totals` (~16 MB of indices)
PAIR_BLOCK = 1 << 20


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
        by that much); circles exact, not via their drawn polygon.

        Args:
            lines: a shapely geometry (a leg, a path), local metres.

        Returns:
            The distance, metres (0 when it touches or enters a polygon).
        """
        if self.circle is None:
            return float(shapely.distance(lines, self.shape))
        cx, cy, r = self.circle
        return float(shapely.distance(lines, Point(cx, cy))) - r

    @property
    def label(self) -> str:
        """The obstacle's name in messages.

        Returns:
            "<kind> <index>" (kind with '-' for '_', e.g. "no-fly-zone 0"), then " '<name>'"
            when the map names it (`planner_core.defaults.obstacle_label`, the wording `check`
            uses too).
        """
        return obstacle_label(self.kind, self.index, self.name)


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
    shapely polygon.

    Args:
        map: a map with `spec.obstacles` (circles, rectangles, no_fly_zones, polygons).

    Returns:
        The `Obstacle`s in that order, each indexed within its own list; circles carry their
        exact (cx, cy, r), their shape a buffer of `CIRCLE_QUAD_SEGS` segments per quarter.
    """
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
    overlapping obstacles counts in both). Time and memory grow as L x O (every pair is kept;
    the circles are measured in one vectorised call, a polygon only where its bounding box meets
    the leg's): for short paths; `overlap_totals` is the bounded form for a mission.

    Args:
        path: (L + 1, 2) polyline, local metres.
        obstacles: the O obstacles (`obstacle_shapes`).

    Returns:
        (L, O) float array, metres; (max(L, 0), O) zeros for fewer than two points or no
        obstacles.
    """
    path = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(path) < 2 or not obstacles:
        return np.zeros((max(len(path) - 1, 0), len(obstacles)))
    out = np.zeros((len(path) - 1, len(obstacles)))
    polys = [k for k, o in enumerate(obstacles) if o.circle is None]
    if polys:
        shapes = np.array([obstacles[k].shape for k in polys], dtype=object)
        # only the (leg, polygon) pairs whose bounding boxes meet are intersected: the others
        # have no length inside (0 either way), and a short path meets few of many polygons
        lo, hi = np.minimum(path[:-1], path[1:]), np.maximum(path[:-1], path[1:])
        box = shapely.bounds(shapes)  # (P, 4): xmin, ymin, xmax, ymax
        meet = ((lo[:, None, 0] <= box[None, :, 2]) & (hi[:, None, 0] >= box[None, :, 0])
                & (lo[:, None, 1] <= box[None, :, 3]) & (hi[:, None, 1] >= box[None, :, 1]))
        li, pi = np.nonzero(meet)
        if len(li):
            legs = shapely.linestrings(np.stack([path[:-1], path[1:]], axis=1))
            got = np.zeros((len(path) - 1, len(polys)))
            got[li, pi] = shapely.length(shapely.intersection(legs[li], shapes[pi]))
            out[:, polys] = got
    circ = [k for k, o in enumerate(obstacles) if o.circle is not None]
    if circ:
        # every (leg, circle) pair in one call of `_chords` (per-row centres and radii), leg
        # major: the same arithmetic per pair as one call per circle, without O Python calls
        c = np.array([obstacles[k].circle for k in circ], dtype=float)  # (C, 3)
        n_legs, n_c = len(path) - 1, len(circ)
        got = _chords(np.repeat(path[:-1], n_c, axis=0), np.repeat(path[1:], n_c, axis=0),
                      np.tile(c[:, :2], (n_legs, 1)), np.tile(c[:, 2], n_legs))
        out[:, circ] = got.reshape(n_legs, n_c)
    return out


def _chords(a: np.ndarray, b: np.ndarray, centre: np.ndarray, r: Any) -> np.ndarray:
    """Metres of each leg a -> b (n, 2) inside the circle(s) `centre` (2,) or (n, 2), radius
    `r`: the roots of |a + t (b - a) - c|^2 = r^2 clipped to [0, 1]. O(n)."""
    d = b - a
    qa = np.einsum("ij,ij->i", d, d)
    f = a - centre
    qb = 2.0 * np.einsum("ij,ij->i", f, d)
    qc = np.einsum("ij,ij->i", f, f) - r * r
    disc = qb * qb - 4.0 * qa * qc
    hit = (qa > 0.0) & (disc > 0.0)
    root = np.sqrt(np.where(hit, disc, 0.0))
    den = np.where(hit, 2.0 * qa, 1.0)
    t0 = np.clip((-qb - root) / den, 0.0, 1.0)
    t1 = np.clip((-qb + root) / den, 0.0, 1.0)
    return np.where(hit, (t1 - t0) * np.sqrt(qa), 0.0)


def distinct_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct rows of `rows` in the order they first occur, how often each occurs, and
    which distinct row each row is.

    A DO_JUMP loop visits the same hover points and flies the same legs again and again; the
    figure draws each once (`lamde_mission.plot`), numbered in the order first flown.

    Args:
        rows: (n, k) numbers (no NaN).

    Returns:
        (first, counts, inverse): `rows[first]` are the U distinct rows in the order of their
        first occurrence, `counts` (U,) how often each occurs, `inverse` (n,) the index in
        0..U-1 of each row's distinct row. O(n log n) time, O(n) memory.
    """
    rows = np.asarray(rows, dtype=float)
    if not len(rows):
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty.copy(), empty.copy()
    rows = rows.reshape(len(rows), -1)
    _, first, inverse, counts = np.unique(rows, axis=0, return_index=True,
                                          return_inverse=True, return_counts=True)  # fmt: skip
    order = np.argsort(first, kind="stable")
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    return (first[order].astype(np.int64), counts[order].astype(np.int64),
            rank[np.asarray(inverse).reshape(-1)])  # fmt: skip


def unique_legs(
    paths: list[np.ndarray], *, flown_order: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The distinct legs (U, 2, 2) of the polylines `paths` and how often each is flown (U,).

    A DO_JUMP loop flies the same legs again and again; measuring each once is what keeps the
    checks' work at the mission's distinct legs. O(L log L) time and O(L) memory in L legs.

    Args:
        paths: polylines (n, 2), local metres; those of fewer than two points have no leg.
        flown_order: the legs in the order first flown (`distinct_rows`; the figure draws
            them so) rather than sorted by their coordinates (the checks).

    Returns:
        (legs, counts): the distinct legs, each as (start, end), and how often each is flown.
    """
    if flown_order:
        legs, counts, _ = flown_legs(paths)
        return legs, counts
    flat = _leg_rows(paths)
    if not len(flat):
        return np.zeros((0, 2, 2)), np.zeros(0, dtype=np.int64)
    uniq, counts = np.unique(flat, axis=0, return_counts=True)
    return uniq.reshape(-1, 2, 2), counts.astype(np.int64)


def _leg_rows(paths: list[np.ndarray]) -> np.ndarray:
    """(L, 4) every leg of the polylines `paths` in flown order (path 0's legs, then path
    1's, ...), each as (x0, y0, x1, y1); polylines of fewer than two points have none."""
    segs = [np.stack([p[:-1], p[1:]], axis=1) for p in
            (np.asarray(q, dtype=float).reshape(-1, 2) for q in paths) if len(p) >= 2]
    return np.concatenate(segs).reshape(-1, 4) if segs else np.zeros((0, 4))


def flown_legs(paths: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct legs of the polylines `paths` in the order first flown, with how often
    each is flown and where: what a message naming legs by their items needs. O(L log L) time
    and O(L) memory in L legs (`distinct_rows`).

    Args:
        paths: polylines (n, 2), local metres; those of fewer than two points have no leg.

    Returns:
        (legs (U, 2, 2), counts (U,), first (U,)): each distinct leg as (start, end), how
        often it is flown, and the index of its first flight among the legs of `paths` taken
        in order.
    """
    flat = _leg_rows(paths)
    if not len(flat):
        empty = np.zeros(0, dtype=np.int64)
        return np.zeros((0, 2, 2)), empty, empty.copy()
    first, counts, _ = distinct_rows(flat)
    return flat[first].reshape(-1, 2, 2), counts, first


def _overlap_pairs(legs: np.ndarray, obstacles: list[Obstacle]) -> Iterator[
        tuple[int, np.ndarray, np.ndarray, np.ndarray]]:  # fmt: skip
    """The (leg, obstacle) pairs that meet, with the length of the leg inside, chunk by chunk.

    Each leg of `legs` (U, 2, 2) is tested only against the obstacles an STRtree finds near
    it: polygons whose shape it intersects, circles whose bounding box it meets (then measured
    exactly, as `overlap_lengths` does). Legs are queried in chunks of PAIR_BLOCK / O.

    Args:
        legs: (U, 2, 2) legs, each as (start, end), local metres; U >= 1.
        obstacles: the O >= 1 obstacles (`obstacle_shapes`).

    Yields:
        (lo, li, oi, length): the chunk's first leg, then per pair the leg's index within the
        chunk, the obstacle's index and the metres inside (0 for a pair that only touches).
    """
    n_obs = len(obstacles)
    circ = np.array([o.circle is not None for o in obstacles])
    boxes = np.array([
        shapely.box(o.circle[0] - o.circle[2], o.circle[1] - o.circle[2],
                    o.circle[0] + o.circle[2], o.circle[1] + o.circle[2])
        if o.circle is not None else o.shape for o in obstacles
    ], dtype=object)  # fmt: skip
    tree = shapely.STRtree(boxes)
    shapes = np.array([o.shape for o in obstacles], dtype=object)
    centres = np.array([o.circle[:2] if o.circle is not None else (0.0, 0.0) for o in obstacles])
    radii = np.array([o.circle[2] if o.circle is not None else 0.0 for o in obstacles])
    chunk = max(1, PAIR_BLOCK // n_obs)
    for lo in range(0, len(legs), chunk):
        seg = legs[lo:lo + chunk]
        lines = shapely.linestrings(seg)
        # circles: their bounding box, measured exactly below; polygons: their shape
        near = tree.query(lines)  # at most chunk x O pairs
        near = near[:, circ[near[1]] | shapely.intersects(lines[near[0]], boxes[near[1]])]
        li, oi = near
        got = np.zeros(len(li))
        poly = ~circ[oi]
        if poly.any():
            got[poly] = shapely.length(shapely.intersection(lines[li[poly]], shapes[oi[poly]]))
        c = ~poly
        if c.any():
            got[c] = _chords(seg[li[c], 0], seg[li[c], 1], centres[oi[c]], radii[oi[c]])
        yield lo, li, oi, got


def overlap_totals(paths: list[np.ndarray], obstacles: list[Obstacle]) -> np.ndarray:
    """(O,) metres of the polylines `paths` inside each obstacle: `overlap_lengths` summed over
    every leg of every path (a leg flown k times counts k times), without its (L, O) table.

    Each distinct leg (`unique_legs`) is tested only against the obstacles an STRtree finds
    near it (`_overlap_pairs`). Time O(U log U + (U + P) log O + P) for U distinct legs, O
    obstacles and P (leg, obstacle) pairs that meet; memory O(U + O) plus at most
    max(`PAIR_BLOCK`, O) pairs at a time.

    Args:
        paths: polylines (n, 2), local metres; those of fewer than two points have no leg.
        obstacles: the O obstacles (`obstacle_shapes`).

    Returns:
        (O,) float array, metres (zeros without legs or obstacles).
    """
    out = np.zeros(len(obstacles))
    legs, counts = unique_legs(paths)
    if not len(obstacles) or not len(legs):
        return out
    for lo, li, oi, got in _overlap_pairs(legs, obstacles):
        np.add.at(out, oi, got * counts[lo + li])
    return out


def leg_overlaps(
    paths: list[np.ndarray], obstacles: list[Obstacle], *, tol: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Which legs of the polylines `paths` run inside which obstacles, and for how long: the
    pairs behind `overlap_totals`, each distinct leg once (a DO_JUMP loop flies the same legs
    again), in the order first flown, so that a message can name the legs at fault.

    Time and memory as `overlap_totals` (the distinct legs in flown order: `flown_legs`).

    Args:
        paths: polylines (n, 2), local metres; those of fewer than two points have no leg.
        obstacles: the O obstacles (`obstacle_shapes`).
        tol: metres: pairs with at most this length inside are left out.

    Returns:
        (first, counts, leg, obstacle, length): per distinct leg (U,) the index of its first
        flight among the legs of `paths` taken in order (path 0's legs, then path 1's, ...)
        and how often it is flown; per pair (P,) the distinct leg's index, the obstacle's
        index and the metres inside one flight of the leg (> tol), sorted by leg.
    """
    empty = np.zeros(0, dtype=np.int64)
    legs, counts, first = flown_legs(paths)
    if not len(legs) or not obstacles:
        return empty, empty.copy(), empty.copy(), empty.copy(), np.zeros(0)
    li_all, oi_all, got_all = [], [], []
    for lo, li, oi, got in _overlap_pairs(legs, obstacles):
        keep = got > tol
        li_all.append(lo + li[keep])
        oi_all.append(oi[keep])
        got_all.append(got[keep])
    li = np.concatenate(li_all).astype(np.int64)
    order = np.argsort(li, kind="stable")
    return (first, counts, li[order], np.concatenate(oi_all).astype(np.int64)[order],
            np.concatenate(got_all)[order])  # fmt: skip


def points_inside(points: np.ndarray, obstacles: list[Obstacle]) -> tuple[np.ndarray, np.ndarray]:
    """Which points lie inside which obstacles: in a polygon's interior (its boundary and its
    holes are outside), or nearer a circle's centre than its radius (exact, not its drawn
    polygon). Through an STRtree of the obstacles' bounding boxes: time O((N + O) log O + P)
    for N points and P (point, box) pairs, memory O(N + O + P).

    Args:
        points: (N, 2) local metres.
        obstacles: the O obstacles (`obstacle_shapes`).

    Returns:
        (point, obstacle): (P,) index pairs, by point then obstacle.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    empty = np.zeros(0, dtype=np.int64)
    if not len(pts) or not obstacles:
        return empty, empty.copy()
    boxes = shapely.box(*np.array([o.shape.bounds for o in obstacles]).T)
    geoms = shapely.points(pts)
    pi, oi = shapely.STRtree(boxes).query(geoms)
    inside = np.zeros(len(pi), dtype=bool)
    for k in np.unique(oi):  # one vectorised test per obstacle met
        sel = oi == k
        o = obstacles[int(k)]
        if o.circle is not None:
            cx, cy, r = o.circle
            inside[sel] = np.hypot(pts[pi[sel], 0] - cx, pts[pi[sel], 1] - cy) < r
        else:
            inside[sel] = shapely.contains_properly(o.shape, geoms[pi[sel]])
    order = np.lexsort((oi[inside], pi[inside]))
    return pi[inside][order].astype(np.int64), oi[inside][order].astype(np.int64)


def distances_to(paths: list[np.ndarray], geoms: np.ndarray) -> np.ndarray:
    """(G,) metres from each shapely geometry of `geoms` to the nearest leg of the polylines
    `paths` (inf without legs): ``shapely.distance(MultiLineString(paths), geoms)``, through an
    STRtree of the distinct legs rather than every leg against every geometry. Time about
    O((U + G) log U) for U distinct legs, memory O(U + G).

    Args:
        paths: polylines (n, 2), local metres; those of fewer than two points have no leg.
        geoms: (G,) shapely geometries, local metres.

    Returns:
        (G,) float array, metres (inf everywhere without legs).
    """
    legs, _ = unique_legs(paths)
    out = np.full(len(geoms), np.inf)
    if not len(legs) or not len(geoms):
        return out
    tree = shapely.STRtree(shapely.linestrings(legs))
    which, dist = tree.query_nearest(geoms, return_distance=True, all_matches=False)
    np.minimum.at(out, which[0], dist)
    return out
