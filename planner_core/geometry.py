"""Collision-risk geometry: L_vio, the length of flight legs inside obstacles (paper Eq. L_vio).

L_vio = L_rec + L_cir + L_nfz is a sum over obstacles: a leg crossing two overlapping obstacles
counts once per obstacle. Only the open interior counts, so legs that touch a circle, run along an
edge or pass through a corner contribute 0.

Obstacles are circles and convex counter-clockwise polygons (rotated rectangles, no-fly zones).
The fast path (`overlap_lengths`) is a numba kernel that works obstacle by obstacle with the
legs in the inner loops: a branch-free float32 pass tests the obstacle's culling disc against
every leg's capsule (vectorises 8 wide; on the paper's 10 km maps it keeps ~2% of pairs), the hits
are compacted, and they get the exact float64 answer, again branch-free: the chord formula for
circles, Cyrus-Beck clipping against the edge half-planes for polygons. Branch-free matters: the
per-pair branches of a straightforward loop mispredict and cost ~100 ns per candidate pair.

Boundary tolerance (conservative). Floating point cannot say whether a leg built from rounded
coordinates is exactly tangent or exactly on an edge, and near tangency the chord length is
ill-conditioned (a rounding error delta in the distance gives a chord of 2*sqrt(2*r*delta)).
The paper's C5 is exact (any positive overlap is a violation), so the rounding band is resolved
towards the violation: with ``tol = Obstacles.tol`` (the float rounding scale of the geometry,
`_TOL_PER_METRE` times the map's extent, at least `planner_core.model.L_VIO_TOL`), every obstacle
is inflated by tol before the exact overlap is taken:
  * a circle of radius r counts the chord of radius r + tol;
  * a polygon counts its overlap with the polygon whose edge lines are moved out by tol (mitred
    corners); a leg at or beyond an inflated edge line all along its length counts 0 for it;
  * a single (leg, obstacle) overlap of length <= tol counts 0 (only legs shorter than tol).
So a tangent leg, a leg along an edge and a leg through a corner all count as touching (a small
positive overlap, hence a violation), and a leg the kernel calls collision-free keeps a clearance
of at least tol from every obstacle: its exact overlap, under shapely or any exact predicate,
is 0 (tests/test_geometry.py::test_feasible_means_zero_exact_overlap). Seeds and routes stand
off obstacles by the clearance c, far above tol.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from planner_core.model import L_VIO_TOL

__all__ = [
    "Obstacles",
    "overlap_lengths",
    "overlap_lengths_reference",
    "points_inside",
    "rectangle_vertices",
]

_TOL_PER_METRE = 1e-13  # boundary tolerance relative to the largest coordinate magnitude
_TOL_MIN = L_VIO_TOL  # metres: the tolerance never drops below this (maps up to 10 km)
_CHUNK_LEGS = 4096  # legs per kernel chunk (the per-leg work arrays stay in cache)
_COORD_LIMIT = 1e15  # metres; legs beyond this skip the float32 first pass (slow, exact path)
# Error bound of the float32 first pass, relative to the coordinate magnitude S: each of the
# capsule test's quantities (h, s) is off by at most ~20 * 2**-24 * S ~ 1.2e-6 * S (conversions,
# unit-vector rounding, three products and sums); the culling radius is padded by 3x that.
_F32_PAD_PER_METRE = 4e-6


def _readonly(x: np.ndarray) -> np.ndarray:
    x.setflags(write=False)
    return x


def _check_polygon(v: np.ndarray, index: int) -> None:
    """Raise ValueError unless v (V, 2) is a finite, simple, convex, counter-clockwise polygon."""
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
    # (an all-left-turn pentagram winds twice); a clockwise polygon would silently count 0
    if np.any(cross < -1e-12 * elen * np.roll(elen, -1)):
        raise ValueError(f"polygon {index}: not convex counter-clockwise (a right turn)")
    winding = float(np.sum(np.arctan2(cross, dot)))
    if abs(winding - 2.0 * math.pi) > 1e-6:
        raise ValueError(f"polygon {index}: not a simple convex CCW polygon (winding {winding:g})")
    area2 = float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    if not area2 > 0.0:
        raise ValueError(f"polygon {index}: zero area")


def _clean_polygon(poly: np.ndarray, index: int) -> np.ndarray:
    """Validate one convex CCW polygon; drop a repeated closing vertex (shapely-style rings)."""
    v = np.array(poly, dtype=np.float64).reshape(-1, 2)
    if len(v) >= 2 and np.array_equal(v[0], v[-1]):
        v = v[:-1]
    _check_polygon(v, index)
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
    tol: float = field(init=False)  # boundary tolerance, metres (see the module docstring)
    # culling discs, one per obstacle (circles first, then polygons), for the kernel's first pass
    cull_radii: np.ndarray = field(init=False, repr=False)  # (K + P,) float64
    cull_centres32: np.ndarray = field(init=False, repr=False)  # (2, K + P) float32, - origin
    origin: np.ndarray = field(init=False, repr=False)  # (2,) centre of the obstacles' extent
    extent: float = field(init=False, repr=False)  # max |culling centre - origin|

    def __post_init__(self) -> None:
        # own copies: they are made read-only below, which must not touch the caller's arrays
        circles = np.array(self.circles, dtype=np.float64).reshape(-1, 3)
        verts = np.array(self.poly_vertices, dtype=np.float64).reshape(-1, 2)
        offs = np.array(self.poly_offsets, dtype=np.int64).reshape(-1)
        if len(offs) == 0:
            offs = np.zeros(1, dtype=np.int64)
        if offs[0] != 0 or offs[-1] != len(verts) or np.any(np.diff(offs) < 3):
            raise ValueError("poly_offsets must start at 0, end at len(poly_vertices), step >= 3")
        if not np.all(np.isfinite(circles)) or np.any(circles[:, 2] <= 0.0):
            raise ValueError("circles must be finite with positive radius")
        for p in range(len(offs) - 1):
            _check_polygon(verts[offs[p] : offs[p + 1]], p)

        scale = 0.0
        if len(circles):
            scale = max(scale, float(np.max(np.abs(circles[:, :2]) + circles[:, 2:3])))
        if len(verts):
            scale = max(scale, float(np.max(np.abs(verts))))
        tol = max(_TOL_MIN, _TOL_PER_METRE * scale)

        n_poly = len(offs) - 1
        normals = np.empty_like(verts)
        cull = np.empty((3, len(circles) + n_poly), dtype=np.float64)  # rows x, y, radius
        cull[:2, : len(circles)] = circles[:, :2].T
        cull[2, : len(circles)] = circles[:, 2] + tol  # the inflated circle
        for p in range(n_poly):
            v = verts[offs[p] : offs[p + 1]]
            e = np.roll(v, -1, axis=0) - v
            elen = np.hypot(e[:, 0], e[:, 1])
            normals[offs[p] : offs[p + 1], 0] = e[:, 1] / elen
            normals[offs[p] : offs[p + 1], 1] = -e[:, 0] / elen
            centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
            radius = float(np.max(np.hypot(v[:, 0] - centre[0], v[:, 1] - centre[1])))
            cull[:2, len(circles) + p] = centre
            cull[2, len(circles) + p] = radius * (1.0 + 1e-9) + 4.0 * tol  # mitred inflation
        if not np.all(np.abs(cull[:2]) < _COORD_LIMIT):
            raise ValueError(f"obstacle coordinates must be below {_COORD_LIMIT:g} in magnitude")

        object.__setattr__(self, "circles", _readonly(circles))
        object.__setattr__(self, "poly_vertices", _readonly(verts))
        object.__setattr__(self, "poly_offsets", _readonly(offs))
        object.__setattr__(self, "edge_normals", _readonly(normals))
        object.__setattr__(self, "tol", tol)
        # the first pass runs in float32 on coordinates relative to the obstacles' centre
        if cull.shape[1]:
            origin = 0.5 * (cull[:2].min(axis=1) + cull[:2].max(axis=1))
        else:
            origin = np.zeros(2)
        rel = cull[:2] - origin[:, None]
        object.__setattr__(self, "origin", _readonly(origin))
        object.__setattr__(self, "extent", float(np.max(np.abs(rel))) if rel.size else 0.0)
        object.__setattr__(self, "cull_radii", _readonly(np.ascontiguousarray(cull[2])))
        object.__setattr__(
            self, "cull_centres32", _readonly(np.ascontiguousarray(rel, dtype=np.float32))
        )

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
    r = r + tol  # inflated (module docstring)
    if h >= r:
        return 0.0
    s = ux * fx + uy * fy  # arc length along the leg of the closest approach
    w = math.sqrt((r - h) * (r + h))  # half chord
    lo = max(s - w, 0.0)
    hi = min(s + w, length)
    d = hi - lo
    return d if d > tol else 0.0


@njit(cache=True, fastmath=False, nogil=True)
def _polygon_overlap(ax, ay, bx, by, length, verts, normals, start, stop, tol):
    # Cyrus-Beck: intersect the parameter interval [0, 1] with each edge's inner half-plane.
    # Written without branches in the loop (selects only): the sign patterns are unpredictable.
    t_lo = 0.0
    t_hi = 1.0
    off = False
    for i in range(start, stop):
        nx = normals[i, 0]
        ny = normals[i, 1]
        vx = verts[i, 0]
        vy = verts[i, 1]
        # signed distance to the edge line moved out by tol, > 0 outside
        sa = nx * (ax - vx) + ny * (ay - vy) - tol
        sb = nx * (bx - vx) + ny * (by - vy) - tol
        # at or beyond this inflated half-plane's line all along the leg
        off |= (sa >= 0.0) & (sb >= 0.0)
        den = sa - sb
        t = sa / (den if den != 0.0 else 1.0)  # where the leg crosses the line, if it does
        entering = (sa >= 0.0) & (sb < 0.0)
        leaving = (sa < 0.0) & (sb >= 0.0)
        t_lo = max(t_lo, t if entering else 0.0)
        t_hi = min(t_hi, t if leaving else 1.0)
    d = (t_hi - t_lo) * length
    return d if (d > tol) & (not off) else 0.0


@njit(cache=True, fastmath=False, nogil=True)
def _leg_overlap_scalar(ax, ay, bx, by, circles, verts, offs, normals, tol):
    """One leg against every obstacle, no culling: the fallback for far-away coordinates."""
    length = math.hypot(bx - ax, by - ay)
    if not math.isfinite(length):
        return np.nan
    if not length > tol:
        return 0.0
    ux = (bx - ax) / length
    uy = (by - ay) / length
    total = 0.0
    for j in range(circles.shape[0]):
        total += _circle_overlap(
            ax, ay, ux, uy, length, circles[j, 0], circles[j, 1], circles[j, 2], tol
        )
    for p in range(offs.shape[0] - 1):
        total += _polygon_overlap(ax, ay, bx, by, length, verts, normals, offs[p], offs[p + 1], tol)
    return total


@njit(cache=True, fastmath=False, nogil=True)
def _overlap_chunk(
    a, b, circles, verts, offs, normals, tol, cull_r, cull_c32, origin, extent, out, m0, m1
):
    """Legs m0..m1 against all obstacles, obstacle by obstacle (inner loops run over legs).

    Per obstacle: (1) a branch-free float32 capsule test over all legs (vectorises 8 wide),
    (2) compaction of the hits, (3) the exact overlap for the hits, again branch-free and
    vectorisable (the sign patterns are unpredictable, so branches would mispredict).
    """
    n = m1 - m0
    n_pad = 8 * ((n + 7) // 8)
    # legs as structure of arrays; excluded legs get length -inf so no test passes
    lax = np.zeros(n_pad)
    lay = np.zeros(n_pad)
    lbx = np.zeros(n_pad)
    lby = np.zeros(n_pad)
    lux = np.zeros(n_pad)
    luy = np.zeros(n_pad)
    llen = np.full(n_pad, -np.inf)
    ox = origin[0]
    oy = origin[1]
    scale = extent
    for i in range(n):
        m = m0 + i
        ax = a[m, 0]
        ay = a[m, 1]
        bx = b[m, 0]
        by = b[m, 1]
        dx = bx - ax
        dy = by - ay
        length = math.sqrt(dx * dx + dy * dy)
        far = max(max(abs(ax - ox), abs(ay - oy)), max(abs(bx - ox), abs(by - oy)))
        out[m] = 0.0
        if length > tol and far < _COORD_LIMIT:
            lax[i] = ax
            lay[i] = ay
            lbx[i] = bx
            lby[i] = by
            lux[i] = dx / length
            luy[i] = dy / length
            llen[i] = length
            scale = max(scale, far)
        elif not length <= tol:  # NaN, inf or beyond the float32 range: no culling
            out[m] = _leg_overlap_scalar(ax, ay, bx, by, circles, verts, offs, normals, tol)
    pad = _F32_PAD_PER_METRE * scale + 1e-6
    fax = np.empty(n_pad, dtype=np.float32)
    fay = np.empty(n_pad, dtype=np.float32)
    fux = np.empty(n_pad, dtype=np.float32)
    fuy = np.empty(n_pad, dtype=np.float32)
    flen = np.empty(n_pad, dtype=np.float32)
    for i in range(n_pad):
        fax[i] = lax[i] - ox
        fay[i] = lay[i] - oy
        fux[i] = lux[i]
        fuy[i] = luy[i]
        flen[i] = llen[i]

    flags = np.zeros(n_pad, dtype=np.uint8)
    words = flags.view(np.uint64)  # scan 8 flags at a time: almost all are 0
    idx = np.empty(n_pad, dtype=np.int64)
    gax = np.empty(n_pad)
    gay = np.empty(n_pad)
    gbx = np.empty(n_pad)
    gby = np.empty(n_pad)
    t_lo = np.empty(n_pad)
    t_hi = np.empty(n_pad)
    off = np.empty(n_pad, dtype=np.bool_)
    n_circ = circles.shape[0]
    for j in range(cull_r.shape[0]):
        # (1) does the leg's capsule meet the culling disc (padded for float32 rounding)?
        cx = cull_c32[0, j]
        cy = cull_c32[1, j]
        rad = np.float32(cull_r[j] + pad)
        for i in range(n_pad):
            fx = cx - fax[i]
            fy = cy - fay[i]
            h = abs(fux[i] * fy - fuy[i] * fx)
            s = fux[i] * fx + fuy[i] * fy
            flags[i] = np.uint8((h < rad) & (s > -rad) & (s < flen[i] + rad))
        # (2) compact the hits into idx[:k]
        k = 0
        for w in range(n_pad // 8):
            if words[w] != 0:
                for i in range(8 * w, 8 * w + 8):
                    idx[k] = i
                    k += flags[i]
        if k == 0:
            continue
        # (3) exact overlap, accumulated in obstacle order (the reference's order)
        if j < n_circ:
            cx64 = circles[j, 0]
            cy64 = circles[j, 1]
            r = circles[j, 2] + tol  # inflated (module docstring)
            for q in range(k):
                i = idx[q]
                fx = cx64 - lax[i]
                fy = cy64 - lay[i]
                h = abs(lux[i] * fy - luy[i] * fx)  # distance from the centre to the line
                s = lux[i] * fx + luy[i] * fy  # where along the leg the closest approach is
                w2 = (r - h) * (r + h)
                half = math.sqrt(w2 if w2 > 0.0 else 0.0)  # half chord
                d = min(s + half, llen[i]) - max(s - half, 0.0)
                t_lo[q] = d if (d > tol) & (h < r) else 0.0
            for q in range(k):
                out[m0 + idx[q]] += t_lo[q]
        else:
            p = j - n_circ
            for q in range(k):
                i = idx[q]
                gax[q] = lax[i]
                gay[q] = lay[i]
                gbx[q] = lbx[i]
                gby[q] = lby[i]
                t_lo[q] = 0.0
                t_hi[q] = 1.0
                off[q] = False
            # Cyrus-Beck: clip the parameter interval [0, 1] by each edge's inner half-plane
            for e in range(offs[p], offs[p + 1]):
                nx = normals[e, 0]
                ny = normals[e, 1]
                vx = verts[e, 0]
                vy = verts[e, 1]
                for q in range(k):
                    # signed distance to the edge line moved out by tol, > 0 outside
                    sa = nx * (gax[q] - vx) + ny * (gay[q] - vy) - tol
                    sb = nx * (gbx[q] - vx) + ny * (gby[q] - vy) - tol
                    # at or beyond this inflated half-plane's line all along the leg
                    off[q] |= (sa >= 0.0) & (sb >= 0.0)
                    den = sa - sb
                    t = sa / (den if den != 0.0 else 1.0)  # crossing (signs differ: no cancel)
                    t_lo[q] = max(t_lo[q], t if (sa >= 0.0) & (sb < 0.0) else 0.0)  # entering
                    t_hi[q] = min(t_hi[q], t if (sa < 0.0) & (sb >= 0.0) else 1.0)  # leaving
            for q in range(k):
                i = idx[q]
                d = (t_hi[q] - t_lo[q]) * llen[i]
                out[m0 + i] += d if (d > tol) & (not off[q]) else 0.0


@njit(cache=True, fastmath=False, nogil=True)
def _overlap_serial(
    a, b, circles, verts, offs, normals, tol, cull_r, cull_c32, origin, extent, out
):
    # chunks of legs small enough that the per-leg arrays stay in the L1/L2 cache
    m = a.shape[0]
    n_chunks = (m + _CHUNK_LEGS - 1) // _CHUNK_LEGS
    for c in range(n_chunks):
        _overlap_chunk(
            a, b, circles, verts, offs, normals, tol, cull_r, cull_c32, origin, extent, out,
            (m * c) // n_chunks, (m * (c + 1)) // n_chunks,
        )  # fmt: skip


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


def overlap_lengths(a: np.ndarray, b: np.ndarray, obstacles: Obstacles) -> np.ndarray:
    """Per leg a->b (shape (..., 2) each, broadcast), the summed length inside every obstacle.

    Exact analytic answer up to the boundary tolerance in the module docstring; NaN legs give NaN.
    Single-threaded and releases the GIL, so callers may split a batch over threads.
    """
    a2, b2, lead = _legs(a, b)
    out = np.empty(a2.shape[0], dtype=np.float64)
    if a2.shape[0]:
        o = obstacles
        _overlap_serial(
            a2, b2, o.circles, o.poly_vertices, o.poly_offsets, o.edge_normals, o.tol,
            o.cull_radii, o.cull_centres32, o.origin, o.extent, out,
        )  # fmt: skip
    return out.reshape(lead)


def _circle_overlap_py(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, r: float, tol: float
) -> float:
    """Plain-Python chord of the leg's line clipped to the leg, circle inflated by tol."""
    length = math.hypot(bx - ax, by - ay)
    if length <= tol:
        return 0.0
    ux, uy = (bx - ax) / length, (by - ay) / length
    # closest approach of the infinite line to the centre: foot at arc length s, distance h
    s = (cx - ax) * ux + (cy - ay) * uy
    h = abs((cx - ax) * uy - (cy - ay) * ux)
    r = r + tol  # the kernel's conservative boundary rule
    if h >= r:
        return 0.0  # misses the inflated circle
    half = math.sqrt(r * r - h * h)
    inside = min(length, s + half) - max(0.0, s - half)
    return inside if inside > tol else 0.0


