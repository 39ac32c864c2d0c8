"""Benchmark map generator (paper Sec. 3.2 and 5.1): maps with a known feasible plan stored inside.

Every map is feasible by construction. A witness plan is drawn first (stops spread over the area,
ordered into a tour, routed around the no-fly zones, with extra bends on some legs); sensors are
then placed around its hover points (C3 kept at every hover point), its hover times are the
smallest that deliver every sensor's data plus a margin (C4, T <= T_max), and circles and
rectangles are placed off its legs: on the straight line start -> end, on the shortcuts the bends
avoid, along the route and anywhere. The witness is stored in the map and checked with `Problem`
(phi == 0) before a map is returned.

The suite (16 tasks): T01..T08 on 5 km x 5 km (I_max 10) and T09..T16 on 10 km x 10 km (I_max 20),
obstacle density 0..7 within each size. Same seed, same bytes (coordinates rounded to 0.1 m,
hover times to 0.01 s).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from planner_core.defaults import SUITE_SEED as _SUITE_SEED
from planner_core.geometry import rectangle_vertices
from planner_core.mapio import Radio, Uav, load_map
from planner_core.problem import Problem, link_rates

__all__ = [
    "SIZES",
    "N_DENSITIES",
    "SUITE_SEED",
    "SUITE_ORIGIN",
    "suite_tasks",
    "default_sensor_count",
    "max_sensor_count",
    "obstacle_counts",
    "generate_map",
    "suite_maps",
    "generate_suite",
    "dumps_map",
    "GenerationError",
]

#: map side (m) -> I_max, the two sizes of the paper's suite
SIZES: dict[int, int] = {5000: 10, 10000: 20}
#: obstacle densities per size (0 = sparsest, 7 = densest)
N_DENSITIES = 8
#: the seed the committed suite was generated with
SUITE_SEED = _SUITE_SEED
#: one fixed, realistic origin for all generated maps (Guangzhou Higher Education Mega Center)
SUITE_ORIGIN: dict[str, float] = {"lat": 23.0493, "lon": 113.3975, "alt": 10.0}

# obstacle counts per density, per size
_CIRCLES = {5000: (3, 5, 8, 11, 14, 18, 22, 26), 10000: (6, 12, 18, 25, 32, 40, 48, 56)}
_RECTANGLES = {5000: (2, 4, 7, 10, 13, 17, 21, 25), 10000: (5, 11, 17, 24, 31, 39, 47, 55)}
_NFZS = {5000: (0, 0, 0, 1, 1, 1, 2, 2), 10000: (0, 0, 1, 1, 2, 2, 3, 4)}
# legs of the witness bent sideways, with an obstacle on the shortcut they avoid
_BENDS = {5000: (0, 0, 1, 1, 2, 2, 3, 3), 10000: (0, 1, 1, 2, 3, 4, 5, 6)}

# paper Sec. 3.2 dimensions, metres
_CIRCLE_R = (40.0, 100.0)
_RECT_SIDE = (80.0, 180.0)
_NFZ_DIAMETER = (3000.0, 4000.0)
_NFZ_VERTICES = (3, 7)

# clearances, metres: generous against the 0.1 m rounding of every coordinate
_LEG_CLEARANCE = 20.0  # circle / rectangle to any witness leg
_NFZ_LEG_CLEARANCE = 30.0  # no-fly zone to any witness leg
_NFZ_CORNER_OFFSET = 60.0  # routing corners sit this far outside a no-fly zone's vertices
_NFZ_ENDPOINT_CLEARANCE = 400.0  # no-fly zone to start / end
_NFZ_STOP_CLEARANCE = 550.0  # no-fly zone to a stop (its sensors lie within 400 m)
_SENSOR_NFZ_CLEARANCE = 40.0
_SENSOR_OBSTACLE_CLEARANCE = 15.0
_SENSOR_SPACING = 120.0
_SENSOR_RADIUS = (60.0, 400.0)  # sensor distance from its hover point
_OBSTACLE_GAP = 10.0  # between circles / rectangles (bounding circles)
_HOP_PENALTY = 400.0  # metres added per routed leg, so tours prefer few routing corners
_DATA_MARGIN = 0.03  # witness hover times deliver 3 % more than required
_C3_MARGIN = 0.5  # Mbit/s kept free under R_lambda at every witness hover point
_MAX_ATTEMPTS = 60


class GenerationError(RuntimeError):
    """No map met every check within the attempt budget (should not happen for valid input)."""


class _Retry(Exception):
    """This attempt drew something unusable; start over with the next sub-seed."""


# ----------------------------------------------------------------------------- tables


def suite_tasks() -> list[tuple[str, int, int]]:
    """The 16 tasks as (name, size, density): T01..T08 on 5 km, T09..T16 on 10 km."""
    return [
        (f"T{k * N_DENSITIES + d + 1:02d}", size, d)
        for k, size in enumerate(sorted(SIZES))
        for d in range(N_DENSITIES)
    ]


def default_sensor_count(size: int, density: int) -> int:
    """Sensors grow with size and density: 8..15 on 5 km, 15..29 on 10 km."""
    _check_size_density(size, density)
    return 8 + density if size == 5000 else 15 + 2 * density


def max_sensor_count(size: int) -> int:
    """The most sensors a map of this size may ask for (two per hover point)."""
    _check_size_density(size, 0)
    return 2 * SIZES[size]


def obstacle_counts(size: int, density: int) -> tuple[int, int, int]:
    """(circles, rectangles, no-fly zones) at this size and density."""
    _check_size_density(size, density)
    return _CIRCLES[size][density], _RECTANGLES[size][density], _NFZS[size][density]


def _check_size_density(size: int, density: int) -> None:
    if size not in SIZES:
        raise ValueError(f"size must be one of {sorted(SIZES)} (got {size})")
    if not 0 <= density < N_DENSITIES:
        raise ValueError(f"density must be 0..{N_DENSITIES - 1} (got {density})")


# ----------------------------------------------------------------------------- small geometry


def _r1(x: Any) -> np.ndarray:
    """Round to 0.1 m (and turn -0.0 into 0.0) so what is checked is what is written."""
    return np.round(np.asarray(x, dtype=float), 1) + 0.0


def _seg_point_dist(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distances (S, P) from points p (P, 2) to segments a->b (S, 2)."""
    ab = b - a
    ap = p[None, :, :] - a[:, None, :]
    den = np.einsum("sk,sk->s", ab, ab)
    t = np.einsum("spk,sk->sp", ap, ab) / np.where(den > 0, den, 1.0)[:, None]
    t = np.clip(t, 0.0, 1.0)
    close = a[:, None, :] + t[:, :, None] * ab[:, None, :]
    return np.hypot(*(p[None, :, :] - close).transpose(2, 0, 1))


