"""Collision-risk geometry: L_vio, the length of flight legs inside obstacles (paper Eq. L_vio).

L_vio = L_rec + L_cir + L_nfz is a sum over obstacles: a leg crossing two overlapping obstacles
counts once per obstacle. Only the interior counts, but the rounding band at the boundary counts
as inside (see "Boundary tolerance" below).

Obstacles are circles, convex counter-clockwise polygons (rotated rectangles, convex no-fly
zones) and *regions*: any simple polygon with holes (footprints, non-convex no-fly zones), cut into
convex pieces with disjoint interiors by `planner_core.model.polygons.convex_pieces`; a region's
overlap
is the sum over its pieces. A piece's internal edges (diagonals, ``Obstacles.edge_flags``) are
not boundaries, so the tolerance rules below do not apply to them: a leg is clipped at a
diagonal's exact line (what one piece drops, its neighbour keeps), and a leg lying within tol of
a diagonal all along counts for exactly one of the two pieces, the one that *owns* the diagonal.
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
`_TOL_PER_METRE` times the map's extent, at least `planner_core.model.formulas.L_VIO_TOL`), every
obstacle
is inflated by tol across its boundary before the exact overlap is taken:
  * a circle of radius r counts the chord of radius r + tol;
  * a polygon (or piece) counts its overlap with the polygon whose boundary edge lines are moved
    out by tol (mitred corners; diagonals between pieces stay exact); a leg at or beyond an
    inflated boundary line all along its length counts 0 for it;
  * a single (leg, obstacle) overlap of length <= 2 tol counts 0: the band itself (a leg leaving
    a point on the boundary crosses tol of it) and a true overlap up to tol, which the sim's C5
    check (`L_VIO_TOL`) passes too.
So a tangent leg, a leg along an edge and a leg through a corner all count as touching (a small
positive overlap, hence a violation), and a leg the kernel calls collision-free has an exact
overlap of at most tol with any obstacle, which the sim's C5 check (same `L_VIO_TOL`) passes
(tests/test_edge.py). Seeds and routes stand off obstacles by the clearance c, far above
tol.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numba import njit

from planner_core.model.formulas import L_VIO_TOL
from planner_core.model.polygons import (
    EDGE_BOUNDARY,
    EDGE_OWNED,
    EDGE_SHARED,
    convex_pieces_many,
    ring_area,
)

__all__ = [
    "Obstacles",
    "cut_legs",
    "overlap_first",
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
_TILE_MIN = 256  # obstacles: from this many on, the kernel culls by tiles first
_TILE_SIZE = 16  # obstacles per tile, roughly
_NEAR_FIRST_LEGS = 1024  # `overlap_first`: chunks of this many legs test the nearest tiles first
_EDGE_BOUNDARY = EDGE_BOUNDARY  # module-level constants the compiled kernels read
_EDGE_OWNED = EDGE_OWNED


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
    if not ring_area(v) > 0.0:
        raise ValueError(f"polygon {index}: zero area")


def _tiles(
    centres: np.ndarray, radii: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Group culling discs (centres (2, J) relative to the origin, radii (J,)) into square tiles
    of about `_TILE_SIZE` obstacles, each with a disc holding all its members' discs.

    Below `_TILE_MIN` obstacles there are no tiles (offsets [0]): the kernel then tests every
    obstacle against every leg, in obstacle order, as it always has.
    """
    J = centres.shape[1]
    if J < _TILE_MIN:
        return (np.zeros((2, 0), dtype=np.float32), np.zeros(0), np.zeros(1, dtype=np.int64),
                np.zeros(0, dtype=np.int64))  # fmt: skip
    g = max(1, int(math.ceil(math.sqrt(J / _TILE_SIZE))))
    lo = centres.min(axis=1)
    span = np.maximum(centres.max(axis=1) - lo, 1e-9)
    cell = np.minimum((g * (centres - lo[:, None]) / span[:, None]).astype(np.int64), g - 1)
    tile = cell[1] * g + cell[0]
    members = np.lexsort((np.arange(J), tile)).astype(np.int64)  # by tile, then index
    counts = np.bincount(tile, minlength=g * g)
    keep = np.flatnonzero(counts)
    offs = np.zeros(len(keep) + 1, dtype=np.int64)
    offs[1:] = np.cumsum(counts[keep])
    tc = np.empty((2, len(keep)))
    tr = np.empty(len(keep))
    for t in range(len(keep)):
        mem = members[offs[t] : offs[t + 1]]
        c, r = centres[:, mem], radii[mem]
        mid = 0.5 * ((c - r).min(axis=1) + (c + r).max(axis=1))
        tc[:, t] = mid
        tr[t] = float(np.max(np.hypot(c[0] - mid[0], c[1] - mid[1]) + r)) * (1.0 + 1e-9)
    # the float32 centre is off by up to ~1e-7 relative: pad the radius by that much and more
    tc32 = np.ascontiguousarray(tc, dtype=np.float32)
    tr = tr + np.hypot(tc32[0] - tc[0], tc32[1] - tc[1]) * 2.0
    return tc32, tr, offs, members


