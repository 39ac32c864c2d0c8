"""Any simple polygon (convex or not, with holes) made fit for the convex overlap kernel.

Real obstacle footprints and no-fly zones are L-shaped, notched, have courtyards. The geometry
kernel (`planner_core.model.geometry`) measures legs against *convex* pieces; here a polygon with
holes
is cut into convex pieces whose interiors are disjoint and whose union is the polygon, so the
length of a leg inside the polygon is the sum of its lengths inside the pieces:

1. ``clean_ring``: a ring as a digitiser or GIS writes it is made a plain vertex cycle: a closing
   vertex equal (within ``VERTEX_TOL``) to the first is dropped, consecutive vertices closer than
   ``VERTEX_TOL`` are merged, and a vertex within ``VERTEX_TOL`` of the segment joining its
   neighbours (a vertex in the middle of an edge) is removed. ``VERTEX_TOL`` = 5 mm: above the
   rounding of coordinates stored with 8 decimals of a degree (1.1 mm), below any real feature.
2. ``polygon_problem``: the cleaned polygon must be simple (shapely/GEOS validity: no
   self-intersection, holes inside the shell and apart) with positive area.
3. ``convex_pieces``: GEOS's constrained Delaunay triangulation (vertices are the polygon's own,
   no new points), then Hertel-Mehlhorn: a diagonal is removed whenever the two pieces it
   separates stay strictly convex after merging (at most 4x the minimum number of convex pieces; an
   L-shape becomes 2 pieces, a block with a square courtyard 4).

Diagonals are the one place where the decomposition could change the answer: a leg running
exactly along a diagonal lies on the boundary of both neighbouring pieces, so the kernel's rule
"a leg along an edge counts 0" would miss it, although it is inside the polygon. Each edge of a
piece therefore carries a flag (`EDGE_BOUNDARY`, `EDGE_OWNED`, `EDGE_SHARED`): of the two pieces
along a diagonal exactly one *owns* it and treats its half-plane as closed (the kernel shifts that
edge's line outward by twice its boundary tolerance), the other treats it as open, so such a leg
is counted exactly once. The price is that a leg crossing a diagonal at an angle theta may be
counted twice over a stretch of 2 * tol / sin(theta) (tol ~ 1e-9 m: below 1e-6 m for any theta
above 0.1 degree); legs touching the polygon's real boundary are unaffected.
"""

from __future__ import annotations

import bisect
import heapq
import math
from collections.abc import Callable, Sequence

import numpy as np

from planner_core.textio import counted

__all__ = [
    "EDGE_BOUNDARY",
    "EDGE_OWNED",
    "EDGE_SHARED",
    "VERTEX_TOL",
    "clean_ring",
    "clean_polygon",
    "convex_pieces",
    "convex_pieces_many",
    "is_convex",
    "polygon_problem",
    "ring_area",
]

#: metres: closing, duplicate and collinear vertices closer than this are merged (see above)
VERTEX_TOL = 0.005

#: edge flag: the edge lies on the polygon's boundary (exterior or a hole)
EDGE_BOUNDARY = 0
#: edge flag: an internal diagonal this piece owns (a leg along it counts here)
EDGE_OWNED = 1
#: edge flag: an internal diagonal the neighbouring piece owns
EDGE_SHARED = 2


def ring_area(ring: np.ndarray) -> float:
    """Signed area (m^2) of a vertex cycle (V, 2), positive when counter-clockwise.

    Args:
        ring: (V, 2) vertex cycle, metres, without the closing vertex.

    Returns:
        The shoelace area, m^2 (negative when clockwise).
    """
    x, y = ring[:, 0], ring[:, 1]
    xn, yn = np.concatenate((x[1:], x[:1])), np.concatenate((y[1:], y[:1]))
    return 0.5 * float(np.dot(x, yn) - np.dot(xn, y))


def _seg_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    L2 = float(d @ d)
    t = 0.0 if L2 == 0.0 else min(1.0, max(0.0, float((p - a) @ d) / L2))
    q = a + t * d
    return math.hypot(p[0] - q[0], p[1] - q[1])