def _offset_vertices(poly: np.ndarray, c: float) -> np.ndarray:
    """Vertices of a convex CCW polygon pushed out by c along the mitre (c from both edges)."""
    e = np.roll(poly, -1, axis=0) - poly
    n = np.stack([e[:, 1], -e[:, 0]], axis=1) / np.hypot(e[:, 0], e[:, 1])[:, None]
    n_prev = np.roll(n, 1, axis=0)
    dot = np.einsum("ik,ik->i", n, n_prev)
    return poly + c * (n + n_prev) / (1.0 + dot)[:, None]


# ----------------------------------------------------------------------------- the generator


class _Draw:
    """One attempt at one map: every random draw comes from `rng`, in a fixed order."""

    def __init__(self, rng: np.random.Generator, size: int, density: int, n_sensors: int):
        self.rng = rng
        self.size = float(size)
        self.density = density
        self.imax = SIZES[size]
        self.n_sensors = n_sensors
        self.n_circles, self.n_rects, self.n_nfz = obstacle_counts(size, density)
        self.n_bends = _BENDS[size][density]
        uav, radio = Uav(), Radio()
        self.altitude = uav.altitude
        self.t_max = uav.max_hover_time
        self.peak_rate = radio.peak_rate
        self.decay = radio.decay
        self.bandwidth = radio.bandwidth
        self.required = radio.required_data

    # ---------------------------------------------------------------- helpers
    def inside(self, p: np.ndarray, margin: float = 0.0) -> bool:
        return bool(np.all(p >= margin) and np.all(p <= self.size - margin))

    def rates(self, hover: np.ndarray, sensors: np.ndarray) -> np.ndarray:
        """R (I, J), the model's rate formula."""
        return link_rates(hover, sensors, self.altitude, self.peak_rate, self.decay)

    def nfz_distance(self, geoms: Any) -> np.ndarray:
        """Distance of shapely geometries to the nearest no-fly zone (inf when there is none)."""
        out = np.full(np.shape(geoms), np.inf)
        for poly in self.nfz_shapes:
            out = np.minimum(out, shapely.distance(geoms, poly))
        return out

    # ---------------------------------------------------------------- 1. start and end
    def endpoints(self) -> None:
        rng, s = self.rng, self.size
        m = rng.uniform(0.03, 0.10, size=4) * s
        layout = int(rng.integers(0, 8))
        if layout < 4:  # opposite corners
            sx, sy = (m[0], m[1])
            ex, ey = (s - m[2], s - m[3])
            if layout & 1:
                sx, ex = s - sx, s - ex
            if layout & 2:
                (sx, sy), (ex, ey) = (ex, ey), (sx, sy)
        else:  # opposite edges
            along = rng.uniform(0.2, 0.8, size=2) * s
            sx, sy, ex, ey = m[0], along[0], s - m[1], along[1]
            if layout & 1:  # bottom -> top instead of left -> right
                sx, sy, ex, ey = sy, sx, ey, ex
            if layout & 2:
                sx, sy, ex, ey = ex, ey, sx, sy
        self.start = _r1([sx, sy])
        self.end = _r1([ex, ey])

    # ---------------------------------------------------------------- 2. no-fly zones
    def no_fly_zones(self) -> None:
        rng, s = self.rng, self.size
        axis = self.end - self.start
        perp = np.array([-axis[1], axis[0]]) / np.hypot(*axis)
        ends = shapely.points([self.start, self.end])
        self.nfz: list[np.ndarray] = []
        for k in range(self.n_nfz):
            for _ in range(300):
                t = 0.2 + 0.6 * (k + rng.uniform(0.15, 0.85)) / self.n_nfz
                centre = self.start + t * axis + rng.normal(0.0, 0.12 * s) * perp
                n = int(rng.integers(_NFZ_VERTICES[0], _NFZ_VERTICES[1] + 1))
                gaps = rng.uniform(0.6, 1.4, size=n)
                ang = rng.uniform(0, 2 * math.pi) + np.cumsum(gaps / gaps.sum() * 2 * math.pi)
                pts = np.stack([np.cos(ang) * rng.uniform(0.6, 1.0), np.sin(ang)], axis=1)
                rot = rng.uniform(0, 2 * math.pi)
                c, sn = math.cos(rot), math.sin(rot)
                pts = pts @ np.array([[c, sn], [-sn, c]])
                diam = np.max(np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1)))
                pts = _r1(centre + pts * (rng.uniform(*_NFZ_DIAMETER) / diam))
                if not self.inside(pts):
                    continue
                e = np.roll(pts, -1, axis=0) - pts
                e2 = np.roll(e, -1, axis=0)
                if np.any(e[:, 0] * e2[:, 1] - e[:, 1] * e2[:, 0] <= 1.0):
                    continue  # keep it strictly convex and counter-clockwise after rounding
                if np.min(shapely.distance(ends, shapely.Polygon(pts))) < _NFZ_ENDPOINT_CLEARANCE:
                    continue
                self.nfz.append(pts)
                break
            else:
                raise _Retry
        self.nfz_shapes = [shapely.Polygon(p) for p in self.nfz]
        for p in self.nfz_shapes:
            shapely.prepare(p)

    # ---------------------------------------------------------------- 3. stops, tour, routing
    def stops(self) -> None:
        rng, s = self.rng, self.size
        n_stops = math.ceil(self.n_sensors / 2)
        n_stops = max(1, min(n_stops, self.imax - 2 * self.n_nfz - (1 if self.n_bends else 0)))
        min_sep = 0.15 * s
        stops: list[np.ndarray] = []
        for _ in range(n_stops):
            for _ in range(500):
                p = _r1(rng.uniform(400.0, s - 400.0, size=2))
                if stops and np.min(np.hypot(*(np.array(stops) - p).T)) < min_sep:
                    continue
                if min(np.hypot(*(p - self.start)), np.hypot(*(p - self.end))) < 300.0:
                    continue
                if self.nfz_distance(shapely.points(p)) < _NFZ_STOP_CLEARANCE:
                    continue
                stops.append(p)
                break
            else:
                raise _Retry
        self.stop_points = np.array(stops)

    def route(self) -> None:
        """Order the stops into a tour and route it around the no-fly zones (visibility graph)."""
        targets = np.vstack([self.start, self.stop_points, self.end])
        corners = [_r1(_offset_vertices(p, _NFZ_CORNER_OFFSET)) for p in self.nfz]
        cand = np.vstack(corners) if corners else np.zeros((0, 2))
        if len(cand):
            ok = np.all((cand >= 1.0) & (cand <= self.size - 1.0), axis=1)
            ok &= self.nfz_distance(shapely.points(cand)) >= _NFZ_LEG_CLEARANCE + 5.0
            cand = cand[ok]
        nodes = np.vstack([targets, cand])
        n, nt = len(nodes), len(targets)
        i, j = np.triu_indices(n, 1)
        length = np.hypot(*(nodes[j] - nodes[i]).T)
        visible = np.ones(len(i), dtype=bool)
        if self.nfz:
            lines = shapely.linestrings(np.stack([nodes[i], nodes[j]], axis=1))
            visible = self.nfz_distance(lines) >= _NFZ_LEG_CLEARANCE
        w = np.full((n, n), np.inf)
        w[i[visible], j[visible]] = length[visible] + _HOP_PENALTY
        w[j[visible], i[visible]] = length[visible] + _HOP_PENALTY
        np.fill_diagonal(w, 0.0)
        nxt = np.where(np.isfinite(w), np.arange(n)[None, :], -1)
        for k in range(n):  # Floyd-Warshall with next-hop tracking
            alt = w[:, k : k + 1] + w[k : k + 1, :]
            better = alt < w
            w = np.where(better, alt, w)
            nxt = np.where(better, nxt[:, k : k + 1], nxt)
        cost = w[:nt, :nt]
        if not np.all(np.isfinite(cost)):
            raise _Retry
        order = self._tour(cost)
        seq = [0, *order, nt - 1]
        hover: list[np.ndarray] = []
        kinds: list[str] = []
        for a, b in zip(seq[:-1], seq[1:], strict=True):
            u = a
            while u != b:
                u = int(nxt[u, b])
                if u == b:
                    break
                hover.append(nodes[u])
                kinds.append("corner")
            if b != nt - 1:
                hover.append(nodes[b])
                kinds.append("stop")
        if len(hover) > self.imax:
            raise _Retry
        self.hover = [np.array(h) for h in hover]
        self.kinds = kinds
        self.tour_stops = targets[seq]  # start, stops in tour order, end

    @staticmethod
    def _tour(cost: np.ndarray) -> list[int]:
        """Stops 1..n-2 between fixed ends 0 and n-1: nearest neighbour, then 2-opt."""
        nt = len(cost)
        left = list(range(1, nt - 1))
        order: list[int] = []
        cur = 0
        while left:
            nxt = min(left, key=lambda q: (cost[cur, q], q))
            order.append(nxt)
            left.remove(nxt)
            cur = nxt
        improved = True
        while improved:
            improved = False
            seq = [0, *order, nt - 1]
            for a in range(1, len(seq) - 2):
                for b in range(a + 1, len(seq) - 1):
                    old = cost[seq[a - 1], seq[a]] + cost[seq[b], seq[b + 1]]
                    new = cost[seq[a - 1], seq[b]] + cost[seq[a], seq[b + 1]]
                    if new < old - 1e-6:
                        seq[a : b + 1] = seq[a : b + 1][::-1]
                        improved = True
            order = seq[1:-1]
        return order

    # ---------------------------------------------------------------- 4. bends
    def bends(self) -> None:
        """Bend some long legs sideways; the shortcut they avoid gets an obstacle later."""
        rng = self.rng
        budget = min(self.n_bends, self.imax - len(self.hover))
        self.chords: list[tuple[np.ndarray, np.ndarray]] = []
        for _ in range(budget):
            nodes = [self.start, *self.hover, self.end]
            legs = [k for k in range(len(nodes) - 1) if np.hypot(*(nodes[k + 1] - nodes[k])) > 1000]
            if not legs:
                return
            for _ in range(40):
                k = int(rng.choice(legs))
                a, b = nodes[k], nodes[k + 1]
                d = b - a
                perp = np.array([-d[1], d[0]]) / np.hypot(*d)
                off = rng.uniform(250.0, 500.0) * rng.choice([-1.0, 1.0])
                bend = _r1(a + rng.uniform(0.35, 0.65) * d + off * perp)
                if not self.inside(bend, 100.0):
                    continue
                if self.nfz:
                    lines = shapely.linestrings([[a, bend], [bend, b]])
                    if np.min(self.nfz_distance(lines)) < _NFZ_LEG_CLEARANCE:
                        continue
                self.hover.insert(k, bend)
                self.kinds.insert(k, "bend")
                self.chords.append((a, b))
                break

    # ---------------------------------------------------------------- 5. sensors
    def sensors(self) -> None:
        """Place sensors around hover points (stops first), keeping C3 at every hover point."""
        rng = self.rng
        hover = np.array(self.hover)
        stops = [k for k, kind in enumerate(self.kinds) if kind == "stop"]
        others = [k for k, kind in enumerate(self.kinds) if kind != "stop"]
        slots: list[int] = []
        for tier in (stops, stops, others, stops, others):
            slots.extend(int(k) for k in rng.permutation(tier))
        if len(slots) < self.n_sensors:
            raise _Retry
        placed: list[np.ndarray] = []
        load = np.zeros(len(hover))  # sum of rates at each hover point
        for k in slots[: self.n_sensors]:
            for _ in range(200):
                r = rng.uniform(*_SENSOR_RADIUS)
                ang = rng.uniform(0, 2 * math.pi)
                p = _r1(hover[k] + r * np.array([math.cos(ang), math.sin(ang)]))
                if not self.inside(p, 30.0):
                    continue
                if placed and np.min(np.hypot(*(np.array(placed) - p).T)) < _SENSOR_SPACING:
                    continue
                if self.nfz and self.nfz_distance(shapely.points(p)) < _SENSOR_NFZ_CLEARANCE:
                    continue
                add = self.rates(hover, p[None, :])[:, 0]
                if np.any(load + add > self.bandwidth - _C3_MARGIN):
                    continue
                placed.append(p)
                load += add
                break
            else:
                raise _Retry
        self.sensor_points = np.array(placed)

    # ---------------------------------------------------------------- 6. hover times
    def hover_times(self) -> None:
        """Smallest times that deliver every sensor's data (+ margin): best-point rule, then a
        coordinate pass lowering each time while all sensors still get their data."""
        hover = np.array(self.hover)
        rate = self.rates(hover, self.sensor_points)  # (I, J)
        need = self.required * (1.0 + _DATA_MARGIN)
        best = np.argmax(rate, axis=0)
        t = np.zeros(len(hover))
        for j, i in enumerate(best):
            if rate[i, j] <= 0.0:
                raise _Retry
            t[i] = max(t[i], need / rate[i, j])
        for i in range(len(hover)):
            others = rate.T @ t - rate[i] * t[i]
            heard = rate[i] > 1e-9
            if heard.any():
                t[i] = max(0.0, float(np.max((need - others[heard]) / rate[i, heard])))
            else:
                t[i] = 0.0
        t = np.ceil(t * 100.0 - 1e-6) / 100.0 + 0.0  # + 0.0: no -0.0 in the file
        if np.any(t > self.t_max) or np.any(rate.T @ t < self.required):
            raise _Retry
        self.times = t

    # ---------------------------------------------------------------- 7. circles, rectangles
    def obstacles(self) -> None:
        rng, s = self.rng, self.size
        nodes = np.array([self.start, *self.hover, self.end])
        self.leg_a, self.leg_b = nodes[:-1], nodes[1:]
        self.witness_line = shapely.LineString(nodes)
        shapely.prepare(self.witness_line)
        self.circles: list[tuple[float, float, float]] = []
        self.rects: list[tuple[float, float, float, float, float]] = []
        self.bounds: list[tuple[float, float, float]] = []  # bounding circles of both
        kinds = ["c"] * self.n_circles + ["r"] * self.n_rects
        kinds = [kinds[k] for k in rng.permutation(len(kinds))]
        blocks = list(self.chords)
        axis = self.end - self.start
        ts = self.tour_stops
        shortcuts = [(ts[k], ts[k + 1]) for k in range(len(ts) - 1)]
        p_line = 0.15 + 0.05 * self.density
        p_short = 0.10 + 0.03 * self.density
        p_route = 0.20
        for kind in kinds:
            block = blocks.pop(0) if blocks else None
            for attempt in range(400):
                if block is not None and attempt < 60:
                    a, b = block
                    centre = a + rng.uniform(0.3, 0.7) * (b - a) + rng.normal(0.0, 30.0, size=2)
                else:
                    u = rng.uniform()
                    if attempt >= 300 or u >= p_line + p_short + p_route:
                        centre = rng.uniform(0.0, s, size=2)
                    elif u < p_line:
                        centre = self._near(self.start, axis, 250.0)
                    elif u < p_line + p_short:
                        a, b = shortcuts[int(rng.integers(len(shortcuts)))]
                        centre = self._near(a, b - a, 150.0)
                    else:
                        k = int(rng.integers(len(self.leg_a)))
                        a, b = self.leg_a[k], self.leg_b[k]
                        centre = self._near(a, b - a, 0.0)
                        d = b - a
                        perp = np.array([-d[1], d[0]]) / max(np.hypot(*d), 1e-9)
                        centre = centre + perp * rng.choice([-1.0, 1.0]) * rng.uniform(120, 400)
                if self._try_place(kind, _r1(centre)):
                    break
            else:
                raise _Retry

    def _near(self, a: np.ndarray, d: np.ndarray, sigma: float) -> np.ndarray:
        t = self.rng.uniform(0.05, 0.95)
        n = np.hypot(*d)
        perp = np.array([-d[1], d[0]]) / max(n, 1e-9)
        return a + t * d + self.rng.normal(0.0, sigma) * perp if sigma > 0 else a + t * d

    def _try_place(self, kind: str, c: np.ndarray) -> bool:
        rng = self.rng
        if kind == "c":
            r = float(_r1(rng.uniform(*_CIRCLE_R)))
            bound = r
        else:
            length, width = (float(v) for v in _r1(rng.uniform(*_RECT_SIDE, size=2)))
            angle = float(_r1(rng.uniform(0.0, 180.0)))
            bound = 0.5 * math.hypot(length, width)
        if not self.inside(c):
            return False
        if self.bounds:
            b = np.array(self.bounds)
            if np.any(np.hypot(b[:, 0] - c[0], b[:, 1] - c[1]) < b[:, 2] + bound + _OBSTACLE_GAP):
                return False
        pt = shapely.points(c)
        if self.nfz and any(shapely.contains(p, pt) for p in self.nfz_shapes):
            return False  # hidden inside a no-fly zone: no use
        leg_d = float(np.min(_seg_point_dist(self.leg_a, self.leg_b, c[None, :])))
        sens_d = np.hypot(*(self.sensor_points - c).T)
        if kind == "c":
            if leg_d < r + _LEG_CLEARANCE or np.min(sens_d) < r + _SENSOR_OBSTACLE_CLEARANCE:
                return False
            self.circles.append((float(c[0]), float(c[1]), r))
        else:
            near_sensor = np.min(sens_d) < bound + _SENSOR_OBSTACLE_CLEARANCE
            if leg_d < bound + _LEG_CLEARANCE or near_sensor:  # bounding circle: look closer
                poly = shapely.Polygon(rectangle_vertices(c[0], c[1], length, width, angle))
                if shapely.distance(poly, self.witness_line) < _LEG_CLEARANCE:
                    return False
                if np.min(shapely.distance(poly, shapely.points(self.sensor_points))) < (
                    _SENSOR_OBSTACLE_CLEARANCE
                ):
                    return False
            self.rects.append((float(c[0]), float(c[1]), length, width, angle))
        self.bounds.append((float(c[0]), float(c[1]), bound))
        return True

    # ---------------------------------------------------------------- all of it
    def run(self) -> None:
        self.endpoints()
        self.no_fly_zones()
        self.stops()
        self.route()
        self.bends()
        self.sensors()
        self.hover_times()
        self.obstacles()

    def to_dict(self, name: str, origin: dict[str, float]) -> dict[str, Any]:
        def xy(p: np.ndarray) -> list[float]:
            return [float(p[0]), float(p[1])]

        return {
            "name": name,
            "origin": dict(origin),
            "area": {"width": int(self.size), "height": int(self.size)},
            "start": xy(self.start),
            "end": xy(self.end),
            "sensors": [
                {"id": f"S{j + 1:02d}", "x": float(p[0]), "y": float(p[1])}
                for j, p in enumerate(self.sensor_points)
            ],
            "obstacles": {
                "circles": [{"x": x, "y": y, "radius": r} for x, y, r in self.circles],
                "rectangles": [
                    {"x": x, "y": y, "length": ln, "width": w, "angle_deg": a}
                    for x, y, ln, w, a in self.rects
                ],
                "no_fly_zones": [{"vertices": [xy(v) for v in p]} for p in self.nfz],
            },
            "uav": {"max_hover_points": self.imax},
            # benchmark maps state the paper's model as it is: no safety margins
            "safety": {"clearance": 0, "data_margin": 0},
            "witness": {
                "hover_points": [xy(p) for p in self.hover],
                "hover_times": [float(t) for t in self.times],
            },
        }