def _next_vertex(offs: np.ndarray) -> np.ndarray:
    """Index of each packed vertex's successor on its own polygon."""
    n = int(offs[-1])
    nxt = np.arange(1, n + 1, dtype=np.int64)
    if len(offs) > 1:
        nxt[offs[1:] - 1] = offs[:-1]
    return nxt


def _polygons_ok(verts: np.ndarray, offs: np.ndarray, nxt: np.ndarray) -> bool:
    """`_check_polygon` for all packed polygons at once (True: all pass)."""
    if len(offs) < 2:
        return True
    if not np.all(np.isfinite(verts)):
        return False
    e = verts[nxt] - verts
    elen = np.hypot(e[:, 0], e[:, 1])
    if np.any(elen == 0.0):
        return False
    e_next = e[nxt]
    cross = e[:, 0] * e_next[:, 1] - e[:, 1] * e_next[:, 0]
    dot = e[:, 0] * e_next[:, 0] + e[:, 1] * e_next[:, 1]
    if np.any(cross < -1e-12 * elen * elen[nxt]):
        return False
    starts = offs[:-1]
    winding = np.add.reduceat(np.arctan2(cross, dot), starts)
    if np.any(np.abs(winding - 2.0 * math.pi) > 1e-6):
        return False
    area2 = np.add.reduceat(verts[:, 0] * verts[nxt, 1] - verts[nxt, 0] * verts[:, 1], starts)
    return bool(np.all(area2 > 0.0))


def _clean_polygon(poly: np.ndarray, index: int) -> np.ndarray:
    """Drop a repeated closing vertex (shapely-style rings); `Obstacles` validates the rest."""
    v = np.array(poly, dtype=np.float64).reshape(-1, 2)
    if len(v) >= 2 and np.array_equal(v[0], v[-1]):
        v = v[:-1]
    if len(v) < 3:
        _check_polygon(v, index)  # raises: the rest is checked for all polygons at once
    return v