def _hugs_an_edge_py(
    ax: float, ay: float, bx: float, by: float, poly: np.ndarray, tol: float
) -> bool:
    """True if both leg ends are at or beyond some edge's line moved out by tol (rule 2)."""
    v = poly.tolist()
    for (x0, y0), (x1, y1) in zip(v, v[1:] + v[:1], strict=True):
        ex, ey = x1 - x0, y1 - y0
        norm = math.hypot(ex, ey)
        # signed distances to the edge's line, positive outside (to the right of a CCW edge)
        da = (ey * (ax - x0) - ex * (ay - y0)) / norm
        db = (ey * (bx - x0) - ex * (by - y0)) / norm
        if da - tol >= 0.0 and db - tol >= 0.0:
            return True
    return False


def _inflated_py(poly: np.ndarray, tol: float) -> list[tuple[float, float]]:
    """Vertices of the convex CCW polygon with every edge line moved out by tol (mitred):
    vertex i moves by tol * (n_prev + n_next) / (1 + n_prev . n_next), n the unit outward
    normals of its two edges."""
    v = np.asarray(poly, dtype=float)
    e = np.roll(v, -1, axis=0) - v
    n = np.stack([e[:, 1], -e[:, 0]], axis=1) / np.hypot(e[:, 0], e[:, 1])[:, None]
    n_prev = np.roll(n, 1, axis=0)
    k = tol / (1.0 + np.einsum("ij,ij->i", n, n_prev))
    return [tuple(p) for p in (v + k[:, None] * (n + n_prev)).tolist()]


def overlap_lengths_reference(a: np.ndarray, b: np.ndarray, obstacles: Obstacles) -> np.ndarray:
    """Slow, obviously correct twin of `overlap_lengths`, one leg and one obstacle at a time.

    Polygons: shapely on the polygon inflated by tol (edge lines moved out, mitred),
    length(leg & polygon) - length(leg & boundary), i.e. the open interior (shapely's
    predicates are exact). Circles: a plain-Python closed-form chord, because shapely only
    approximates circles by polygons (buffer), which is
    off by up to r * (1 - cos(pi / n_segments)) in radius. The boundary-tolerance rules of the
    module docstring are applied explicitly, so both paths implement the same definition.
    """
    from shapely.geometry import LineString, Polygon

    a2, b2, lead = _legs(a, b)
    o = obstacles
    polys = [Polygon(_inflated_py(o.polygon(p), o.tol)) for p in range(o.n_polygons)]
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
            for p, poly in enumerate(polys):
                if _hugs_an_edge_py(ax, ay, bx, by, o.polygon(p), o.tol):
                    continue
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