def _witness_ok(data: dict[str, Any]) -> bool:
    """Load the map and check its witness: phi == 0, times <= T_max, points in the area."""
    m = load_map(data)
    w = m.spec.witness
    if w is None:
        return False
    hp = np.array(w.hover_points, dtype=float).reshape(-1, 2)
    ht = np.array(w.hover_times, dtype=float)
    if len(hp) > m.max_hover_points or np.any(ht < 0) or np.any(ht > m.spec.uav.max_hover_time):
        return False
    if np.any(hp < 0) or np.any(hp[:, 0] > m.width) or np.any(hp[:, 1] > m.height):
        return False
    problem = Problem(m)
    _, phi = problem.evaluate(problem.encode(hp, ht)[None, :])
    return bool(phi[0] == 0.0)


def generate_map(
    size: int,
    density: int,
    seed: int = SUITE_SEED,
    *,
    name: str | None = None,
    n_sensors: int | None = None,
    origin: dict[str, float] | None = None,
) -> dict[str, Any]:
    """One map with a stored witness (phi == 0), as JSON-ready data; same arguments, same map.

    size: 5000 or 10000 (metres a side); density: 0..7; n_sensors: default grows with size and
    density (`default_sensor_count`). Raises ValueError for bad arguments.
    """
    _check_size_density(size, density)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer (got {seed!r})")
    if n_sensors is None:
        n_sensors = default_sensor_count(size, density)
    if not 1 <= n_sensors <= max_sensor_count(size):
        raise ValueError(
            f"sensors must be 1..{max_sensor_count(size)} on a {size} m map (got {n_sensors})"
        )
    if name is None:
        name = f"gen-{size}-d{density}-s{seed}"
    for attempt in range(_MAX_ATTEMPTS):
        rng = np.random.default_rng([int(seed), size, density, n_sensors, attempt])
        draw = _Draw(rng, size, density, n_sensors)
        try:
            draw.run()
        except _Retry:
            continue
        data = draw.to_dict(name, origin or SUITE_ORIGIN)
        if _witness_ok(data):
            return data
    raise GenerationError(
        f"no feasible map after {_MAX_ATTEMPTS} attempts (size {size}, density {density}, "
        f"seed {seed}, {n_sensors} sensors)"
    )