@dataclass(frozen=True, eq=False)
class Obstacles:
    """All obstacles of a map in packed arrays for the kernel; build once per map, share freely.

    Only the first six fields are inputs; the rest are derived in ``__post_init__``. Arrays are
    read-only. Equality is identity (arrays do not compare as a single bool). Regions (general
    polygons) enter as their convex pieces: `edge_flags` says which piece edges are diagonals
    (`planner_core.model.polygons`), `piece_region` which region each polygon is a piece of (-1: a
    convex polygon of its own), and `regions` keeps each region's rings (for the reference).
    """

    circles: np.ndarray  # (K, 3) rows [cx, cy, r]
    poly_vertices: np.ndarray  # (V_total, 2), each polygon CCW
    poly_offsets: np.ndarray  # (P + 1,) int64
    edge_flags: np.ndarray | None = None  # (V_total,) int8 EDGE_*; None: all boundary
    piece_region: np.ndarray | None = None  # (P,) int64 region index or -1; None: all -1
    regions: tuple[tuple[np.ndarray, tuple[np.ndarray, ...]], ...] = ()  # (shell, holes) each
    edge_normals: np.ndarray = field(init=False, repr=False)  # (V_total, 2) unit outward normals
    poly_boxes: np.ndarray = field(init=False, repr=False)  # (P, 4) min x, min y, max x, max y
    tol: float = field(init=False)  # boundary tolerance, metres (see the module docstring)
    # culling discs, one per obstacle (circles first, then polygons), for the kernel's first pass
    cull_radii: np.ndarray = field(init=False, repr=False)  # (K + P,) float64
    cull_centres32: np.ndarray = field(init=False, repr=False)  # (2, K + P) float32, - origin
    origin: np.ndarray = field(init=False, repr=False)  # (2,) centre of the obstacles' extent
    # tiles (maps with many obstacles): obstacles grouped by place, a culling disc per group
    tile_centres32: np.ndarray = field(init=False, repr=False)  # (2, T) float32, - origin
    tile_radii: np.ndarray = field(init=False, repr=False)  # (T,) float64
    tile_offsets: np.ndarray = field(init=False, repr=False)  # (T + 1,) int64; [0]: no tiles
    tile_members: np.ndarray = field(init=False, repr=False)  # (K + P,) obstacle indices
    extent: float = field(init=False, repr=False)  # max |culling centre - origin|

    @cached_property
    def kernel_arrays(self) -> tuple:
        """What the kernel (`_overlap_serial`) takes after the legs, in its order (circles ...
        tile_members, 14 items): one tuple for compiled callers of `cut_legs`.

        Returns:
            The 14 read-only arrays and scalars, built once and kept.
        """
        return (self.circles, self.poly_vertices, self.poly_offsets, self.edge_normals,
                self.edge_flags, self.tol, self.cull_radii, self.cull_centres32, self.origin,
                self.extent, self.tile_centres32, self.tile_radii, self.tile_offsets,
                self.tile_members)

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
        nxt = _next_vertex(offs)
        if not _polygons_ok(verts, offs, nxt):
            for p in range(len(offs) - 1):  # find the first bad one, for the message
                _check_polygon(verts[offs[p] : offs[p + 1]], p)
        if self.edge_flags is None:
            flags = np.zeros(len(verts), dtype=np.int8)
        else:
            flags = np.array(self.edge_flags, dtype=np.int8).reshape(-1)
        if len(flags) != len(verts) or not np.all(
            (flags == EDGE_BOUNDARY) | (flags == EDGE_OWNED) | (flags == EDGE_SHARED)
        ):
            raise ValueError("edge_flags must hold one EDGE_* flag per polygon vertex")
        if self.piece_region is None:
            region = np.full(len(offs) - 1, -1, dtype=np.int64)
        else:
            region = np.array(self.piece_region, dtype=np.int64).reshape(-1)
        regions = tuple(
            (np.array(sh, dtype=np.float64).reshape(-1, 2),
             tuple(np.array(h, dtype=np.float64).reshape(-1, 2) for h in hs))
            for sh, hs in self.regions
        )  # fmt: skip
        if len(region) != len(offs) - 1 or np.any(region < -1) or np.any(region >= len(regions)):
            raise ValueError("piece_region must give each polygon a region index or -1")

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
        if n_poly:  # all polygons at once (elementwise the same as one by one)
            e = verts[nxt] - verts
            elen = np.hypot(e[:, 0], e[:, 1])
            normals[:, 0] = e[:, 1] / elen
            normals[:, 1] = -e[:, 0] / elen
            starts = offs[:-1]
            lo = np.minimum.reduceat(verts, starts, axis=0)
            hi = np.maximum.reduceat(verts, starts, axis=0)
            centre = 0.5 * (lo + hi)
            boxes = np.hstack([lo, hi])
            owner = np.repeat(np.arange(n_poly), np.diff(offs))
            d = np.hypot(verts[:, 0] - centre[owner, 0], verts[:, 1] - centre[owner, 1])
            radius = np.maximum.reduceat(d, starts)
            cull[:2, len(circles):] = centre.T
            cull[2, len(circles):] = radius * (1.0 + 1e-9) + 4.0 * tol  # mitred inflation
        if not np.all(np.abs(cull[:2]) < _COORD_LIMIT):
            raise ValueError(f"obstacle coordinates must be below {_COORD_LIMIT:g} in magnitude")

        object.__setattr__(self, "circles", _readonly(circles))
        object.__setattr__(self, "poly_vertices", _readonly(verts))
        object.__setattr__(self, "poly_offsets", _readonly(offs))
        object.__setattr__(self, "edge_normals", _readonly(normals))
        if not n_poly:
            boxes = np.zeros((0, 4))
        object.__setattr__(self, "poly_boxes", _readonly(np.ascontiguousarray(boxes)))
        object.__setattr__(self, "tol", tol)
        object.__setattr__(self, "edge_flags", _readonly(flags))
        object.__setattr__(self, "piece_region", _readonly(region))
        object.__setattr__(self, "regions", regions)
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
        tc, tr, toffs, tmem = _tiles(rel, cull[2])
        object.__setattr__(self, "tile_centres32", _readonly(tc))
        object.__setattr__(self, "tile_radii", _readonly(tr))
        object.__setattr__(self, "tile_offsets", _readonly(toffs))
        object.__setattr__(self, "tile_members", _readonly(tmem))

    @classmethod
    def build(
        cls,
        circles: Sequence[tuple[float, float, float]],
        polygons: Sequence[np.ndarray],
        regions: Sequence[tuple[np.ndarray, Sequence[np.ndarray]]] = (),
    ) -> Obstacles:
        """Pack circles (cx, cy, r), convex CCW polygons ((V, 2) each) and regions.

        A region is (shell (V, 2), [hole (V_h, 2), ...]): any valid simple polygon with holes,
        rings as cleaned vertex cycles in any orientation (`planner_core.model.polygons.clean_ring`,
        `polygon_problem`); it is decomposed into convex pieces placed after `polygons`.
        Validates everything.

        Args:
            circles: (cx, cy, r) per circle, metres.
            polygons: convex counter-clockwise polygons, (V, 2) each, metres; a repeated
                closing vertex is dropped.
            regions: (shell (V, 2), holes [(V_h, 2), ...]) per region, metres.

        Returns:
            The packed, read-only `Obstacles`.

        Raises:
            ValueError: an invalid polygon or region (naming its index), or bad circles
                (non-finite, radius <= 0) or coordinates beyond 1e15 m.
        """
        c = np.array(circles, dtype=np.float64).reshape(-1, 3)
        cleaned = [_clean_polygon(p, i) for i, p in enumerate(polygons)]
        flags = [np.zeros(len(v), dtype=np.int8) for v in cleaned]
        piece_region = [-1] * len(cleaned)
        kept: list[tuple[np.ndarray, tuple[np.ndarray, ...]]] = []
        regions = list(regions)
        for r, ((shell, holes), pieces) in enumerate(
                zip(regions, convex_pieces_many(regions), strict=True)):
            if isinstance(pieces, ValueError | KeyError):
                raise ValueError(f"region {r}: {pieces}") from None
            if isinstance(pieces, Exception):
                raise pieces
            for v, f in pieces:  # checked with all the others in __post_init__
                cleaned.append(v)
                flags.append(f)
                piece_region.append(r)
            kept.append((np.asarray(shell, dtype=np.float64), tuple(map(np.asarray, holes))))
        offsets = np.zeros(len(cleaned) + 1, dtype=np.int64)
        offsets[1:] = np.cumsum([len(v) for v in cleaned])
        verts = np.concatenate(cleaned) if cleaned else np.zeros((0, 2), dtype=np.float64)
        fl = np.concatenate(flags) if flags else np.zeros(0, dtype=np.int8)
        return cls(circles=c, poly_vertices=verts, poly_offsets=offsets, edge_flags=fl,
                   piece_region=np.array(piece_region, dtype=np.int64), regions=tuple(kept))

    @property
    def n_regions(self) -> int:
        """Regions (general polygons with holes) packed.

        Returns:
            Their number.
        """
        return len(self.regions)

    @property
    def n_circles(self) -> int:
        """Circles packed.

        Returns:
            Their number, K.
        """
        return int(self.circles.shape[0])

    @property
    def n_polygons(self) -> int:
        """Convex polygons packed, the regions' pieces included.

        Returns:
            Their number, P.
        """
        return int(self.poly_offsets.shape[0] - 1)

    def polygon(self, p: int) -> np.ndarray:
        """Vertices (V, 2) of polygon p (read-only view).

        Args:
            p: the polygon's index, 0 .. P - 1.

        Returns:
            (V, 2) counter-clockwise vertices, metres (a read-only view).
        """
        return self.poly_vertices[self.poly_offsets[p] : self.poly_offsets[p + 1]]