def clean_ring(points: Sequence[Sequence[float]] | np.ndarray,
               tol: float = VERTEX_TOL) -> tuple[np.ndarray, dict[str, int]]:
    """One ring made a plain vertex cycle: (V, 2) float64 without the closing vertex.

    Drops a closing vertex within `tol` of the first, merges consecutive vertices closer than
    `tol` and removes vertices within `tol` of the segment joining their neighbours (never
    below 3). Orientation is kept. The caller checks that at least 3 vertices remain.

    The same rings and counts as the vertex-by-vertex `_clean_ring_reference`, to the bit
    (tests): each vertex's distances are first computed for all vertices at once, and only a
    vertex whose distance is not certainly above `tol` (within `_screen_slack` of it, a
    margin far above the rounding by which the two computations may differ) is decided by the
    reference's own scalar test, in the reference's order. Cost: O(V) array work per ring, plus
    Python work per vertex only on a ring that has such a vertex.

    Args:
        points: the ring's vertices, (V, 2), metres, closed or not.
        tol: metres (`VERTEX_TOL`, 5 mm).

    Returns:
        (cycle (V', 2) float64, counts of what was changed: {"closing": 0|1,
        "duplicate": n, "collinear": n}).

    Raises:
        ValueError: a non-finite coordinate ("has a non-finite coordinate").
    """
    v = np.array(points, dtype=np.float64).reshape(-1, 2)
    if not np.all(np.isfinite(v)):
        raise ValueError("has a non-finite coordinate")
    counts = {"closing": 0, "duplicate": 0, "collinear": 0}
    if len(v) >= 2 and math.hypot(*(v[0] - v[-1])) <= tol:
        v = v[:-1]
        counts["closing"] = 1
    n = len(v)
    if n == 0:
        return v.copy(), counts
    slack = _screen_slack(v)
    if not slack < 0.125 * tol:  # coordinates beyond 1.5e8 m: no screen worth its name
        return _clean_ring_reference(points, tol)
    sure = tol + slack  # a distance computed above this is above tol computed either way
    with np.errstate(all="ignore"):  # inf or nan (overflow) is never "sure": the scalar decides
        step = np.hypot(v[1:, 0] - v[:-1, 0], v[1:, 1] - v[:-1, 1])  # |v[k + 1] - v[k]|
        apart = step > sure
    # consecutive near-duplicates (cyclically), keeping the first of a run
    keep = _merge_duplicates(v, apart, tol, counts) if not bool(np.all(apart)) else list(range(n))
    while len(keep) > 1 and math.hypot(*(v[keep[-1]] - v[keep[0]])) <= tol:
        keep.pop()
        counts["duplicate"] += 1
    w = v[keep] if len(keep) != n else v.copy()
    m = len(w)
    if m > 3:
        # each vertex's distance to the segment joining its first neighbours, all at once
        a = np.concatenate((w[-1:], w[:-1]))
        b = np.concatenate((w[1:], w[:1]))
        dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
        px, py = w[:, 0] - a[:, 0], w[:, 1] - a[:, 1]
        with np.errstate(all="ignore"):
            L2 = dx * dx + dy * dy
            t = np.where(L2 == 0.0, 0.0, np.clip((px * dx + py * dy) / L2, 0.0, 1.0))
            safe = np.hypot(px - t * dx, py - t * dy) > sure
        if not bool(np.all(safe)):
            kept = _drop_collinear(w, safe, tol, counts)
            if len(kept) != m:
                w = w[kept]
    return w, counts


def _screen_slack(v: np.ndarray) -> float:
    """Metres by which a distance computed for all vertices at once (`clean_ring`) may differ
    from `_seg_distance`'s or `math.hypot`'s on the same vertices, with a wide margin: the
    operations are the same up to their grouping, so each result differs by a few roundings
    of quantities no larger than 4x the largest coordinate (about 1e-15 x it). O(V)."""
    return 1e-12 * (1.0 + 4.0 * float(np.max(np.abs(v))))


def _merge_duplicates(v: np.ndarray, apart: np.ndarray, tol: float,
                      counts: dict[str, int]) -> list[int]:
    """`_clean_ring_reference`'s loop merging consecutive near-duplicates of `v` (N, 2), on
    indices: vertex k is compared with the last vertex kept, as there, except where that is
    vertex k - 1 and `apart[k - 1]` says the two are certainly farther than `tol` apart (kept,
    untested), so runs of such vertices are skipped. Returns the indices kept. O(N) array
    work, plus Python steps per vertex not certainly apart from its predecessor (and per
    vertex after one merged)."""
    n = len(v)
    near = (np.flatnonzero(~apart) + 1).tolist()  # k with |v[k] - v[k - 1]| possibly <= tol
    far = apart.tolist()
    xs, ys = v[:, 0].tolist(), v[:, 1].tolist()
    merged: list[int] = []
    last, k = 0, 1
    while k < n:
        if last == k - 1 and far[k - 1]:
            at = bisect.bisect_left(near, k)
            if at == len(near):
                break  # the rest is kept
            last, k = near[at] - 1, near[at]
            continue
        if math.hypot(xs[k] - xs[last], ys[k] - ys[last]) <= tol:  # the reference's floats
            merged.append(k)
            counts["duplicate"] += 1
        else:
            last = k
        k += 1
    if not merged:
        return list(range(n))
    mask = np.ones(n, dtype=bool)
    mask[merged] = False
    return np.flatnonzero(mask).tolist()


