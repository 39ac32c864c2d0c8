"""Shortest paths around obstacles: the reduced visibility graph (compiled Dijkstra on demand)
and all-pairs shortest paths with next hops (Floyd-Warshall) for small dense graphs.

The reduced visibility graph's nodes are obstacle corners pushed out by a margin
(`offset.obstacle_polygons`); its edges join mutually visible nodes whose line is tangent to
both nodes' polygons, the only edges a shortest path uses.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from planner_core.model.geometry import overlap_first, points_inside
from planner_core.model.routing.offset import obstacle_polygons

__all__ = ["CLEAR", "VisibilityGraph", "build_visibility_graph", "shortest_paths", "path_hops",
           "weight_bounds"]

#: overlap lengths (m) at or below this count as a clear line of sight
CLEAR = 1e-9


@dataclass(frozen=True, eq=False)
class VisibilityGraph:
    """Reduced visibility graph over pushed-out obstacle corners (undirected, CSR adjacency).

    ``nodes`` (N, 2); ``prev``/``next`` (N, 2): the neighbouring corners on each node's own
    polygon, for the tangency test; ``indptr``/``indices``/``weights``: both directions of every
    edge; ``edges`` (E, 2): node index pairs i < j.
    """

    nodes: np.ndarray
    prev: np.ndarray
    next: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray
    weights: np.ndarray
    edges: np.ndarray

    @property
    def n(self) -> int:
        """Nodes of the graph.

        Returns:
            N.
        """
        return int(self.nodes.shape[0])

    def tangent_mask(self, pts: np.ndarray) -> np.ndarray:
        """(P, N): whether the line from each point to each node is tangent at the node.

        Args:
            pts: (P, 2) points, metres.

        Returns:
            (P, N) bool (visibility not tested: see `Seeder.connect`).
        """
        return _tangent_mask(np.ascontiguousarray(pts, dtype=float), self.nodes, self.prev,
                             self.next)  # fmt: skip

    def spread(self, src_dist: np.ndarray, weights: np.ndarray | None = None,
               bounds: tuple[float, float] | None = None) -> np.ndarray:
        """(N,) least cost from a point to every node: src_dist (N,) its cost to the nodes it
        sees (inf elsewhere), then along graph edges costing `weights` (aligned with `indices`;
        default the edge lengths, m); inf for a node it cannot reach. Multi-source Dijkstra
        (`_spread`: a bucket queue when the weights allow, else an indexed heap).

        Args:
            src_dist: (N,) the point's cost to the nodes it sees (inf elsewhere).
            weights: (2E,) edge costs aligned with `indices` (None: `weights`, the edge
                lengths, m).
            bounds: (least, largest) weight when the caller keeps them (else found here,
                O(E), `weight_bounds`).

        Returns:
            (N,) least cost to every node (inf where unreachable).
        """
        w = self.weights if weights is None else np.ascontiguousarray(weights, dtype=float)
        lo, hi = weight_bounds(w) if bounds is None else bounds
        return _spread(self.indptr, self.indices, w, np.ascontiguousarray(src_dist, dtype=float),
                       float(lo), float(hi))

    def route(self, src_dist: np.ndarray, dst_dist: np.ndarray,
              weights: np.ndarray | None = None) -> tuple[float, list[int]]:
        """Shortest a -> nodes -> b given a's (src_dist) and b's (dst_dist) distances to the
        nodes they see (inf elsewhere): (length, node path); (inf, []) when there is none.

        Args:
            src_dist: (N,) a's distances to the nodes it sees (inf elsewhere).
            dst_dist: (N,) b's distances to the nodes it sees (inf elsewhere).
            weights: edge costs aligned with `indices` (default the edge lengths, m).

        Returns:
            (length in the weights' units, node indices from a's side to b's), or (inf, []).
        """
        w = self.weights if weights is None else np.ascontiguousarray(weights, dtype=float)
        length, path = _route(self.indptr, self.indices, w, src_dist, dst_dist)
        return float(length), path.tolist()


# ----------------------------------------------------------------------------- kernels


@njit(cache=True, nogil=True)
def _tangent(u, fx, fy, nodes, prev, nxt):
    """Whether the line from (fx, fy) to node u only touches u's (pushed-out) polygon: both
    polygon neighbours of u on one side. Shortest paths bend only at such nodes."""
    dx = nodes[u, 0] - fx
    dy = nodes[u, 1] - fy
    s1 = dx * (prev[u, 1] - nodes[u, 1]) - dy * (prev[u, 0] - nodes[u, 0])
    s2 = dx * (nxt[u, 1] - nodes[u, 1]) - dy * (nxt[u, 0] - nodes[u, 0])
    tol = 1e-9 * (abs(dx) + abs(dy) + 1.0) * 20.0
    return s1 * s2 >= -tol * tol


@njit(cache=True, nogil=True)
def _tangent_pairs(nodes, prev, nxt, i0, i1):
    """The node pairs (i, j), i0 <= i < i1, i < j, whose line is tangent at both nodes (both
    polygon neighbours of each end on one side of the line: `_tangent`'s test at both ends,
    the same floats, so the same pairs as `_tangent_pairs_reference`); the output grows as
    pairs are found (doubling), so memory follows what is kept (plus a row), not n^2.

    Row by row: first both ends' tests for every j > i into a flag row, branch-free over
    structure-of-arrays copies of the nodes and their sides (vectorises), then the flags
    compacted into the output. ~3.5x faster than the reference's pair-by-pair branches (a
    quarter of the pairs tangent at random: the branches mispredict)."""
    n = nodes.shape[0]
    xs = np.ascontiguousarray(nodes[:, 0])
    ys = np.ascontiguousarray(nodes[:, 1])
    # each node's two polygon sides, as `_tangent` computes them
    px = np.empty(n)
    py = np.empty(n)
    qx = np.empty(n)
    qy = np.empty(n)
    for u in range(n):
        px[u] = prev[u, 0] - nodes[u, 0]
        py[u] = prev[u, 1] - nodes[u, 1]
        qx[u] = nxt[u, 0] - nodes[u, 0]
        qy[u] = nxt[u, 1] - nodes[u, 1]
    flags = np.zeros(n + 8, dtype=np.uint8)
    cap = 1024
    out_i = np.empty(cap, dtype=np.int64)
    out_j = np.empty(cap, dtype=np.int64)
    k = 0
    for i in range(i0, i1):
        xi = xs[i]
        yi = ys[i]
        pxi = px[i]
        pyi = py[i]
        qxi = qx[i]
        qyi = qy[i]
        for j in range(i + 1, n):
            # at i, seen from j: _tangent(i, nodes[j]); at j, seen from i: _tangent(j, nodes[i])
            dx = xi - xs[j]
            dy = yi - ys[j]
            s1 = dx * pyi - dy * pxi
            s2 = dx * qyi - dy * qxi
            tol = 1e-9 * (abs(dx) + abs(dy) + 1.0) * 20.0
            ex = xs[j] - xi
            ey = ys[j] - yi
            r1 = ex * py[j] - ey * px[j]
            r2 = ex * qy[j] - ey * qx[j]
            tol2 = 1e-9 * (abs(ex) + abs(ey) + 1.0) * 20.0
            flags[j] = np.uint8((s1 * s2 >= -tol * tol) & (r1 * r2 >= -tol2 * tol2))
        need = k + (n - i - 1)
        if need > cap:
            while cap < need:
                cap *= 2
            out_i, out_j = _grown(out_i, out_j, k, cap)
        for j in range(i + 1, n):
            out_i[k] = i
            out_j[k] = j
            k += flags[j]
    return out_i[:k].copy(), out_j[:k].copy()


@njit(cache=True, nogil=True)
def _grown(out_i, out_j, k, cap):  # pragma: no cover - compiled
    """The pair buffers `out_i`, `out_j` copied into new ones of `cap` entries (their first
    `k` kept): the growth both `_tangent_pairs` and its reference use."""
    grown_i = np.empty(cap, dtype=np.int64)
    grown_j = np.empty(cap, dtype=np.int64)
    grown_i[:k] = out_i[:k]
    grown_j[:k] = out_j[:k]
    return grown_i, grown_j


@njit(cache=True, nogil=True)
def _tangent_pairs_reference(nodes, prev, nxt, i0, i1):
    """The slow, plain reference of `_tangent_pairs` (tests hold the two equal): pair by pair,
    `_tangent` at both ends."""
    n = nodes.shape[0]
    cap = 1024
    out_i = np.empty(cap, dtype=np.int64)
    out_j = np.empty(cap, dtype=np.int64)
    k = 0
    for i in range(i0, i1):
        for j in range(i + 1, n):
            if _tangent(i, nodes[j, 0], nodes[j, 1], nodes, prev, nxt) and _tangent(
                j, nodes[i, 0], nodes[i, 1], nodes, prev, nxt
            ):
                if k == cap:
                    cap *= 2
                    out_i, out_j = _grown(out_i, out_j, k, cap)
                out_i[k] = i
                out_j[k] = j
                k += 1
    return out_i[:k].copy(), out_j[:k].copy()


#: node pairs tested per block of rows of `_tangent_pairs` (the tangent ones are then tested
#: for a clear line block by block): what the visibility graph's build holds at once is this
#: block's candidates plus the edges kept, never n(n-1)/2 pairs (~20 GB of int64 at 50,000
#: nodes, the documented vertex limit)
PAIR_BLOCK = 4_000_000


def _row_blocks(n: int, block: int | None = None) -> list[tuple[int, int]]:
    """[i0, i1) row ranges of the upper triangle of an n x n pair matrix, each holding about
    `block` pairs (None: `PAIR_BLOCK` as it is at the call) (at least one row)."""
    block = PAIR_BLOCK if block is None else block
    out = []
    i0 = 0
    while i0 < n:
        i1, pairs = i0, 0
        while i1 < n and (pairs == 0 or pairs + (n - i1 - 1) <= block):
            pairs += n - i1 - 1
            i1 += 1
        out.append((i0, i1))
        i0 = i1
    return out


@njit(cache=True, nogil=True)
def _tangent_mask(pts, nodes, prev, nxt):
    out = np.empty((pts.shape[0], nodes.shape[0]), dtype=np.bool_)
    for a in range(pts.shape[0]):
        for u in range(nodes.shape[0]):
            out[a, u] = _tangent(u, pts[a, 0], pts[a, 1], nodes, prev, nxt)
    return out


@njit(cache=True, nogil=True)
def _heap_push(hk, hv, size, key, val):
    """Push (key, val) onto the binary min-heap (hk, hv) holding `size` items; the new size."""
    pos = size
    while pos > 0:
        par = (pos - 1) // 2
        if hk[par] <= key:
            break
        hk[pos] = hk[par]
        hv[pos] = hv[par]
        pos = par
    hk[pos] = key
    hv[pos] = val
    return size + 1


@njit(cache=True, nogil=True)
def _heap_pop(hk, hv, size):
    """Pop the least (key, val) off the binary min-heap (hk, hv) holding `size` items (size > 0);
    returns (key, val, the new size)."""
    key = hk[0]
    val = hv[0]
    size -= 1
    lk = hk[size]
    lv = hv[size]
    pos = 0
    while True:  # sift the last item down from the root
        c = 2 * pos + 1
        if c >= size:
            break
        if c + 1 < size and hk[c + 1] < hk[c]:
            c += 1
        if hk[c] >= lk:
            break
        hk[pos] = hk[c]
        hv[pos] = hv[c]
        pos = c
    hk[pos] = lk
    hv[pos] = lv
    return key, val, size


@njit(cache=True, nogil=True)
def _heap_of(d, m):
    """A binary min-heap of capacity m holding (d[u], u) for every finite d[u]: (hk, hv, size)."""
    hk = np.empty(m)
    hv = np.empty(m, dtype=np.int64)
    size = 0
    for u in range(d.shape[0]):
        if d[u] < np.inf:
            size = _heap_push(hk, hv, size, d[u], u)
    return hk, hv, size


@njit(cache=True, nogil=True)
def _route(indptr, indices, weights, src_dist, dst_dist):
    """Multi-source Dijkstra (binary heap, lazy deletion) from the nodes a sees to the nodes b
    sees, stopping once no shorter way to b can appear."""
    n = src_dist.shape[0]
    d = src_dist.copy()
    pred = np.full(n, -1, dtype=np.int64)
    hk, hv, size = _heap_of(d, indices.shape[0] + n + 1)
    best = np.inf
    last = -1
    while size > 0:
        key, u, size = _heap_pop(hk, hv, size)
        if key >= best:
            break
        if key > d[u]:
            continue  # stale entry
        if key + dst_dist[u] < best:
            best = key + dst_dist[u]
            last = u
        for e in range(indptr[u], indptr[u + 1]):
            w = indices[e]
            nd = key + weights[e]
            if nd < d[w]:
                d[w] = nd
                pred[w] = u
                size = _heap_push(hk, hv, size, nd, w)
    count = 0
    u = last
    while u >= 0:
        count += 1
        u = pred[u]
    path = np.empty(count, dtype=np.int64)
    u = last
    for i in range(count - 1, -1, -1):
        path[i] = u
        u = pred[u]
    return best, path


@njit(cache=True, nogil=True)
def _sift_up(heap, pos, d, i, u, key):
    """Move node u (cost key = d[u]) up from slot i of the indexed binary min-heap (heap: node
    ids, ordered by d; pos: each node's slot) to its place."""
    while i > 0:
        p = (i - 1) >> 1
        hp = heap[p]
        if d[hp] <= key:
            break
        heap[i] = hp
        pos[hp] = i
        i = p
    heap[i] = u
    pos[u] = i


def weight_bounds(weights: np.ndarray) -> tuple[float, float]:
    """(least, largest) of edge weights (inf, 0 when there are none): what `_spread` needs to
    choose and size its bucket queue.

    Args:
        weights: edge weights, any shape.

    Returns:
        (least, largest) as floats; (inf, 0.0) for none.
    """
    w = np.asarray(weights, dtype=float)
    return (float(w.min()), float(w.max())) if w.size else (np.inf, 0.0)


#: `_spread`'s bucket queue: at most this many buckets per node (else the heap)
_BUCKETS_PER_NODE = 4
#: ... and distances within this many bucket widths (rounding stays far below one width)
_BUCKET_SPAN = 1e12


@njit(cache=True, nogil=True)
def _spread(indptr, indices, weights, src_dist, w_min, w_max):  # pragma: no cover - compiled
    """Multi-source Dijkstra from src_dist to every node: a bucket queue (Dial's, circular,
    buckets of width delta = w_min / 4) when every weight is positive and the buckets stay few,
    else `_spread_heap`. O(E + N + the distance span / delta) per call (L02's graph: 2,230
    corners, 48,040 arcs, ~450 buckets: ~0.27 ms against the heap's ~0.40 ms).

    The same costs to the bit as the heap and `_spread_reference` (tests): a node leaves the
    lowest non-empty bucket b (its cost < (b + 1) delta, rounding aside) only when its cost
    is final, since every other node waiting costs >= b delta and an arc adds >= 4 delta;
    so, as for any label-setting order, the costs are the unique fixed point
    d[u] = min(src[u], min over arcs p->u of fl(d[p] + w)) (see `_spread_heap`)."""
    n = src_dist.shape[0]
    lo = np.inf
    hi = -np.inf
    for u in range(n):
        if src_dist[u] < np.inf:
            lo = min(lo, src_dist[u])
            hi = max(hi, src_dist[u])
    if not lo < np.inf:
        return src_dist.copy()
    delta = 0.25 * w_min
    if not (delta > 0.0 and w_max < np.inf and lo >= 0.0 and hi < np.inf) or (
            hi + n * w_max) / delta > _BUCKET_SPAN:  # fmt: skip
        return _spread_heap(indptr, indices, weights, src_dist)
    need = (max(w_max, hi - lo) / delta) + 4.0
    if need > _BUCKETS_PER_NODE * n + 1024:
        return _spread_heap(indptr, indices, weights, src_dist)
    nb = 1
    while nb < need:
        nb *= 2
    mask = nb - 1
    inv = 1.0 / delta
    d = src_dist.copy()
    head = np.full(nb, -1, dtype=np.int64)
    nxt = np.empty(n, dtype=np.int64)
    prv = np.empty(n, dtype=np.int64)
    bkt = np.full(n, -1, dtype=np.int64)  # a node's bucket; -1: never queued, -2: settled
    count = 0
    for u in range(n):
        if d[u] < np.inf:
            _bucket_push(u, np.int64(d[u] * inv), mask, head, nxt, prv, bkt)
            count += 1
    cur = np.int64(lo * inv)
    while count > 0:
        s = cur & mask
        while head[s] == -1:
            cur += 1
            s = cur & mask
        u = head[s]  # any node of the lowest bucket: its cost is final
        h = nxt[u]
        head[s] = h
        if h >= 0:
            prv[h] = -1
        bkt[u] = -2
        count -= 1
        key = d[u]
        for e in range(indptr[u], indptr[u + 1]):
            w = indices[e]
            nd = key + weights[e]
            if nd < d[w]:  # never true for a settled w
                d[w] = nd
                ob = bkt[w]
                if ob >= 0:  # out of its bucket
                    p = prv[w]
                    q = nxt[w]
                    if p >= 0:
                        nxt[p] = q
                    else:
                        head[ob & mask] = q
                    if q >= 0:
                        prv[q] = p
                else:
                    count += 1
                _bucket_push(w, np.int64(nd * inv), mask, head, nxt, prv, bkt)
    return d


@njit(cache=True, nogil=True, inline="always")
def _bucket_push(u, b, mask, head, nxt, prv, bkt):  # pragma: no cover - compiled
    """Put node u at the front of bucket b's doubly linked list (`_spread`'s queue)."""
    s = b & mask
    h = head[s]
    nxt[u] = h
    prv[u] = -1
    if h >= 0:
        prv[h] = u
    head[s] = u
    bkt[u] = b


@njit(cache=True, nogil=True)
def _spread_heap(indptr, indices, weights, src_dist):  # pragma: no cover - compiled
    """Multi-source Dijkstra from src_dist to every node, on an indexed binary heap with
    decrease-key: each node enters the heap once and is moved up when its cost falls, so the
    heap holds at most N nodes (lazy deletion, `_spread_reference`, pushes a node per
    improvement: up to E + N entries). O(E log N) per call, ~2x faster than the reference on
    L02's graph (2,230 corners, 48,040 arcs), where it runs ~700 times a plan. `_spread`
    takes it when its buckets would not do (a weight <= 0, too many buckets).

    The same costs to the bit as `_spread_reference` (tests): with non-negative weights a node's
    cost is final when it leaves the heap (a later relaxation adds >= 0 to a key >= its own,
    and rounding is monotone), so both compute the unique fixed point
    d[u] = min(src[u], min over arcs p->u of fl(d[p] + w)), whatever the heap's tie order."""
    n = src_dist.shape[0]
    d = src_dist.copy()
    heap = np.empty(n, dtype=np.int64)
    pos = np.full(n, -1, dtype=np.int64)  # -1: never in the heap, -2: settled
    size = 0
    for u in range(n):
        if d[u] < np.inf:
            size += 1
            _sift_up(heap, pos, d, size - 1, u, d[u])
    while size > 0:
        u = heap[0]
        pos[u] = -2
        size -= 1
        if size > 0:  # the last node into the root's slot, sifted down
            last = heap[size]
            lk = d[last]
            i = 0
            while True:
                c = 2 * i + 1
                if c >= size:
                    break
                hc = heap[c]
                if c + 1 < size and d[heap[c + 1]] < d[hc]:
                    c += 1
                    hc = heap[c]
                if d[hc] >= lk:
                    break
                heap[i] = hc
                pos[hc] = i
                i = c
            heap[i] = last
            pos[last] = i
        key = d[u]
        for e in range(indptr[u], indptr[u + 1]):
            w = indices[e]
            nd = key + weights[e]
            if nd < d[w]:  # never true for a settled w (nd >= key >= d[w])
                d[w] = nd
                i = pos[w]
                if i == -1:
                    size += 1
                    i = size - 1
                _sift_up(heap, pos, d, i, w, nd)
    return d


@njit(cache=True, nogil=True)
def _spread_reference(indptr, indices, weights, src_dist):
    """Multi-source Dijkstra (binary heap, lazy deletion) from src_dist to every node: the slow
    reference of `_spread` and `_spread_heap` (tests hold the three equal)."""
    n = src_dist.shape[0]
    d = src_dist.copy()
    hk, hv, size = _heap_of(d, indices.shape[0] + n + 1)
    while size > 0:
        key, u, size = _heap_pop(hk, hv, size)
        if key > d[u]:
            continue  # stale entry
        for e in range(indptr[u], indptr[u + 1]):
            w = indices[e]
            nd = key + weights[e]
            if nd < d[w]:
                d[w] = nd
                size = _heap_push(hk, hv, size, nd, w)
    return d


# ----------------------------------------------------------------------------- building


def build_visibility_graph(
    obstacles: Any, width: float, height: float, margin: float, *,
    progress: Callable[[float], None] | None = None,
) -> VisibilityGraph:
    """The reduced visibility graph of `obstacles` (a `geometry.Obstacles`) pushed out by
    `margin` metres (see `VisibilityGraph`); nodes inside an obstacle or outside the area
    [0, width] x [0, height] are left out.

    Cost: N nodes (~4 per rectangle, ~6.4 per campus footprint; sensors are not nodes).
    Tangency (`_tangent_pairs`, branch-free, ~14 ns a pair) runs over all N(N-1)/2 pairs;
    the line of sight (`overlap_first`) over the tangent ones only (16-25 % of the pairs, ~95 %
    of those cut), each costing the obstacle tiles up to its first cut (the tiles nearest the
    row's corner first): O(N^2) tangency plus O(tangent pairs x tiles) float32 tile tests in
    the worst case, far fewer as cut lines leave. Measured on 2 shared CPUs under load
    (2026-12-06), the numba cache warm, CPU seconds of this call (`time.process_time`
    around ``build_visibility_graph(m.obstacles, m.width, m.height, 20.0)`` after
    ``m = load_map(MAP)``), the same sha256 of every array before and after:

    - campus-2000 (`lamde-mission map campus --footprints 2000 --sensors 100 --access
      scheduled`: 6,047 convex pieces, 12,870 nodes, 20.6 M tangent pairs, 1,086,707 edges):
      9.7 s CPU (25.8 s wall) before, 5.1 s CPU (14.6 s wall) after;
    - examples/maps/large/L08.json (1,023 obstacles, 5,014 nodes, 2.0 M tangent pairs,
      76,954 edges): 0.87 s CPU (1.7 s wall) before, 0.42 s CPU (0.65 s wall) after.

    Args:
        obstacles: the packed obstacles.
        width: the area's side along x, metres.
        height: the area's side along y, metres.
        margin: how far the corners are pushed out, metres (`offset.obstacle_polygons`).
        progress: called after each block of node pairs (`_row_blocks`: tangency, then a
            clear line) with the fraction of the N(N-1)/2 pairs done, increasing, the last
            call 1.0 (one call, 1.0, when there are fewer than two nodes); None: nothing.
            The graph is the same with or without it (a map at the obstacle limit takes
            minutes here: the CLI's setup line shows it).

    Returns:
        The graph: edges join node pairs tangent at both ends whose line is clear
        (overlap <= `CLEAR`), weighted by length, m.
    """
    polys = obstacle_polygons(obstacles, margin)
    if polys:
        nodes = np.concatenate(polys)
        prev = np.concatenate([np.roll(q, 1, axis=0) for q in polys])
        nxt = np.concatenate([np.roll(q, -1, axis=0) for q in polys])
    else:
        nodes = prev = nxt = np.zeros((0, 2))
    w, h = width, height
    keep = (nodes[:, 0] >= 0.0) & (nodes[:, 1] >= 0.0) & (nodes[:, 0] <= w) & (nodes[:, 1] <= h)
    if len(nodes):
        keep &= ~points_inside(nodes, obstacles)
    nodes = np.ascontiguousarray(nodes[keep])
    prev = np.ascontiguousarray(prev[keep])
    nxt = np.ascontiguousarray(nxt[keep])
    n = len(nodes)
    pairs = n * (n - 1) // 2
    if n:
        kept_i, kept_j = [], []
        for i0, i1 in _row_blocks(n):
            bi, bj = _tangent_pairs(nodes, prev, nxt, i0, i1)
            clear = overlap_first(nodes[bi], nodes[bj], obstacles) <= CLEAR  # = overlap_lengths
            kept_i.append(bi[clear])
            kept_j.append(bj[clear])
            if progress is not None and pairs:  # rows i1.. hold (n - i1)(n - i1 - 1)/2 pairs
                progress(1.0 - (n - i1) * (n - i1 - 1) // 2 / pairs)
        i, j = np.concatenate(kept_i), np.concatenate(kept_j)
    else:
        i = j = np.zeros(0, dtype=np.int64)
    if progress is not None and not pairs:
        progress(1.0)
    length = np.hypot(nodes[i, 0] - nodes[j, 0], nodes[i, 1] - nodes[j, 1])
    src = np.concatenate([i, j])
    dst = np.concatenate([j, i])
    wts = np.concatenate([length, length])
    order = np.lexsort((dst, src))
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=indptr[1:])
    return VisibilityGraph(
        nodes, prev, nxt, indptr, np.ascontiguousarray(dst[order]),
        np.ascontiguousarray(wts[order]), np.column_stack([i, j]),
    )  # fmt: skip


# ----------------------------------------------------------------------------- all pairs


def shortest_paths(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All-pairs shortest paths (Floyd-Warshall) of a weight matrix w (n, n) with inf for no
    edge: (distances (n, n), next hop (n, n), -1 where there is no path).

    Args:
        w: (n, n) edge weights, inf for no edge (the diagonal is taken as 0; w is copied).

    Returns:
        (distances (n, n), next hop (n, n) int: the node after i on the way to j, -1 where
        there is no path). O(n^3).
    """
    n = len(w)
    w = np.array(w, dtype=float)
    np.fill_diagonal(w, 0.0)
    nxt = np.where(np.isfinite(w), np.arange(n)[None, :], -1)
    for k in range(n):
        alt = w[:, k : k + 1] + w[k : k + 1, :]
        better = alt < w
        w = np.where(better, alt, w)
        nxt = np.where(better, nxt[:, k : k + 1], nxt)
    return w, nxt


def path_hops(nxt: np.ndarray, a: int, b: int) -> list[int]:
    """The nodes strictly between a and b on the shortest path (from `shortest_paths`).

    Args:
        nxt: (n, n) next hops from `shortest_paths`.
        a: the first node.
        b: the last node.

    Returns:
        The node indices in order, [] when a == b or they are adjacent.

    Raises:
        ValueError: b is not reachable from a (nxt[a, b] = -1), or `nxt` holds a cycle on
            the way (it is not a next-hop table of `shortest_paths`).
    """
    out: list[int] = []
    u = a
    while u != b:
        u = int(nxt[u, b])
        if u < 0 or len(out) >= len(nxt):
            raise ValueError(f"path_hops: no path from node {a} to node {b}")
        if u == b:
            break
        out.append(u)
    return out