def rectangle_vertices(
    cx: float, cy: float, length: float, width: float, angle_deg: float
) -> np.ndarray:
    """(4, 2) CCW corners; `length` runs along the axis angle_deg counter-clockwise from east.

    Args:
        cx: the centre's x, metres.
        cy: the centre's y, metres.
        length: the side along the axis, metres (> 0).
        width: the side across the axis, metres (> 0).
        angle_deg: the axis' angle counter-clockwise from east, degrees.

    Returns:
        (4, 2) float64 corners, counter-clockwise, metres.

    Raises:
        ValueError: a side not positive, or length x width not finite.
    """
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
    return d if d > 2.0 * tol else 0.0


@njit(cache=True, fastmath=False, nogil=True)
def _polygon_overlap(ax, ay, bx, by, length, verts, normals, eflags, start, stop, tol):
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
        # signed distance to the edge line (a boundary edge's moved out by tol), > 0 outside
        shift = tol if eflags[i] == _EDGE_BOUNDARY else 0.0
        sa = nx * (ax - vx) + ny * (ay - vy) - shift
        sb = nx * (bx - vx) + ny * (by - vy) - shift
        den = sa - sb
        t = sa / (den if den != 0.0 else 1.0)  # where the leg crosses the line, if it does
        entering = (sa >= 0.0) & (sb < 0.0)
        leaving = (sa < 0.0) & (sb >= 0.0)
        if eflags[i] == _EDGE_BOUNDARY:
            # at or beyond this inflated half-plane's line all along the leg
            off |= (sa >= 0.0) & (sb >= 0.0)
        else:
            # a diagonal: a leg along it (within tol) belongs to its owner; others clip exactly
            hug = (abs(sa) < tol) & (abs(sb) < tol)
            off |= ((sa >= 0.0) & (sb >= 0.0) & (not hug)) | (hug & (eflags[i] != _EDGE_OWNED))
            entering &= not hug
            leaving &= not hug
        t_lo = max(t_lo, t if entering else 0.0)
        t_hi = min(t_hi, t if leaving else 1.0)
    d = (t_hi - t_lo) * length
    return d if (d > 2.0 * tol) & (not off) else 0.0


@njit(cache=True, fastmath=False, nogil=True)
def _leg_overlap_scalar(ax, ay, bx, by, circles, verts, offs, normals, eflags, tol):
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
        total += _polygon_overlap(
            ax, ay, bx, by, length, verts, normals, eflags, offs[p], offs[p + 1], tol
        )
    return total


