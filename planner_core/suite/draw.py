"""One attempt at one benchmark map: the witness route, sensors, hover times and obstacles.

Every random draw comes from the attempt's generator, in a fixed order; an attempt that draws
something unusable raises `Retry` and the caller starts over with the next sub-seed.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely

from planner_core.model.formulas import ModelParams
from planner_core.model.geometry import rectangle_vertices
from planner_core.model.mapio import Objective, Radio, Uav
from planner_core.model.routing import offset_convex, open_tour, path_hops, shortest_paths
from planner_core.suite.tables import BENDS, SIZES, obstacle_counts

__all__ = ["Draw", "Retry"]

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


class Retry(Exception):
    """This attempt drew something unusable; start over with the next sub-seed."""


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


# ----------------------------------------------------------------------------- the generator


class Draw:
    """One attempt at one map: every random draw comes from `rng`, in a fixed order."""

    def __init__(self, rng: np.random.Generator, size: int, density: int, n_sensors: int):
        self.rng = rng
        self.size = float(size)
        self.density = density
        self.imax = SIZES[size]
        self.n_sensors = n_sensors
        self.n_circles, self.n_rects, self.n_nfz = obstacle_counts(size, density)
        self.n_bends = BENDS[size][density]
        radio = Radio()
        #: the model's parameters with the schema's default settings (no sensors yet)
        self.model = ModelParams.from_settings(
            Uav(), radio, Objective(), width=self.size, height=self.size, n_points=self.imax
        )
        self.t_max = self.model.t_max
        self.bandwidth = self.model.bandwidth
        self.required = radio.required_data

    # ---------------------------------------------------------------- helpers
    def inside(self, p: np.ndarray, margin: float = 0.0) -> bool:
        """Whether points lie in the square area, at least `margin` from its sides.

        Args:
            p: a point (2,) or points (n, 2), local metres.
            margin: the distance (m) kept from every side.

        Returns:
            True when every coordinate is within margin .. size - margin.
        """
        return bool(np.all(p >= margin) and np.all(p <= self.size - margin))

    def convex_nfz(self, centre: np.ndarray) -> np.ndarray | None:
        """Draw one convex no-fly zone around `centre` (the paper's Sec. 3.2 shape).

        Draws, in this order, from `rng`: the vertex count (`_NFZ_VERTICES`), the angular gaps
        between the vertices, their starting angle, a squash of the x axis (0.6..1), a rotation
        and the diameter (`_NFZ_DIAMETER`); the maps' bytes depend on this order.

        Args:
            centre: (2,) the zone's centre, local metres.

        Returns:
            (n, 2) vertices rounded to 0.1 m, counter-clockwise, or None when the zone leaves
            the area or is not strictly convex after rounding (the draws are spent either way).
        """
        rng = self.rng
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
            return None
        e = np.roll(pts, -1, axis=0) - pts
        e2 = np.roll(e, -1, axis=0)
        if np.any(e[:, 0] * e2[:, 1] - e[:, 1] * e2[:, 0] <= 1.0):
            return None  # keep it strictly convex and counter-clockwise after rounding
        return pts

    def rates(self, hover: np.ndarray, sensors: np.ndarray) -> np.ndarray:
        """R (I, J), the model's rate formula.

        Args:
            hover: hover points (m), (I, 2).
            sensors: sensor positions (m), (J, 2).

        Returns:
            R (Mbit/s, >= 0), (I, J) (`ModelParams.rates`, paper Sec. 3.1).
        """
        return self.model.rates(hover, sensors)

    def nfz_distance(self, geoms: Any) -> np.ndarray:
        """Distance of shapely geometries to the nearest no-fly zone (inf when there is none).

        Args:
            geoms: a shapely geometry or an array of them, local metres.

        Returns:
            Distances (m), `geoms`'s shape.
        """
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
                pts = self.convex_nfz(centre)
                if pts is None:
                    continue
                if np.min(shapely.distance(ends, shapely.Polygon(pts))) < _NFZ_ENDPOINT_CLEARANCE:
                    continue
                self.nfz.append(pts)
                break
            else:
                raise Retry
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
                raise Retry
        self.stop_points = np.array(stops)

    def route(self) -> None:
        """Order the stops into a tour and route it around the no-fly zones (visibility graph)."""
        targets = np.vstack([self.start, self.stop_points, self.end])
        corners = [_r1(offset_convex(p, _NFZ_CORNER_OFFSET)) for p in self.nfz]
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
        w, nxt = shortest_paths(w)
        cost = w[:nt, :nt]
        if not np.all(np.isfinite(cost)):
            raise Retry
        seq = open_tour(np.ascontiguousarray(cost), True).tolist()
        hover: list[np.ndarray] = []
        kinds: list[str] = []
        for a, b in zip(seq[:-1], seq[1:], strict=True):
            for u in path_hops(nxt, a, b):
                hover.append(nodes[u])
                kinds.append("corner")
            if b != nt - 1:
                hover.append(nodes[b])
                kinds.append("stop")
        if len(hover) > self.imax:
            raise Retry
        self.hover = [np.array(h) for h in hover]
        self.kinds = kinds
        self.tour_stops = targets[seq]  # start, stops in tour order, end

    # ---------------------------------------------------------------- 4. bends
    def bend_allowed(self, bend: np.ndarray) -> bool:
        """Whether a bend point may be placed (inside the area is checked apart): always
        on the paper's maps; a layout that keeps zones free of hover points overrides it.

        Args:
            bend: the bend point (2,), local metres.

        Returns:
            True (this class).
        """
        return True

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
                if not self.inside(bend, 100.0) or not self.bend_allowed(bend):
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
            raise Retry
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
                raise Retry
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
                raise Retry
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
            raise Retry
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
                raise Retry

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
        """The drawn map as JSON-ready map data, its witness plan included.

        Args:
            name: the map's name.
            origin: the map's geographic origin (copied).

        Returns:
            The map data: area, start, end, sensors S01.., circles, rectangles, no-fly zones,
            I_max, safety clearance and data margin 0 (the paper's model), and the witness's
            hover points and times.
        """
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