def _drop_collinear(w: np.ndarray, safe: np.ndarray, tol: float,
                    counts: dict[str, int]) -> list[int]:
    """`_clean_ring_reference`'s passes removing vertices in the middle of an edge, on a
    linked list of indices into `w` (M, 2). The reference tests every vertex left, in order,
    with its neighbours at that moment, and passes again until a pass removes none; a test
    whose vertex and neighbours are those of an earlier test gives the same answer. So a pass
    here tests, in the same order, only the vertices whose neighbours changed since their
    last test (and, in the first pass, those not certainly above `tol` from their first
    neighbours' segment: `safe` False), and stops where the reference stops (3 vertices
    left). A test computes the distance on plain floats and calls `_seg_distance` only where
    that lies within `_screen_slack` of `tol`. Returns the indices kept. O(M) array work, plus
    O(log M) Python steps per vertex tested."""
    m = len(w)
    slack = _screen_slack(w)
    sure, below = tol + slack, tol - slack
    xs, ys = w[:, 0].tolist(), w[:, 1].tolist()
    prev = [m - 1, *range(m - 1)]
    nxt = [*range(1, m), 0]
    gone = np.zeros(m, dtype=bool)
    left = m
    todo = np.flatnonzero(~safe).tolist()  # sorted: a heap already
    while todo and left > 3:
        queued = set(todo)
        again: set[int] = set()  # neighbours changed after their test: the next pass
        while todo and left > 3:
            j = heapq.heappop(todo)
            a, b = prev[j], nxt[j]
            # the same distance on plain floats decides where it is certainly on one side
            # of tol (the two may differ by rounding only: `_screen_slack`), else the reference
            dx, dy = xs[b] - xs[a], ys[b] - ys[a]
            px, py = xs[j] - xs[a], ys[j] - ys[a]
            L2 = dx * dx + dy * dy
            t = 0.0 if L2 == 0.0 else min(1.0, max(0.0, (px * dx + py * dy) / L2))
            dist = math.hypot(px - t * dx, py - t * dy)
            if dist > sure:
                near = False
            elif dist < below:
                near = True
            else:
                near = _seg_distance(w[j], w[a], w[b]) <= tol
            if near:
                nxt[a], prev[b] = b, a
                gone[j] = True
                left -= 1
                counts["collinear"] += 1
                for x in (a, b):
                    if x < j:
                        again.add(x)
                    elif x not in queued:
                        queued.add(x)
                        heapq.heappush(todo, x)
        todo = sorted(again)
    return np.flatnonzero(~gone).tolist()


def _clean_ring_reference(points: Sequence[Sequence[float]] | np.ndarray,
               tol: float = VERTEX_TOL) -> tuple[np.ndarray, dict[str, int]]:
    """`clean_ring` vertex by vertex, the reference it equals to the bit (tests): one
    `_seg_distance` per vertex and pass, O(V) Python calls per pass (O(V^2) in all when a pass
    removes vertices one at a time)."""
    v = np.array(points, dtype=np.float64).reshape(-1, 2)
    if not np.all(np.isfinite(v)):
        raise ValueError("has a non-finite coordinate")
    counts = {"closing": 0, "duplicate": 0, "collinear": 0}
    if len(v) >= 2 and math.hypot(*(v[0] - v[-1])) <= tol:
        v = v[:-1]
        counts["closing"] = 1
    pts = [p for p in v]
    # consecutive near-duplicates (cyclically), keeping the first of a run
    out: list[np.ndarray] = []
    for p in pts:
        if out and math.hypot(*(p - out[-1])) <= tol:
            counts["duplicate"] += 1
            continue
        out.append(p)
    while len(out) > 1 and math.hypot(*(out[-1] - out[0])) <= tol:
        out.pop()
        counts["duplicate"] += 1
    # vertices in the middle of an edge, until none is left
    changed = True
    while changed and len(out) > 3:
        changed = False
        i = 0
        while i < len(out) and len(out) > 3:
            a, p, b = out[i - 1], out[i], out[(i + 1) % len(out)]
            if _seg_distance(p, a, b) <= tol:
                del out[i]
                counts["collinear"] += 1
                changed = True
            else:
                i += 1
    return np.array(out, dtype=np.float64).reshape(-1, 2), counts