@njit(cache=True, fastmath=False, nogil=True)
def _drop_cut(fax, fay, fux, fuy, flen, lmap, n_act):
    """`overlap_first`: once a quarter of the float32 slots 0..n_act hold cut legs (length
    -inf), the live ones moved to the front in order (lmap with them) and padded to a multiple
    of 8 with slots that fail every test; returns the new slot count."""
    alive = 0
    for i in range(n_act):
        alive += flen[i] > -np.inf
    if 4 * alive > 3 * n_act:
        return n_act
    w = 0
    for i in range(n_act):
        if flen[i] > -np.inf:
            fax[w] = fax[i]
            fay[w] = fay[i]
            fux[w] = fux[i]
            fuy[w] = fuy[i]
            flen[w] = flen[i]
            lmap[w] = lmap[i]
            w += 1
    n_new = 8 * ((w + 7) // 8)
    for i in range(w, n_new):
        fax[i] = 0.0
        fay[i] = 0.0
        fux[i] = 0.0
        fuy[i] = 0.0
        flen[i] = -np.inf
        lmap[i] = 0
    return n_new


@njit(cache=True, fastmath=False, nogil=True)
def _overlap_chunk(
    a, b, circles, verts, offs, normals, eflags, tol, cull_r, cull_c32, origin, extent, tile_c32,
    tile_r, tile_offs, tile_members, out, m0, m1, first,
):
    """Legs m0..m1 against all obstacles, obstacle by obstacle (inner loops run over legs).

    Per obstacle: (1) a branch-free float32 capsule test over all legs (vectorises 8 wide),
    (2) compaction of the hits, (3) the exact overlap for the hits, again branch-free and
    vectorisable (the sign patterns are unpredictable, so branches would mispredict).
    `first`: a leg leaves the tests once one obstacle's overlap is positive (its float32
    length set to -inf, which fails every capsule test), so out holds that overlap alone
    (`overlap_first`); otherwise the sum over all obstacles.
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
    # bounding box of the culled legs (relative to origin): obstacles far from it are skipped
    bx0 = np.inf
    by0 = np.inf
    bx1 = -np.inf
    by1 = -np.inf
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
            bx0 = min(bx0, min(ax, bx) - ox)
            bx1 = max(bx1, max(ax, bx) - ox)
            by0 = min(by0, min(ay, by) - oy)
            by1 = max(by1, max(ay, by) - oy)
        elif not length <= tol:  # NaN, inf or beyond the float32 range: no culling
            out[m] = _leg_overlap_scalar(
                ax, ay, bx, by, circles, verts, offs, normals, eflags, tol
            )
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
    pos = np.empty(n_pad, dtype=np.int64)  # idx's places in the tile's (sub)list
    gax = np.empty(n_pad)
    gay = np.empty(n_pad)
    gbx = np.empty(n_pad)
    gby = np.empty(n_pad)
    t_lo = np.empty(n_pad)
    t_hi = np.empty(n_pad)
    off = np.empty(n_pad, dtype=np.bool_)
    ident = np.arange(n_pad)
    # lmap: each float32 slot's leg (chunk index); identity unless `first` drops cut legs
    lmap = np.arange(n_pad)
    fp = np.empty(n_pad, dtype=np.int64)  # idx's float32 slots
    n_act = n_pad
    # many obstacles (tile_offs holds tiles): first a disc around each tile's obstacles, then
    # the tile's obstacles against only the legs that come near it; otherwise one "tile" of all
    # obstacles in order against all legs
    flat = tile_offs.shape[0] <= 1
    sfax = np.empty(n_pad, dtype=np.float32)
    sfay = np.empty(n_pad, dtype=np.float32)
    sfux = np.empty(n_pad, dtype=np.float32)
    sfuy = np.empty(n_pad, dtype=np.float32)
    sflen = np.empty(n_pad, dtype=np.float32)
    sub = np.empty(n_pad, dtype=np.int64)
    n_circ = circles.shape[0]
    n_tiles = 1 if flat else tile_offs.shape[0] - 1
    # `first` with many legs: the tiles nearest the first leg's start first (legs that share
    # a start, as a row of the visibility graph's pairs, are mostly cut near it and leave the
    # tests early); otherwise in order. Which cut is found first may differ, whether one is
    # found does not (`overlap_first`).
    tile_order = np.arange(n_tiles)
    if first and not flat and n >= _NEAR_FIRST_LEGS:
        near = np.empty(n_tiles, dtype=np.float32)
        for t in range(n_tiles):
            near[t] = np.float32(math.hypot(tile_c32[0, t] - fax[0], tile_c32[1, t] - fay[0])
                                 - tile_r[t])  # fmt: skip
        tile_order = np.argsort(near, kind="mergesort")
    for tt in range(n_tiles):
        t = tile_order[tt]
        if flat:
            cfax, cfay, cfux, cfuy, cflen, csub = fax, fay, fux, fuy, flen, ident
            n_sub = n_pad
            j_lo = 0
            j_hi = cull_r.shape[0]
        else:
            tx = tile_c32[0, t]
            ty = tile_c32[1, t]
            trad = np.float32(tile_r[t] + pad)
            for i in range(n_act):
                fx = tx - fax[i]
                fy = ty - fay[i]
                h = abs(fux[i] * fy - fuy[i] * fx)
                s = fux[i] * fx + fuy[i] * fy
                flags[i] = np.uint8((h < trad) & (s > -trad) & (s < flen[i] + trad))
            k = 0
            for w in range(n_act // 8):
                if words[w] != 0:
                    for i in range(8 * w, 8 * w + 8):
                        sub[k] = i
                        k += flags[i]
            if k == 0:
                continue
            n_sub = 8 * ((k + 7) // 8)
            for q in range(n_sub):
                i = sub[q] if q < k else n_act - 1  # past k: a slot that fails every test
                sfax[q] = fax[i]
                sfay[q] = fay[i]
                sfux[q] = fux[i]
                sfuy[q] = fuy[i]
                sflen[q] = flen[i] if q < k else -np.inf
                sub[q] = i
            cfax, cfay, cfux, cfuy, cflen, csub = sfax, sfay, sfux, sfuy, sflen, sub
            j_lo = tile_offs[t]
            j_hi = tile_offs[t + 1]
        for jj in range(j_lo, j_hi):
            j = jj if flat else tile_members[jj]
            # (0) skip obstacles whose culling disc is clear of the legs' bounding box (none of
            # these legs can come near; the same answer as the tests below, only sooner)
            reach = cull_r[j] + 2.0 * pad
            if (
                cull_c32[0, j] + reach < bx0 or cull_c32[0, j] - reach > bx1
                or cull_c32[1, j] + reach < by0 or cull_c32[1, j] - reach > by1
            ):  # fmt: skip
                continue
            # (1) does the leg's capsule meet the culling disc (padded for float32 rounding)?
            cx = cull_c32[0, j]
            cy = cull_c32[1, j]
            rad = np.float32(cull_r[j] + pad)
            for i in range(n_sub):
                fx = cx - cfax[i]
                fy = cy - cfay[i]
                h = abs(cfux[i] * fy - cfuy[i] * fx)
                s = cfux[i] * fx + cfuy[i] * fy
                flags[i] = np.uint8((h < rad) & (s > -rad) & (s < cflen[i] + rad))
            # (2) compact the hits into idx[:k] (as the chunk's leg indices)
            k = 0
            for w in range(n_sub // 8):
                if words[w] != 0:
                    for i in range(8 * w, 8 * w + 8):
                        idx[k] = lmap[csub[i]]
                        fp[k] = csub[i]
                        pos[k] = i
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
                    t_lo[q] = d if (d > 2.0 * tol) & (h < r) else 0.0
                for q in range(k):
                    out[m0 + idx[q]] += t_lo[q]
                if first:
                    for q in range(k):
                        if t_lo[q] > 0.0:  # cut: out of every later test
                            flen[fp[q]] = -np.inf
                            cflen[pos[q]] = -np.inf
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
                    if eflags[e] == _EDGE_BOUNDARY:
                        for q in range(k):
                            # signed distances to the edge's line moved out by tol, > 0 outside
                            sa = nx * (gax[q] - vx) + ny * (gay[q] - vy) - tol
                            sb = nx * (gbx[q] - vx) + ny * (gby[q] - vy) - tol
                            # at or beyond this inflated half-plane's line all along the leg
                            off[q] |= (sa >= 0.0) & (sb >= 0.0)
                            den = sa - sb
                            t = sa / (den if den != 0.0 else 1.0)  # crossing (signs differ)
                            # entering, leaving
                            t_lo[q] = max(t_lo[q], t if (sa >= 0.0) & (sb < 0.0) else 0.0)
                            t_hi[q] = min(t_hi[q], t if (sa < 0.0) & (sb >= 0.0) else 1.0)
                    else:
                        # a diagonal: exact clipping; a leg along it (within tol) is the owner's
                        shared = eflags[e] != _EDGE_OWNED
                        for q in range(k):
                            sa = nx * (gax[q] - vx) + ny * (gay[q] - vy)
                            sb = nx * (gbx[q] - vx) + ny * (gby[q] - vy)
                            hug = (abs(sa) < tol) & (abs(sb) < tol)
                            off[q] |= ((sa >= 0.0) & (sb >= 0.0) & (not hug)) | (hug & shared)
                            den = sa - sb
                            t = sa / (den if den != 0.0 else 1.0)
                            ent = (sa >= 0.0) & (sb < 0.0) & (not hug)
                            lea = (sa < 0.0) & (sb >= 0.0) & (not hug)
                            t_lo[q] = max(t_lo[q], t if ent else 0.0)
                            t_hi[q] = min(t_hi[q], t if lea else 1.0)
                for q in range(k):
                    i = idx[q]
                    d = (t_hi[q] - t_lo[q]) * llen[i]
                    t_lo[q] = d if (d > 2.0 * tol) & (not off[q]) else 0.0
                    out[m0 + i] += t_lo[q]
                if first:
                    for q in range(k):
                        if t_lo[q] > 0.0:  # cut: out of every later test
                            flen[fp[q]] = -np.inf
                            cflen[pos[q]] = -np.inf
        if first and not flat:
            n_act = _drop_cut(fax, fay, fux, fuy, flen, lmap, n_act)


@njit(cache=True, fastmath=False, nogil=True)
def _overlap_serial(
    a, b, circles, verts, offs, normals, eflags, tol, cull_r, cull_c32, origin, extent, tile_c32,
    tile_r, tile_offs, tile_members, out, first=False,
):
    # chunks of legs small enough that the per-leg arrays stay in the L1/L2 cache
    m = a.shape[0]
    n_chunks = (m + _CHUNK_LEGS - 1) // _CHUNK_LEGS
    for c in range(n_chunks):
        _overlap_chunk(
            a, b, circles, verts, offs, normals, eflags, tol, cull_r, cull_c32, origin, extent,
            tile_c32, tile_r, tile_offs, tile_members, out, (m * c) // n_chunks,
            (m * (c + 1)) // n_chunks, first,
        )  # fmt: skip


@njit(cache=True, fastmath=False, nogil=True)
def _inside_a_polygon(x, y, verts, offs, normals, eflags, boxes, tol):
    """True if (x, y) is inside some convex piece (its box first, then every edge's side)."""
    for p in range(offs.shape[0] - 1):
        if (x < boxes[p, 0] - tol) | (x > boxes[p, 2] + tol) | (
            y < boxes[p, 1] - tol) | (y > boxes[p, 3] + tol):  # fmt: skip
            continue
        ok = True
        for i in range(offs[p], offs[p + 1]):
            s = normals[i, 0] * (x - verts[i, 0]) + normals[i, 1] * (y - verts[i, 1])
            if s < -tol:
                continue
            # a point on (within tol of) an owned diagonal is inside its owner, unless it is at
            # one of the diagonal's ends: those are the polygon's vertices
            if eflags[i] == _EDGE_OWNED and s < tol:
                j = i + 1 if i + 1 < offs[p + 1] else offs[p]
                d0 = math.hypot(x - verts[i, 0], y - verts[i, 1])
                d1 = math.hypot(x - verts[j, 0], y - verts[j, 1])
                if d0 > tol and d1 > tol:
                    continue
            ok = False
            break
        if ok:
            return True
    return False


@njit(cache=True, fastmath=False, nogil=True)
def _points_inside_kernel(pts, circles, verts, offs, normals, eflags, boxes, tol, out):
    n_circ = circles.shape[0]
    for m in range(pts.shape[0]):
        x = pts[m, 0]
        y = pts[m, 1]
        inside = False
        for j in range(n_circ):
            # hypot >= each |coordinate difference|: a circle whose box misses the point is
            # skipped without the hypot (the same answer as `_points_inside_reference`)
            rr = circles[j, 2] - tol
            dx = x - circles[j, 0]
            if abs(dx) >= rr:
                continue
            dy = y - circles[j, 1]
            if abs(dy) >= rr:
                continue
            if math.hypot(dx, dy) < rr:
                inside = True
                break
        if not inside:
            inside = _inside_a_polygon(x, y, verts, offs, normals, eflags, boxes, tol)
        out[m] = inside


@njit(cache=True, fastmath=False, nogil=True)
def _points_inside_reference(pts, circles, verts, offs, normals, eflags, boxes, tol, out):
    """The slow reference of `_points_inside_kernel`: every circle by its hypot (tests)."""
    n_circ = circles.shape[0]
    for m in range(pts.shape[0]):
        x = pts[m, 0]
        y = pts[m, 1]
        inside = False
        for j in range(n_circ):
            if math.hypot(x - circles[j, 0], y - circles[j, 1]) < circles[j, 2] - tol:
                inside = True
                break
        if not inside:
            inside = _inside_a_polygon(x, y, verts, offs, normals, eflags, boxes, tol)
        out[m] = inside


# --------------------------------------------------------------------------- public API


def _legs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if (a.ndim == 2 and a.shape == b.shape and a.shape[1] == 2 and a.flags.c_contiguous
            and b.flags.c_contiguous):  # the common (n, 2) call: nothing to broadcast
        return a, b, a.shape[:1]
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

    Args:
        a: leg starts, metres, shape (..., 2).
        b: leg ends, metres, shape (..., 2) (broadcast against `a`).
        obstacles: the packed obstacles.

    Returns:
        L_vio per leg, metres (>= 0, NaN for a NaN leg), the broadcast leading shape.

    Raises:
        ValueError: `a` or `b` without a trailing axis of 2.
    """
    return _overlap(a, b, obstacles, False)


def _overlap(a: np.ndarray, b: np.ndarray, obstacles: Obstacles, first: bool) -> np.ndarray:
    """The kernel's call behind `overlap_lengths` (first False) and `overlap_first` (True)."""
    a2, b2, lead = _legs(a, b)
    out = np.empty(a2.shape[0], dtype=np.float64)
    if a2.shape[0]:
        _overlap_serial(a2, b2, *obstacles.kernel_arrays, out, first)
    return out.reshape(lead)


def overlap_first(a: np.ndarray, b: np.ndarray, obstacles: Obstacles) -> np.ndarray:
    """Per leg a->b (as `overlap_lengths`): 0 where `overlap_lengths` is 0, else the overlap
    with the first obstacle the kernel finds cutting the leg (> 2 tol, at most the sum), NaN
    where `overlap_lengths` is NaN.

    Every obstacle's overlap is 0 or above 2 tol and the sum of non-negative floats is at
    least each term, so for any threshold t < 2 tol (`routing.graph.CLEAR`, `L_VIO_TOL`)
    ``overlap_first(...) > t`` equals ``overlap_lengths(...) > t`` leg by leg (tests): the
    clear / blocked questions of the seeder, the visibility graph and the descent. A cut leg
    leaves the kernel's tests at its first cut, so on a map with many obstacles (most long
    legs cut) it costs the tiles and obstacles up to that cut, not all of them: the same
    O(legs x tiles + candidate pairs) bound as `overlap_lengths`, much less in practice. A
    kernel chunk of at least `_NEAR_FIRST_LEGS` legs takes the tiles nearest its first leg's
    start first (legs sharing a start, as the visibility graph's rows, are mostly cut near
    it: half the line-of-sight time on a 2,000-footprint campus); which cut it reports may
    then differ from the tiles' fixed order, whether one is found does not.

    Args:
        a: leg starts, metres, shape (..., 2).
        b: leg ends, metres, shape (..., 2) (broadcast against `a`).
        obstacles: the packed obstacles.

    Returns:
        Metres per leg, the broadcast leading shape.

    Raises:
        ValueError: `a` or `b` without a trailing axis of 2.
    """
    return _overlap(a, b, obstacles, True)


@njit(cache=True, nogil=True)
def cut_legs(a, b, obst, limit):  # pragma: no cover - compiled
    """``overlap_first(a, b, obstacles) > limit`` for compiled callers: legs a -> b (n, 2) each,
    C-contiguous float64, `obst` the obstacles' `Obstacles.kernel_arrays`; (n,) bool. The same
    kernel call on the same legs as `overlap_first`, so the same flags (tests); O(`overlap_first`)
    without its Python wrapper (~10 us a call).

    Args:
        a: (n, 2) leg starts, metres, C-contiguous float64.
        b: (n, 2) leg ends, metres, C-contiguous float64.
        obst: `Obstacles.kernel_arrays`.
        limit: metres; a leg is cut when its first overlap exceeds it (below 2 tol, e.g.
            `routing.graph.CLEAR`).

    Returns:
        (n,) bool, True where the leg is cut.
    """
    (circles, verts, offs, normals, eflags, tol, cull_r, cull_c32, origin, extent, tile_c32,
     tile_r, tile_offs, tile_members) = obst
    out = np.empty(a.shape[0], dtype=np.float64)
    if a.shape[0]:
        _overlap_serial(a, b, circles, verts, offs, normals, eflags, tol, cull_r, cull_c32, origin,
                        extent, tile_c32, tile_r, tile_offs, tile_members, out, True)
    return out > limit


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
    return inside if inside > 2.0 * tol else 0.0


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
    predicates are exact). Circles: a plain-Python
    closed-form chord, because shapely only approximates circles by polygons (buffer), which is
    off by up to r * (1 - cos(pi / n_segments)) in radius. The boundary-tolerance rules of the
    module docstring are applied explicitly, so both paths implement the same definition.
    Regions (general polygons) are measured whole, as shapely polygons with holes, not piece by
    piece, inflated by tol (a mitred shapely buffer): length(leg & region) - length(leg &
    boundary), counted when above tol.

    Args:
        a: leg starts, metres, shape (..., 2).
        b: leg ends, metres, shape (..., 2) (broadcast against `a`).
        obstacles: the packed obstacles.

    Returns:
        L_vio per leg, metres (NaN for a leg with a non-finite end), the broadcast leading
        shape.

    Raises:
        ValueError: `a` or `b` without a trailing axis of 2.
    """
    from shapely.geometry import LineString, Polygon

    a2, b2, lead = _legs(a, b)
    o = obstacles
    own = [p for p in range(o.n_polygons) if o.piece_region[p] < 0]
    polys = [(p, Polygon(_inflated_py(o.polygon(p), o.tol))) for p in own]
    regions = [
        Polygon(shell, list(holes)).buffer(o.tol, join_style="mitre", mitre_limit=1e9)
        for shell, holes in o.regions
    ]
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
            for p, poly in polys:
                if _hugs_an_edge_py(ax, ay, bx, by, o.polygon(p), o.tol):
                    continue
                inside = leg.intersection(poly).length - leg.intersection(poly.exterior).length
                total += inside if inside > 2.0 * o.tol else 0.0
            for poly in regions:
                inside = leg.intersection(poly).length - leg.intersection(poly.boundary).length
                total += inside if inside > 2.0 * o.tol else 0.0
        out[m] = total
    return out.reshape(lead)


def points_inside(points: np.ndarray, obstacles: Obstacles) -> np.ndarray:
    """(..., 2) -> bool (...): True where a point lies strictly inside any obstacle (by > tol).

    Args:
        points: points, metres, shape (..., 2).
        obstacles: the packed obstacles.

    Returns:
        bool, shape (...).

    Raises:
        ValueError: `points` without a trailing axis of 2.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.shape[-1:] != (2,):
        raise ValueError(f"points need a trailing axis of 2, got {p.shape}")
    lead = p.shape[:-1]
    p2 = np.ascontiguousarray(p.reshape(-1, 2))
    out = np.zeros(p2.shape[0], dtype=np.bool_)
    o = obstacles
    if p2.shape[0]:
        _points_inside_kernel(
            p2, o.circles, o.poly_vertices, o.poly_offsets, o.edge_normals, o.edge_flags,
            o.poly_boxes, o.tol, out,
        )  # fmt: skip
    return out.reshape(lead)