def suite_maps(seed: int = SUITE_SEED) -> dict[str, dict[str, Any]]:
    """The 16 suite maps by name (T01..T16); each task uses `seed` with its own size/density."""
    return {name: generate_map(size, d, seed, name=name) for name, size, d in suite_tasks()}


def generate_suite(
    folder: str | Path,
    seed: int = SUITE_SEED,
    *,
    write: Callable[[Path, str], object] | None = None,
) -> list[Path]:
    """Write T01.json..T16.json into `folder`; `write(path, text)` defaults to Path.write_text."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, data in suite_maps(seed).items():
        path = folder / f"{name}.json"
        if write is None:
            path.write_text(dumps_map(data))
        else:
            write(path, dumps_map(data))
        paths.append(path)
    return paths


# ----------------------------------------------------------------------------- JSON text

_WIDTH = 100


def dumps_map(data: dict[str, Any]) -> str:
    """Readable, stable JSON: short containers on one line, long number lists wrapped."""
    return _fmt(data, 0, 0) + "\n"


def _fmt(v: Any, indent: int, used: int) -> str:
    compact = json.dumps(v, separators=(", ", ": "))
    if not isinstance(v, dict | list) or not v or used + len(compact) <= _WIDTH:
        return compact
    pad = " " * (indent + 2)
    if isinstance(v, dict):
        items = []
        for k, x in v.items():
            key = json.dumps(k) + ": "
            items.append(pad + key + _fmt(x, indent + 2, indent + 2 + len(key) + 1))
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    if all(not isinstance(x, dict) for x in v) and all(
        len(json.dumps(x, separators=(", ", ": "))) + indent + 4 <= _WIDTH for x in v
    ):  # pack numbers / short lists several to a line
        lines, cur = [], ""
        for x in v:
            t = json.dumps(x, separators=(", ", ": "))
            if cur and len(pad) + len(cur) + 2 + len(t) + 1 > _WIDTH:
                lines.append(cur)
                cur = t
            else:
                cur = f"{cur}, {t}" if cur else t
        lines.append(cur)
        return "[\n" + ",\n".join(pad + ln for ln in lines) + "\n" + " " * indent + "]"
    items = [pad + _fmt(x, indent + 2, indent + 3) for x in v]
    return "[\n" + ",\n".join(items) + "\n" + " " * indent + "]"