def is_convex(ring: np.ndarray) -> bool:
    """Whether a counter-clockwise cycle (V, 2) turns left at every vertex.

    Strictly: a straight vertex (cross product 0) makes it not convex; cleaned rings
    (`clean_ring`) have none.

    Args:
        ring: (V, 2) vertex cycle, metres, without the closing vertex.

    Returns:
        True when every turn's cross product is > 0 (False for a clockwise cycle).
    """
    e = np.concatenate((ring[1:], ring[:1])) - ring
    e2 = np.concatenate((e[1:], e[:1]))
    cross = e[:, 0] * e2[:, 1] - e[:, 1] * e2[:, 0]
    return bool(np.all(cross > 0.0))


def _on_one_line(ring: np.ndarray) -> bool:
    """Whether every vertex of `ring` (V, 2) lies within `VERTEX_TOL` of the line through its
    first vertex and the vertex farthest from it (a ring of no area, which GEOS calls a
    self-intersection). O(V)."""
    d = ring - ring[0]
    far = d[int(np.argmax(np.hypot(d[:, 0], d[:, 1])))]
    n = math.hypot(*far)
    if n == 0.0:
        return True
    return bool(np.all(np.abs(d[:, 0] * far[1] - d[:, 1] * far[0]) / n <= VERTEX_TOL))


def polygon_problem(
    shell: np.ndarray,
    holes: Sequence[np.ndarray] = (),
    locate: Callable[[float, float], str] | None = None,
) -> str | None:
    """Why the polygon (rings as vertex cycles) is not a simple polygon with area, or None.

    Uses GEOS's validity test; the answer names the problem and where, e.g.
    "self-intersection at (12.5, 40)".

    Args:
        shell: (V, 2) the exterior ring, metres.
        holes: (V_h, 2) each, the holes' rings, metres.
        locate: words the place of a problem from (x, y) instead of "x, y" (e.g. as
            longitude and latitude); None: the local coordinates.

    Returns:
        One lower-case line naming the problem (fewer than 3 vertices, zero area, or GEOS's
        reason and where), or None for a valid polygon with area.
    """
    import shapely
    from shapely.geometry import Polygon

    if len(shell) < 3:
        return f"needs at least 3 distinct vertices, got {len(shell)}"
    for k, h in enumerate(holes):
        if len(h) < 3:
            return f"hole {k} needs at least 3 distinct vertices, got {len(h)}"
    for k, ring in enumerate((shell, *holes)):
        if _on_one_line(np.asarray(ring, dtype=np.float64)):
            return ("has zero area (collinear vertices)" if k == 0
                    else f"hole {k - 1} has zero area (collinear vertices)")  # fmt: skip
    poly = Polygon(shell, [h for h in holes])
    if not poly.is_valid:
        why = shapely.is_valid_reason(poly)
        # GEOS says e.g. "Self-intersection[12.5 40]"; make it a sentence
        if "[" in why and why.endswith("]"):
            what, _, where = why[:-1].partition("[")
            xy = where.split()
            if len(xy) >= 2:
                x, y = float(xy[0]), float(xy[1])
                place = locate(x, y) if locate is not None else f"{x:.6g}, {y:.6g}"
                return f"{what.lower()} at ({place})"
        return why.lower()
    if not poly.area > 0.0:
        return "has zero area"
    return None


