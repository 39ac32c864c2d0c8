"""Collision-risk geometry: L_vio, the length of flight legs inside obstacles (paper Eq. L_vio).

L_vio = L_rec + L_cir + L_nfz is a sum over obstacles: a leg crossing two overlapping obstacles
counts once per obstacle. Only the open interior counts, so legs that touch a circle, run along an
edge or pass through a corner contribute 0.

Obstacles are circles and convex counter-clockwise polygons (rotated rectangles, no-fly zones).
The fast path (`overlap_lengths`) is a numba kernel: per leg, a branch-free pass tests every
obstacle's bounding circle against the leg's capsule (vectorises well and rejects ~99% of pairs on
a 10 km map), then the few candidates get the exact answer: the chord formula for circles,
Cyrus-Beck clipping against the edge half-planes for polygons.

Boundary tolerance. Floating point cannot say whether a leg built from rounded coordinates is
exactly tangent or exactly on an edge, and near tangency the chord length is ill-conditioned
(a rounding error delta in the distance gives a chord of 2*sqrt(2*r*delta)). So, with
``tol = Obstacles.tol`` (1e-9 m for coordinates up to 10 km, growing with the map's extent):
  * a leg whose supporting line passes at distance >= r - tol from a circle's centre counts 0;
  * a leg that stays within tol of (or outside) one edge line of a polygon counts 0 for it;
  * a single (leg, obstacle) overlap of length <= tol counts 0 (a leg grazing a corner gives
    exactly 0, so the feasibility test L_vio == 0 of constraint C5 is not tripped by rounding).
Everything else is exact up to rounding.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit, prange

__all__ = [
    "Obstacles",
    "overlap_lengths",
    "overlap_lengths_reference",
    "points_inside",
    "rectangle_vertices",
]

_TOL_PER_METRE = 1e-13  # boundary tolerance relative to the largest coordinate magnitude
_TOL_MIN = 1e-9  # metres: the tolerance never drops below this (maps up to 10 km)
_PARALLEL_MIN_PAIRS = 2_000_000  # legs x obstacles above which the threaded kernel pays off


def _readonly(x: np.ndarray) -> np.ndarray:
    x.setflags(write=False)
    return x


def _clean_polygon(poly: np.ndarray, index: int) -> np.ndarray:
    """Validate one convex CCW polygon; drop a repeated closing vertex (shapely-style rings)."""
    v = np.array(poly, dtype=np.float64).reshape(-1, 2)
    if len(v) >= 2 and np.array_equal(v[0], v[-1]):
        v = v[:-1]
    if len(v) < 3:
        raise ValueError(f"polygon {index}: needs at least 3 distinct vertices, got {len(v)}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"polygon {index}: non-finite vertex")
    e = np.roll(v, -1, axis=0) - v
    elen = np.hypot(e[:, 0], e[:, 1])
    if np.any(elen == 0.0):
        raise ValueError(f"polygon {index}: repeated consecutive vertex")
    e_next = np.roll(e, -1, axis=0)
    cross = e[:, 0] * e_next[:, 1] - e[:, 1] * e_next[:, 0]
    dot = e[:, 0] * e_next[:, 0] + e[:, 1] * e_next[:, 1]
    # every turn must be a left turn (or straight), and the turns must add up to one full turn
    # (an all-left-turn pentagram winds twice)
    if np.any(cross < -1e-12 * elen * np.roll(elen, -1)):
        raise ValueError(f"polygon {index}: not convex counter-clockwise (a right turn)")
    winding = float(np.sum(np.arctan2(cross, dot)))
    if abs(winding - 2.0 * math.pi) > 1e-6:
        raise ValueError(f"polygon {index}: not a simple convex CCW polygon (winding {winding:g})")
    area2 = float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    if not area2 > 0.0:
        raise ValueError(f"polygon {index}: zero area")
    return v


@dataclass(frozen=True, eq=False)
class Obstacles:
    """All obstacles of a map in packed arrays for the kernel; build once per map, share freely.

    Only the first three fields are inputs; the rest are derived in ``__post_init__``. Arrays are
    read-only. Equality is identity (arrays do not compare as a single bool).
    """

    circles: np.ndarray  # (K, 3) rows [cx, cy, r]
    poly_vertices: np.ndarray  # (V_total, 2), each polygon CCW
    poly_offsets: np.ndarray  # (P + 1,) int64
    edge_normals: np.ndarray = field(init=False, repr=False)  # (V_total, 2) unit outward normals
    bound_circles: np.ndarray = field(init=False, repr=False)  # (K + P, 3) culling discs
    tol: float = field(init=False)  # boundary tolerance, metres (see the module docstring)

    def __post_init__(self) -> None:
        circles = np.ascontiguousarray(self.circles, dtype=np.float64).reshape(-1, 3)
        verts = np.ascontiguousarray(self.poly_vertices, dtype=np.float64).reshape(-1, 2)
        offs = np.ascontiguousarray(self.poly_offsets, dtype=np.int64).reshape(-1)
        if len(offs) == 0:
            offs = np.zeros(1, dtype=np.int64)
        if offs[0] != 0 or offs[-1] != len(verts) or np.any(np.diff(offs) < 3):
            raise ValueError("poly_offsets must start at 0, end at len(poly_vertices), step >= 3")
        if not np.all(np.isfinite(circles)) or np.any(circles[:, 2] <= 0.0):
            raise ValueError("circles must be finite with positive radius")
        if not np.all(np.isfinite(verts)):
            raise ValueError("polygon vertices must be finite")

        scale = 0.0
        if len(circles):
            scale = max(scale, float(np.max(np.abs(circles[:, :2]) + circles[:, 2:3])))
        if len(verts):
            scale = max(scale, float(np.max(np.abs(verts))))
        tol = max(_TOL_MIN, _TOL_PER_METRE * scale)

        n_poly = len(offs) - 1
        normals = np.empty_like(verts)
        bound = np.empty((len(circles) + n_poly, 3), dtype=np.float64)
        bound[: len(circles), :2] = circles[:, :2]
        bound[: len(circles), 2] = circles[:, 2] - tol  # exact circle test, tangent band removed
        for p in range(n_poly):
            v = verts[offs[p] : offs[p + 1]]
            e = np.roll(v, -1, axis=0) - v
            elen = np.hypot(e[:, 0], e[:, 1])
            normals[offs[p] : offs[p + 1], 0] = e[:, 1] / elen
            normals[offs[p] : offs[p + 1], 1] = -e[:, 0] / elen
            centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
            radius = float(np.max(np.hypot(v[:, 0] - centre[0], v[:, 1] - centre[1])))
            bound[len(circles) + p, :2] = centre
            bound[len(circles) + p, 2] = radius * (1.0 + 1e-9) + tol  # conservative

        object.__setattr__(self, "circles", _readonly(circles))
        object.__setattr__(self, "poly_vertices", _readonly(verts))
        object.__setattr__(self, "poly_offsets", _readonly(offs))
        object.__setattr__(self, "edge_normals", _readonly(normals))
        object.__setattr__(self, "bound_circles", _readonly(bound))
        object.__setattr__(self, "tol", tol)

    @classmethod
    def build(
        cls, circles: Sequence[tuple[float, float, float]], polygons: Sequence[np.ndarray]
    ) -> Obstacles:
        """Pack circles (cx, cy, r) and convex CCW polygons ((V, 2) each); validates both."""
        c = np.array(circles, dtype=np.float64).reshape(-1, 3)
        cleaned = [_clean_polygon(p, i) for i, p in enumerate(polygons)]
        offsets = np.zeros(len(cleaned) + 1, dtype=np.int64)
        offsets[1:] = np.cumsum([len(v) for v in cleaned])
        verts = np.concatenate(cleaned) if cleaned else np.zeros((0, 2), dtype=np.float64)
        return cls(circles=c, poly_vertices=verts, poly_offsets=offsets)

    @property
    def n_circles(self) -> int:
        return int(self.circles.shape[0])

    @property
    def n_polygons(self) -> int:
        return int(self.poly_offsets.shape[0] - 1)

    def polygon(self, p: int) -> np.ndarray:
        """Vertices (V, 2) of polygon p (read-only view)."""
        return self.poly_vertices[self.poly_offsets[p] : self.poly_offsets[p + 1]]


def rectangle_vertices(
    cx: float, cy: float, length: float, width: float, angle_deg: float
) -> np.ndarray:
    """(4, 2) CCW corners; `length` runs along the axis angle_deg counter-clockwise from east."""
    if not (length > 0.0 and width > 0.0) or not math.isfinite(length * width):
        raise ValueError(f"rectangle needs positive finite sides, got {length!r} x {width!r}")
    th = math.radians(angle_deg)
    ux, uy = math.cos(th), math.sin(th)
    hl, hw = 0.5 * length, 0.5 * width
    # (along, across) offsets in CCW order; across = along rotated +90 degrees
    corners = ((-hl, -hw), (hl, -hw), (hl, hw), (-hl, hw))
    return np.array(
        [[cx + s * ux - t * uy, cy + s * uy + t * ux] for s, t in corners], dtype=np.float64
    )


# --------------------------------------------------------------------------- kernel


@njit(cache=True, fastmath=False, nogil=True)
def _circle_overlap(ax, ay, ux, uy, length, cx, cy, r, tol):
    fx = cx - ax
    fy = cy - ay
    h = abs(ux * fy - uy * fx)  # distance from the centre to the leg's line
    if h >= r - tol:
        return 0.0
    s = ux * fx + uy * fy  # arc length along the leg of the closest approach
    w = math.sqrt((r - h) * (r + h))  # half chord
    lo = max(s - w, 0.0)
    hi = min(s + w, length)
    d = hi - lo
    return d if d > tol else 0.0


@njit(cache=True, fastmath=False, nogil=True)
def _polygon_overlap(ax, ay, bx, by, length, verts, normals, start, stop, tol):
    t_lo = 0.0
    t_hi = 1.0
    for i in range(start, stop):
        nx = normals[i, 0]
        ny = normals[i, 1]
        vx = verts[i, 0]
        vy = verts[i, 1]
        sa = nx * (ax - vx) + ny * (ay - vy)  # signed distance to the edge line, > 0 outside
        sb = nx * (bx - vx) + ny * (by - vy)
        if sa > -tol and sb > -tol:
            return 0.0  # outside this half-plane, or within tol of its boundary line throughout
        if sa < 0.0 and sb < 0.0:
            continue  # inside this half-plane over the whole leg
        t = sa / (sa - sb)  # crossing; sa and sb have opposite signs, no cancellation
        if sa < 0.0:
            t_hi = min(t_hi, t)  # leaving
        else:
            t_lo = max(t_lo, t)  # entering
        if t_lo >= t_hi:
            return 0.0
    d = (t_hi - t_lo) * length
    return d if d > tol else 0.0


@njit(cache=True, fastmath=False, nogil=True)
def _overlap_range(a, b, bound, circles, verts, offs, normals, tol, out, m0, m1):
    n_circ = circles.shape[0]
    n_obs = bound.shape[0]
    cand = np.empty(n_obs, dtype=np.bool_)
    for m in range(m0, m1):
        ax = a[m, 0]
        ay = a[m, 1]
        bx = b[m, 0]
        by = b[m, 1]
        dx = bx - ax
        dy = by - ay
        length = math.sqrt(dx * dx + dy * dy)
        if not length > tol:
            # zero-length or shorter than the tolerance (every overlap <= tol), or NaN
            out[m] = 0.0 if length == length else np.nan
            continue
        if not math.isfinite(length):
            out[m] = np.nan
            continue
        ux = dx / length
        uy = dy / length
        # pass 1, branch-free: does the leg's capsule meet the obstacle's bounding disc?
        for j in range(n_obs):
            fx = bound[j, 0] - ax
            fy = bound[j, 1] - ay
            rad = bound[j, 2]
            h = abs(ux * fy - uy * fx)
            s = ux * fx + uy * fy
            cand[j] = (h < rad) & (s > -rad) & (s < length + rad)
        # pass 2: exact overlap for the few candidates
        total = 0.0
        for j in range(n_circ):
            if cand[j]:
                total += _circle_overlap(
                    ax, ay, ux, uy, length, circles[j, 0], circles[j, 1], circles[j, 2], tol
                )
        for j in range(n_circ, n_obs):
            if cand[j]:
                p = j - n_circ
                total += _polygon_overlap(
                    ax, ay, bx, by, length, verts, normals, offs[p], offs[p + 1], tol
                )
        out[m] = total


@njit(cache=True, fastmath=False, nogil=True)
def _overlap_serial(a, b, bound, circles, verts, offs, normals, tol, out):
    _overlap_range(a, b, bound, circles, verts, offs, normals, tol, out, 0, a.shape[0])


@njit(cache=True, fastmath=False, parallel=True)
def _overlap_parallel(a, b, bound, circles, verts, offs, normals, tol, out, n_chunks):
    m = a.shape[0]
    for c in prange(n_chunks):
        m0 = (m * c) // n_chunks
        m1 = (m * (c + 1)) // n_chunks
        _overlap_range(a, b, bound, circles, verts, offs, normals, tol, out, m0, m1)


@njit(cache=True, fastmath=False, nogil=True)
def _points_inside_kernel(pts, circles, verts, offs, normals, tol, out):
    n_circ = circles.shape[0]
    n_poly = offs.shape[0] - 1
    for m in range(pts.shape[0]):
        x = pts[m, 0]
        y = pts[m, 1]
        inside = False
        for j in range(n_circ):
            if math.hypot(x - circles[j, 0], y - circles[j, 1]) < circles[j, 2] - tol:
                inside = True
                break
        if not inside:
            for p in range(n_poly):
                ok = True
                for i in range(offs[p], offs[p + 1]):
                    s = normals[i, 0] * (x - verts[i, 0]) + normals[i, 1] * (y - verts[i, 1])
                    if not s < -tol:
                        ok = False
                        break
                if ok:
                    inside = True
                    break
        out[m] = inside


# --------------------------------------------------------------------------- public API


def _legs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape[-1:] != (2,) or b.shape[-1:] != (2,):
        raise ValueError(f"leg endpoints need a trailing axis of 2, got {a.shape} and {b.shape}")
    a, b = np.broadcast_arrays(a, b)
    lead = a.shape[:-1]
    a2 = np.ascontiguousarray(a.reshape(-1, 2))
    b2 = np.ascontiguousarray(b.reshape(-1, 2))
    return a2, b2, lead


def overlap_lengths(
    a: np.ndarray, b: np.ndarray, obstacles: Obstacles, *, parallel: bool | None = None
) -> np.ndarray:
    """Per leg a->b (shape (..., 2) each, broadcast), the summed length inside every obstacle.

    Exact analytic answer up to the boundary tolerance in the module docstring; NaN legs give NaN.
    ``parallel``: use numba threads (None: only for very large batches, where it pays off).
    """
    a2, b2, lead = _legs(a, b)
    out = np.empty(a2.shape[0], dtype=np.float64)
    o = obstacles
    if a2.shape[0] == 0:
        return out.reshape(lead)
    if parallel is None:
        parallel = a2.shape[0] * o.bound_circles.shape[0] >= _PARALLEL_MIN_PAIRS
    args = (
        a2, b2, o.bound_circles, o.circles, o.poly_vertices, o.poly_offsets, o.edge_normals,
        o.tol, out,
    )  # fmt: skip
    if parallel:
        import numba

        n_chunks = min(4 * numba.get_num_threads(), a2.shape[0])
        _overlap_parallel(*args, n_chunks)
    else:
        _overlap_serial(*args)
    return out.reshape(lead)


def _circle_overlap_py(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, r: float, tol: float
) -> float:
    """Plain-Python chord of the leg's line clipped to the leg (the kernel's boundary rule)."""
    length = math.hypot(bx - ax, by - ay)
    if length <= tol:
        return 0.0
    ux, uy = (bx - ax) / length, (by - ay) / length
    # closest approach of the infinite line to the centre: foot at arc length s, distance h
    s = (cx - ax) * ux + (cy - ay) * uy
    h = abs((cx - ax) * uy - (cy - ay) * ux)
    if h >= r - tol:
        return 0.0  # misses, or tangent within tol
    half = math.sqrt(r * r - h * h)
    inside = min(length, s + half) - max(0.0, s - half)
    return inside if inside > tol else 0.0


def overlap_lengths_reference(a: np.ndarray, b: np.ndarray, obstacles: Obstacles) -> np.ndarray:
    """Slow, obviously correct twin of `overlap_lengths`, one leg and one obstacle at a time.

    Polygons: shapely, length(leg & polygon) - length(leg & boundary), i.e. the open interior
    (shapely's predicates are exact, so a leg along an edge gives 0). Circles: a plain-Python
    closed-form chord, because shapely only approximates circles by polygons (buffer), which is
    off by up to r * (1 - cos(pi / n_segments)) in radius.
    """
    from shapely.geometry import LineString, Polygon

    a2, b2, lead = _legs(a, b)
    o = obstacles
    polys = [Polygon(o.polygon(p)) for p in range(o.n_polygons)]
    out = np.zeros(a2.shape[0], dtype=np.float64)
    for m in range(a2.shape[0]):
        ax, ay = float(a2[m, 0]), float(a2[m, 1])
        bx, by = float(b2[m, 0]), float(b2[m, 1])
        if not all(map(math.isfinite, (ax, ay, bx, by))):
            out[m] = np.nan
            continue
        total = 0.0
        for cx, cy, r in o.circles.tolist():
            total += _circle_overlap_py(ax, ay, bx, by, cx, cy, r, o.tol)
        if (ax, ay) != (bx, by):
            leg = LineString([(ax, ay), (bx, by)])
            for poly in polys:
                inside = leg.intersection(poly).length - leg.intersection(poly.exterior).length
                total += inside if inside > o.tol else 0.0
        out[m] = total
    return out.reshape(lead)


def points_inside(points: np.ndarray, obstacles: Obstacles) -> np.ndarray:
    """(..., 2) -> bool (...): True where a point lies strictly inside any obstacle (by > tol)."""
    p = np.asarray(points, dtype=np.float64)
    if p.shape[-1:] != (2,):
        raise ValueError(f"points need a trailing axis of 2, got {p.shape}")
    lead = p.shape[:-1]
    p2 = np.ascontiguousarray(p.reshape(-1, 2))
    out = np.zeros(p2.shape[0], dtype=np.bool_)
    o = obstacles
    if p2.shape[0]:
        _points_inside_kernel(
            p2, o.circles, o.poly_vertices, o.poly_offsets, o.edge_normals, o.tol, out
        )
    return out.reshape(lead)