def clean_polygon(
    rings: Sequence[Sequence[Sequence[float]] | np.ndarray],
    locate: Callable[[float, float], str] | None = None,
) -> tuple[np.ndarray, list[np.ndarray], list[str]]:
    """A polygon's rings (exterior first, then holes) made ready for `convex_pieces`.

    Each ring is cleaned (`clean_ring`), the polygon checked (`polygon_problem`), the exterior
    made counter-clockwise and the holes clockwise (RFC 7946).

    Args:
        rings: the exterior ring, then the holes, each (V, 2) metres.
        locate: words the place of a problem (see `polygon_problem`); None: local x, y.

    Returns:
        (shell (V, 2), holes [(V_h, 2), ...], notes): notes say what was changed ("given
        clockwise; ...", "merged 1 near-duplicate vertex ...").

    Raises:
        ValueError: one line naming the problem (and the ring, or where).
    """
    out: list[np.ndarray] = []
    merged = {"duplicate": 0, "collinear": 0}
    for r, ring in enumerate(rings):
        what = "exterior ring" if r == 0 else f"hole {r - 1}"
        try:
            v, counts = clean_ring(ring)
        except ValueError as exc:
            raise ValueError(f"{what} {exc}") from None
        if len(v) < 3:
            got = len(np.asarray(ring, dtype=float).reshape(-1, 2))
            distinct = f" ({len(v)} distinct)" if len(v) != got else ""
            raise ValueError(f"{what} needs at least 3 vertices, got {got}{distinct}")
        merged["duplicate"] += counts["duplicate"]
        merged["collinear"] += counts["collinear"]
        out.append(v)
    if not out:
        raise ValueError("has no exterior ring")
    problem = polygon_problem(out[0], out[1:], locate=locate)
    if problem:
        raise ValueError(problem)
    notes = []
    shell = out[0]
    if ring_area(shell) < 0.0:
        shell = shell[::-1].copy()
        notes.append("given clockwise; reordered counter-clockwise")
    holes = [h if ring_area(h) < 0.0 else h[::-1].copy() for h in out[1:]]
    done = []
    if merged["duplicate"]:
        n = merged["duplicate"]
        done.append(f"merged {counted(n, 'near-duplicate vertex', 'near-duplicate vertices')}")
    if merged["collinear"]:
        done.append(f"removed {counted(merged['collinear'], 'vertex', 'vertices')} in the middle "
                    "of an edge")
    if done:
        notes.append(f"{' and '.join(done)} (tolerance {VERTEX_TOL * 1000:g} mm)")
    return shell, holes, notes


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def convex_pieces(
    shell: np.ndarray, holes: Sequence[np.ndarray] = ()
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Convex pieces with disjoint interiors whose union is the polygon (shell minus holes).

    A convex polygon without holes is one piece, its vertices unchanged (made
    counter-clockwise). Constrained Delaunay triangles merged by Hertel-Mehlhorn.

    `convex_pieces_many` for one polygon; the same pieces, vertices and flags as
    `_convex_pieces_reference`, to the bit (tests). Cost per polygon of V vertices: the
    triangulation (GEOS), then O(V) array work and O(V) Python steps (one per diagonal, and
    per vertex of each merged piece).

    Args:
        shell: cleaned vertex cycle (V, 2), metres, any orientation, of a valid polygon (see
            `polygon_problem`).
        holes: cleaned vertex cycles (V_h, 2), metres, any orientation.

    Returns:
        [(vertices (V, 2) counter-clockwise, flags (V,) int8)], where flags[i] describes the
        edge from vertex i to vertex i + 1 (`EDGE_BOUNDARY`, `EDGE_OWNED`, `EDGE_SHARED`; see
        the module docstring).

    Raises:
        ValueError: the triangulation does not reproduce the polygon's own vertices, has a
            zero-area triangle or does not tile the polygon (a degenerate input).
    """
    (got,) = convex_pieces_many([(shell, holes)])
    if isinstance(got, Exception):
        raise got
    return got


def convex_pieces_many(
    regions: Sequence[tuple[np.ndarray, Sequence[np.ndarray]]],
) -> list[list[tuple[np.ndarray, np.ndarray]] | Exception]:
    """`convex_pieces` of many polygons together: per polygon its pieces, or the exception
    `convex_pieces` raises for it (a ValueError for a degenerate polygon).

    The same pieces, vertices and flags as `_convex_pieces_reference` polygon by polygon, to
    the bit (tests): GEOS triangulates them all in one call (each as on its own); the
    triangles' vertices are looked up and oriented for all at once (the same cross products,
    operation by operation, as the reference's numpy scalars); Hertel-Mehlhorn visits each
    polygon's diagonals in the same order on plain floats. Cost: the triangulation, O(V)
    array work over all V vertices, and O(V) Python steps (one per vertex, diagonal and
    vertex of each merged piece), instead of a few dozen numpy and shapely calls per polygon.

    Args:
        regions: (shell (V, 2), holes [(V_h, 2), ...]) per polygon, metres, as for
            `convex_pieces`.

    Returns:
        Per polygon, in order: [(vertices (V, 2) counter-clockwise, flags (V,) int8)], or the
        exception `convex_pieces` raises for it (a ValueError naming why it cannot be cut).
    """
    import shapely
    from shapely.geometry import Polygon

    out: list[list[tuple[np.ndarray, np.ndarray]] | Exception] = []
    todo: list[tuple[int, np.ndarray, list[np.ndarray]]] = []  # (position, shell, holes)
    polys = []
    for shell, holes in regions:
        try:  # what the reference does before the triangulation, polygon by polygon
            shell = np.asarray(shell, dtype=np.float64).reshape(-1, 2)
            if ring_area(shell) < 0.0:
                shell = shell[::-1].copy()
            hl = [np.asarray(h, dtype=np.float64).reshape(-1, 2) for h in holes]
            if not hl and is_convex(shell):
                out.append([(shell, np.zeros(len(shell), dtype=np.int8))])
                continue
            poly = Polygon(shell, hl)
        except Exception as exc:  # the reference raises it: so is it answered
            out.append(exc)
            continue
        out.append([])
        todo.append((len(out) - 1, shell, hl))
        polys.append(poly)
    if not todo:
        return out
    try:
        cdt = shapely.constrained_delaunay_triangles(np.array(polys, dtype=object))
    except Exception:  # GEOS refused one: each on its own, as the reference does
        for pos, shell, hl in todo:
            out[pos] = _one_by_reference(shell, hl)
        return out
    # every polygon's vertices, numbered together, polygon after polygon
    rings = [r for _, shell, hl in todo for r in (shell, *hl)]
    lens = np.array([len(r) for r in rings], dtype=np.int64)
    per = np.array([1 + len(hl) for _, _, hl in todo], dtype=np.int64)
    nv = np.add.reduceat(lens, np.cumsum(per) - per)  # vertices per polygon
    coords = np.concatenate(rings)
    owner_of = np.repeat(np.arange(len(todo)), nv)
    keys = list(zip(owner_of.tolist(), *coords.T.tolist(), strict=True))
    n_all = len(keys)
    # a vertex's id: the first of its polygon's equal coordinates (earlier ones win)
    index = dict(zip(reversed(keys), range(n_all - 1, -1, -1), strict=True))
    ids = np.fromiter(map(index.__getitem__, keys), dtype=np.int64, count=n_all)
    nxt = np.arange(1, n_all + 1)
    ends = np.cumsum(lens)[lens > 0]
    nxt[ends - 1] = ends - lens[lens > 0]  # each ring closes on its first vertex
    lo, hi = np.minimum(ids, ids[nxt]), np.maximum(ids, ids[nxt])
    boundary = set(zip(lo.tolist(), hi.tolist(), strict=True))

    nt = shapely.get_num_geometries(cdt).astype(np.int64)
    tc, at = shapely.get_coordinates(cdt, return_index=True)
    counts = np.bincount(at, minlength=len(todo))
    odd = counts != 4 * nt  # not all closed triangles (never seen): the reference decides
    if odd.any():
        keep = ~odd[at]
        tc, at = tc[keep], at[keep]
    corner = tc.reshape(-1, 4, 2)[:, :3].reshape(-1, 2)
    tg = at[::4]  # each triangle's polygon
    ck = zip(np.repeat(tg, 3).tolist(), *corner.T.tolist(), strict=True)
    tri = np.fromiter(map(lambda k: index.get(k, -1), ck), dtype=np.int64,
                      count=len(corner)).reshape(-1, 3)  # fmt: skip
    # the reference's checks, triangle by triangle: a polygon's first failing one names it
    bad_vertex = np.any(tri < 0, axis=1)
    t0 = np.where(bad_vertex[:, None], 0, tri)
    p0, p1, p2 = coords[t0[:, 0]], coords[t0[:, 1]], coords[t0[:, 2]]
    turn = ((p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1])
            - (p1[:, 1] - p0[:, 1]) * (p2[:, 0] - p0[:, 0]))  # fmt: skip
    back = turn < 0.0  # clockwise: reversed, and the cross product taken again that way
    turn_back = ((p1[:, 0] - p2[:, 0]) * (p0[:, 1] - p2[:, 1])
                 - (p1[:, 1] - p2[:, 1]) * (p0[:, 0] - p2[:, 0]))  # fmt: skip
    flat = np.where(back, turn_back, turn) == 0.0
    tri[back] = tri[back][:, ::-1]
    failing = bad_vertex | flat
    starts = np.searchsorted(tg, np.arange(len(todo) + 1)).tolist()
    tri_l = tri.tolist()
    fail_l, bad_l = failing.tolist(), bad_vertex.tolist()
    xs, ys = coords[:, 0].tolist(), coords[:, 1].tolist()
    for g, (pos, shell, hl) in enumerate(todo):
        if odd[g]:
            out[pos] = _one_by_reference(shell, hl)
            continue
        t_a, t_b = starts[g], starts[g + 1]
        try:
            if any(fail_l[t_a:t_b]):
                k = t_a + fail_l[t_a:t_b].index(True)
                raise ValueError(
                    "the triangulation introduced a vertex (degenerate polygon)" if bad_l[k]
                    else "the triangulation has a zero-area triangle (degenerate polygon)")
            got = _hertel_mehlhorn(tri_l[t_a:t_b], boundary, xs, ys)
        except ValueError as exc:
            out[pos] = exc
            continue
        if got is None:  # a directed edge in two triangles (never seen): the reference
            out[pos] = _one_by_reference(shell, hl)
            continue
        out[pos] = [(coords[pc], np.array(fl, dtype=np.int8)) for pc, fl in got]
    return out


def _one_by_reference(shell: np.ndarray,
                      holes: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]] | Exception:
    """`_convex_pieces_reference`'s pieces, or the exception it raises."""
    try:
        return _convex_pieces_reference(shell, holes)
    except Exception as exc:
        return exc


def _hertel_mehlhorn(
    pieces: list[list[int]], boundary: set[tuple[int, int]], xs: list[float], ys: list[float],
) -> list[tuple[list[int], list[int]]] | None:
    """`_convex_pieces_reference`'s merging of counter-clockwise triangles (vertex ids into
    `xs`, `ys`) on plain floats, the same arithmetic as its numpy scalars: every diagonal, in
    order, is dropped where both pieces' merged corners stay strictly convex. Returns the
    pieces left with their edges' flags; None where a directed edge lies in two triangles
    (the reference's bookkeeping differs there). O(T) Python steps, plus the length of each
    merged piece.

    Raises:
        ValueError: the triangles do not tile the polygon (as the reference)."""
    nt = len(pieces)
    owner: dict[tuple[int, int], int] = {}
    for k, (a, b, c) in enumerate(pieces):
        owner[(a, b)] = owner[(b, c)] = owner[(c, a)] = k
    if len(owner) != 3 * nt:
        return None
    alive = [True] * nt
    diagonals = sorted({(a, b) if a < b else (b, a) for a, b in owner} - boundary)
    for u, v in diagonals:
        ka, kb = owner.get((u, v)), owner.get((v, u))
        if ka is None or kb is None or ka == kb:
            raise ValueError("the triangulation does not tile the polygon (degenerate polygon)")
        A, B = pieces[ka], pieces[kb]
        ia, ib = A.index(v), B.index(u)
        merged = A[ia:] + A[:ia] + (B[ib + 1:] + B[:ib])[:-1]  # v .. u, then B's u .. v
        # the only corners that change, v (at 0) and u (at len(A) - 1): strictly convex
        # (at a straight corner an edge's line would run along its neighbour edge, and a
        # boundary edge must not share its line with a diagonal)
        o, q, r = merged[-1], merged[0], merged[1]
        xo, yo = xs[o], ys[o]
        if not (xs[q] - xo) * (ys[r] - yo) - (ys[q] - yo) * (xs[r] - xo) > 0.0:
            continue
        pu = len(A) - 1
        o, q, r = merged[pu - 1], merged[pu], merged[(pu + 1) % len(merged)]
        xo, yo = xs[o], ys[o]
        if not (xs[q] - xo) * (ys[r] - yo) - (ys[q] - yo) * (xs[r] - xo) > 0.0:
            continue
        pieces[ka] = merged
        alive[kb] = False
        pieces[kb] = []
        # the reference gives every edge of the merged piece to ka: A's were ka's already
        for e in zip(B, B[1:] + B[:1], strict=True):
            owner[e] = ka
        owner.pop((u, v), None)
        owner.pop((v, u), None)
    return [(pc, [EDGE_BOUNDARY if ((a, b) if a < b else (b, a)) in boundary
                  else EDGE_OWNED if a < b else EDGE_SHARED
                  for a, b in zip(pc, pc[1:] + pc[:1], strict=True)])
            for k, pc in enumerate(pieces) if alive[k]]  # fmt: skip


def _convex_pieces_reference(
    shell: np.ndarray, holes: Sequence[np.ndarray] = ()
) -> list[tuple[np.ndarray, np.ndarray]]:
    """`convex_pieces` triangle by triangle on numpy scalars, the reference it equals to the
    bit (tests). O(T) Python work per polygon of T triangles (a dict lookup per vertex, a
    numpy cross product per triangle and per diagonal)."""
    shell = np.asarray(shell, dtype=np.float64).reshape(-1, 2)
    if ring_area(shell) < 0.0:
        shell = shell[::-1].copy()
    holes = [np.asarray(h, dtype=np.float64).reshape(-1, 2) for h in holes]
    if not holes and is_convex(shell):
        return [(shell, np.zeros(len(shell), dtype=np.int8))]

    import shapely
    from shapely.geometry import Polygon

    rings = [shell] + holes
    coords = np.concatenate(rings)
    index: dict[tuple[float, float], int] = {}
    for i, (x, y) in enumerate(coords.tolist()):
        index.setdefault((x, y), i)
    boundary: set[tuple[int, int]] = set()
    for r in rings:
        ids = [index[(float(x), float(y))] for x, y in r.tolist()]
        for a, b in zip(ids, ids[1:] + ids[:1], strict=True):
            boundary.add((min(a, b), max(a, b)))

    tris = shapely.get_parts(shapely.constrained_delaunay_triangles(Polygon(shell, holes)))
    pieces: list[list[int]] = []
    for t in tris:
        ring = np.asarray(t.exterior.coords)[:-1]
        try:
            ids = [index[(float(x), float(y))] for x, y in ring.tolist()]
        except KeyError:
            raise ValueError("the triangulation introduced a vertex (degenerate polygon)") from None
        if _cross(coords[ids[0]], coords[ids[1]], coords[ids[2]]) < 0.0:
            ids.reverse()
        if _cross(coords[ids[0]], coords[ids[1]], coords[ids[2]]) == 0.0:
            raise ValueError("the triangulation has a zero-area triangle (degenerate polygon)")
        pieces.append(ids)

    # Hertel-Mehlhorn: drop every diagonal whose removal leaves a convex piece
    owner: dict[tuple[int, int], int] = {}  # directed edge -> piece id
    for k, ids in enumerate(pieces):
        for a, b in zip(ids, ids[1:] + ids[:1], strict=True):
            owner[(a, b)] = k
    alive = [True] * len(pieces)
    diagonals = sorted({(min(a, b), max(a, b)) for (a, b) in owner} - boundary)
    for u, v in diagonals:
        ka, kb = owner.get((u, v)), owner.get((v, u))
        if ka is None or kb is None or ka == kb:
            raise ValueError("the triangulation does not tile the polygon (degenerate polygon)")
        A, B = pieces[ka], pieces[kb]
        ia, ib = A.index(v), B.index(u)
        a_rot = A[ia:] + A[:ia]  # v ... u
        b_rot = B[ib:] + B[:ib]  # u ... v
        merged = a_rot + b_rot[1:-1]
        n = len(merged)
        pos_u = len(a_rot) - 1
        ok = True
        for pos in (0, pos_u):  # the only corners that change: v and u
            p = coords[merged[pos - 1]]
            q = coords[merged[pos]]
            r = coords[merged[(pos + 1) % n]]
            # strictly convex: at a straight corner an edge's line would run along its
            # neighbour edge, and a boundary edge must not share its line with a diagonal
            if not _cross(p, q, r) > 0.0:
                ok = False
        if not ok:
            continue
        pieces[ka] = merged
        alive[kb] = False
        pieces[kb] = []
        for a, b in zip(merged, merged[1:] + merged[:1], strict=True):
            owner[(a, b)] = ka
        owner.pop((u, v), None)
        owner.pop((v, u), None)

    out: list[tuple[np.ndarray, np.ndarray]] = []
    for k, ids in enumerate(pieces):
        if not alive[k]:
            continue
        flags = np.empty(len(ids), dtype=np.int8)
        for i, (a, b) in enumerate(zip(ids, ids[1:] + ids[:1], strict=True)):
            if (min(a, b), max(a, b)) in boundary:
                flags[i] = EDGE_BOUNDARY
            else:
                # of the two pieces along a diagonal, the one holding it as (low id -> high id)
                flags[i] = EDGE_OWNED if a < b else EDGE_SHARED
        out.append((coords[ids].copy(), flags))
    return out
