"""Large deployments: maps of up to 30 km a side and 1,000 sensors (as many as the size, layout
and density fit), each with a stored witness plan.

The paper's generator (`planner_core.suite`) stops at 10 km and 40 sensors. This one keeps its
rules and scales them: the witness is drawn first (stops, a tour routed around the no-fly zones,
bent legs), sensors are then placed where every hover point of the witness keeps C3 (the summed
link rate <= R_lambda - 0.5 Mbit/s) and where some hover point hears them at >= 1 Mbit/s (so a
hover time <= T_max delivers their data), hover times follow the paper generator's rule, and
circles, rectangles and no-fly zones follow the paper's placement rules with counts scaled from
its 10 km table by the area. The witness is checked with `Problem` (phi == 0) before a map is
returned. Same arguments, same bytes.

Layouts (where the sensors are):

- ``uniform``: drawn uniformly over the area, at least `UNIFORM_SPACING` m apart, kept where a
  stop of the witness (stops spread over the whole area) hears them;
- ``clustered``: fields of `CLUSTER_SIZE` sensors (an argument) within `FIELD_RADIUS` m of the
  field's centre; a hover point inside a field would hear all of them at once and break C3, so
  the witness serves each field from points on a ring `RING_RADIUS` m around it (the field's
  edge), several per field;
- ``corridor``: along a pipeline or road, a polyline crossing the area from one edge to the
  opposite one, within `CORRIDOR_BAND` m of it; the witness flies beside the corridor, its stops
  `CORRIDOR_OFFSET` m off the line on both sides (over the line C3 would fail the same way).

I_max is `large_max_hover_points(n_sensors)`: two sensors per hover point, at least the paper's
20 and at most the map file's 200.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator
from typing import Any

import numpy as np
import shapely

from planner_core import textio
from planner_core.model.formulas import ModelParams
from planner_core.model.mapio import Objective, Radio, Uav
from planner_core.suite.draw import (
    _C3_MARGIN,
    _NFZ_ENDPOINT_CLEARANCE,
    _SENSOR_NFZ_CLEARANCE,
    Draw,
    Retry,
    _r1,
)
from planner_core.suite.tables import _CIRCLES, _NFZS, _RECTANGLES, BENDS, N_DENSITIES, SUITE_SEED

__all__ = [
    "LAYOUTS",
    "MIN_SIZE",
    "MAX_SIZE",
    "MAX_SENSORS",
    "max_sensors",
    "CLUSTER_SIZE",
    "UNIFORM_SPACING",
    "FIELD_RADIUS",
    "RING_RADIUS",
    "CORRIDOR_BAND",
    "CORRIDOR_OFFSET",
    "REACH_RATE",
    "large_max_hover_points",
    "large_obstacle_counts",
    "generate_large_map",
    "witness_score",
    "LARGE_SUITE",
    "large_suite_maps",
]

#: where the sensors lie (see the module's text)
LAYOUTS = ("uniform", "clustered", "corridor")
#: smallest and largest map side, metres
MIN_SIZE = 5000
MAX_SIZE = 30000
#: the most sensors one large map may ask for by default: the limit check and plan read
#: (`textio.LIMITS["sensors"]`); LAMDE_MAX_SENSORS raises or lowers it (`max_sensors`). How many
#: fit depends on the size, layout and density (`generate_large_map` raises GenerationError
#: naming why when they do not: e.g. 1,000 at 30 km did not fit the uniform layout at density 7
#: nor the corridor at density 0 or 7)
MAX_SENSORS = textio.LIMITS["sensors"].default
#: sensors per field in the clustered layout (the default of `cluster_size`)
CLUSTER_SIZE = 12
#: metres: the least distance between two sensors, per layout
UNIFORM_SPACING = 500.0
FIELD_SPACING = 60.0
CORRIDOR_SPACING = 50.0
#: metres: a field's sensors lie within this distance of its centre
FIELD_RADIUS = 250.0
#: metres (low, high): the witness's points around a field lie this far from its centre
RING_RADIUS = (820.0, 880.0)
#: metres: corridor sensors lie within this distance of the corridor's polyline
CORRIDOR_BAND = 120.0
#: metres (low, high): the witness's stops beside a corridor lie this far from its polyline
CORRIDOR_OFFSET = (720.0, 800.0)
#: Mbit/s: every sensor is heard at least this fast by some witness hover point
REACH_RATE = 1.0

_LAYOUT_CODE = {name: k + 1 for k, name in enumerate(LAYOUTS)}
_MAX_ATTEMPTS = 12
_BATCH = 128  # candidate positions drawn at once for a stop or a sensor
_BATCHES = 24  # batches tried before a sensor counts as impossible to place
_NFZ_GAP = 800.0  # metres kept between two no-fly zones (routes and stops fit between)
_STOP_NFZ_CLEARANCE = 550.0  # a uniform stop to any no-fly zone (its sensors lie within ~900 m)
_RING_NFZ_CLEARANCE = 150.0  # a field's whole ring (centre + ring radius) to any no-fly zone
_CORRIDOR_NFZ_CLEARANCE = 950.0  # the corridor's polyline to any no-fly zone
_EDGE = 150.0  # metres: witness stops stay this far inside the area


def max_sensors() -> int:
    """The most sensors a large map may have: the limit `check` and `plan` read, so that every
    generated map is one they accept (not a limit of the generator, whose layouts fit fewer at
    some sizes and densities: GenerationError says so).

    Returns:
        LAMDE_MAX_SENSORS when set, else `MAX_SENSORS` (`textio.limit("sensors")`).

    Raises:
        textio.InputError: LAMDE_MAX_SENSORS is set to anything but a positive integer (its
            `where` names the variable).
    """
    return textio.limit("sensors")


def large_max_hover_points(n_sensors: int) -> int:
    """I_max of a large map: two sensors per hover point, within [20, 200].

    Args:
        n_sensors: the map's sensor count.

    Returns:
        max(20, min(200, ceil(n_sensors / 2))).
    """
    return max(20, min(200, math.ceil(n_sensors / 2)))


def _stop_budget(size: int, density: int, n_sensors: int) -> tuple[int, int, int, int]:
    """How I_max is shared on a large map: (the witness's stops, the hover points kept for the
    route's corners round the no-fly zones, those kept for bent legs, I_max); the stops get
    what the other two leave, at least 1."""
    imax = large_max_hover_points(n_sensors)
    _, _, n_nfz, bends = large_obstacle_counts(size, density)
    corners, bent = min(2 * n_nfz, imax // 4), min(bends, imax // 10)
    return max(1, imax - corners - bent), corners, bent, imax


def _ring_points_fit(size: int, density: int, n_sensors: int, cluster_size: int) -> bool:
    """Whether the clustered layout's fields get 2 hover points each on their rings (the
    witness's stops, `_stop_budget`)."""
    return 2 * math.ceil(n_sensors / cluster_size) <= _stop_budget(size, density, n_sensors)[0]


def _roomier(fixes: list[str], size: int, density: int) -> list[str]:
    """`fixes` and, where they are possible, a larger size (below `MAX_SIZE`) and a lower
    density (above 0): never a change the generator refuses."""
    return (fixes + (["a larger size"] if size < MAX_SIZE else [])
            + (["a lower density"] if density > 0 else []))  # fmt: skip


def _either(fixes: list[str]) -> str:
    """'a, b or c' (`fixes`, at least one)."""
    return (", ".join(fixes[:-1]) + " or " if len(fixes) > 1 else "") + fixes[-1]


def _ring_shortfall(size: int, density: int, n_sensors: int, cluster_size: int) -> str:
    """The clustered layout's fields need more ring points than I_max leaves them: what is short
    (numbers from `_stop_budget`) and the changes that give each field its 2 (the most sensors
    that do, the least cluster size that does, the densest density that does)."""
    budget, corners, bent, imax = _stop_budget(size, density, n_sensors)
    n_fields = math.ceil(n_sensors / cluster_size)
    # one field always fits: I_max >= 20 keeps at most 5 + 2 of them for corners and bends
    fewer = next(n for n in range(n_sensors - 1, 0, -1)
                 if _ring_points_fit(size, density, n, cluster_size))  # fmt: skip
    fixes = [f"at most {fewer} sensors"]
    larger = [k for k in range(cluster_size + 1, 51)
              if _ring_points_fit(size, density, n_sensors, k)]  # fmt: skip
    if larger:
        fixes.append(f"a cluster size of at least {larger[0]} (fewer fields)")
    lower = [d for d in range(density - 1, -1, -1)
             if _ring_points_fit(size, d, n_sensors, cluster_size)]  # fmt: skip
    if lower:
        fixes.append(f"a density of at most {lower[0]} (fewer no-fly zones and bends)")
    return (f"{n_fields} fields of {cluster_size} sensors need {2 * n_fields} hover points (2 on "
            f"each field's ring), but only {budget} of the map's I_max = {imax} are left for "
            f"them ({corners} are kept for the route's corners round the no-fly zones, {bent} "
            f"for bent legs); each field gets its 2 with {_either(fixes)}")


def large_obstacle_counts(size: int, density: int) -> tuple[int, int, int, int]:
    """(circles, rectangles, no-fly zones, bent legs): the paper's 10 km counts scaled by area.

    Args:
        size: map side, metres.
        density: 0 (sparse) .. 7 (dense), the paper's density index.

    Returns:
        The counts at this size: each 10 km count times (size / 10000)^2, rounded.

    Raises:
        ValueError: density outside 0..7.
    """
    if not 0 <= density < N_DENSITIES:
        raise ValueError(f"density must be 0..{N_DENSITIES - 1} (got {density})")
    scale = (size / 10000.0) ** 2
    return tuple(  # type: ignore[return-value]
        int(round(t[10000][density] * scale)) for t in (_CIRCLES, _RECTANGLES, _NFZS, BENDS)
    )


@contextlib.contextmanager
def _sensor_limit(n: int) -> Iterator[None]:
    """Let `load_map` read a map of n sensors while its witness is checked (LAMDE_MAX_SENSORS is
    raised to n for the check when it is lower, and restored after)."""
    from planner_core import textio

    old = os.environ.get("LAMDE_MAX_SENSORS")
    try:
        raise_it = textio.limit("sensors") < n
    except textio.InputError:
        raise_it = True
    if raise_it:
        os.environ["LAMDE_MAX_SENSORS"] = str(n)
    try:
        yield
    finally:
        if raise_it:
            if old is None:
                os.environ.pop("LAMDE_MAX_SENSORS", None)
            else:
                os.environ["LAMDE_MAX_SENSORS"] = old


def _polyline_point(pts: np.ndarray, cum: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, ...]:
    """Points at arc lengths s along a polyline (vertices pts, cumulative lengths cum) and the
    unit normals (left of the direction of travel) of their segments."""
    k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(pts) - 2)
    d = pts[k + 1] - pts[k]
    n = np.hypot(d[:, 0], d[:, 1])
    u = d / n[:, None]
    p = pts[k] + u * (s - cum[k])[:, None]
    return p, np.stack([-u[:, 1], u[:, 0]], axis=1)


class LargeDraw(Draw):
    """One attempt at one large map; every random draw comes from `rng`, in a fixed order."""

    def __init__(
        self,
        rng: np.random.Generator,
        size: int,
        density: int,
        n_sensors: int,
        layout: str,
        cluster_size: int = CLUSTER_SIZE,
    ):
        self.layout = layout
        self.cluster_size = cluster_size
        self._imax = large_max_hover_points(n_sensors)
        super().__init__(rng, 10000, density, n_sensors)  # the model's settings; sizes below
        self.size = float(size)
        self.size_m = int(size)
        self.imax = self._imax
        self.n_circles, self.n_rects, self.n_nfz, _ = large_obstacle_counts(size, density)
        self.n_bends = _stop_budget(size, density, n_sensors)[2]
        self.model = ModelParams.from_settings(
            Uav(), Radio(), Objective(), width=self.size, height=self.size, n_points=self.imax
        )
        self.placed_best = 0

    # ---------------------------------------------------------------- helpers
    def _clear(self, pts: np.ndarray, clearance: float) -> np.ndarray:
        """Which points (P, 2) lie at least `clearance` m from every no-fly zone."""
        if not self.nfz:
            return np.ones(len(pts), dtype=bool)
        return self.nfz_distance(shapely.points(pts)) >= clearance

    def _inside(self, pts: np.ndarray, margin: float) -> np.ndarray:
        return np.all((pts >= margin) & (pts <= self.size - margin), axis=1)

    # ---------------------------------------------------------------- 2. corridor, no-fly zones
    def corridor(self) -> None:
        """The corridor's polyline (corridor layout only): edge to opposite edge, bending at
        interior vertices spread along the crossing axis."""
        rng, s = self.rng, self.size
        if self.layout != "corridor":
            self.line = None
            return
        n_v = max(2, round(s / 6000.0))
        x = np.linspace(0.0, s, n_v + 2)
        y = rng.uniform(0.1 * s, 0.9 * s, size=n_v + 2)
        pts = np.stack([x, y], axis=1)
        if rng.uniform() < 0.5:
            pts = pts[:, ::-1]  # south -> north instead of west -> east
        self.line = _r1(pts)
        seg = np.hypot(*np.diff(self.line, axis=0).T)
        self.line_cum = np.concatenate([[0.0], np.cumsum(seg)])
        self.line_shape = shapely.LineString(self.line)

    def no_fly_zones(self) -> None:
        """The paper's convex no-fly zones (3..7 vertices, 3-4 km across, clear of start and end),
        the 10 km count along the start -> end axis as the paper places them and the rest anywhere;
        kept `_NFZ_GAP` m apart (and off the corridor). When a zone finds no place in 300
        draws the area is full and the map has fewer zones than the scaled count."""
        rng, s = self.rng, self.size
        axis = self.end - self.start
        perp = np.array([-axis[1], axis[0]]) / np.hypot(*axis)
        ends = shapely.points([self.start, self.end])
        n_axis = min(self.n_nfz, _NFZS[10000][self.density])
        self.nfz: list[np.ndarray] = []
        self.nfz_shapes = []
        for k in range(self.n_nfz):
            for _ in range(300):
                if k < n_axis:
                    t = 0.2 + 0.6 * (k + rng.uniform(0.15, 0.85)) / n_axis
                    centre = self.start + t * axis + rng.normal(0.0, 0.12 * s) * perp
                else:
                    centre = rng.uniform(0.1 * s, 0.9 * s, size=2)
                pts = self.convex_nfz(centre)
                if pts is None:
                    continue
                poly = shapely.Polygon(pts)
                if np.min(shapely.distance(ends, poly)) < _NFZ_ENDPOINT_CLEARANCE:
                    continue
                if self.nfz_shapes and np.min(shapely.distance(self.nfz_shapes, poly)) < _NFZ_GAP:
                    continue
                if self.line is not None and (
                    shapely.distance(self.line_shape, poly) < _CORRIDOR_NFZ_CLEARANCE
                ):
                    continue
                shapely.prepare(poly)
                self.nfz.append(pts)
                self.nfz_shapes.append(poly)
                break
            else:
                return  # the area is full: as many zones as fit

    # ---------------------------------------------------------------- 3. stops
    def stops(self) -> None:
        """The witness's stops, by layout (uniform: spread over the area; clustered: rings
        around the fields; corridor: both sides of the polyline)."""
        budget = _stop_budget(self.size_m, self.density, self.n_sensors)[0]
        if self.layout == "uniform":
            self.stop_points = self._uniform_stops(budget)
        elif self.layout == "clustered":
            self.stop_points = self._field_stops(budget)
        else:
            self.stop_points = self._corridor_stops(budget)

    def _uniform_stops(self, k: int) -> np.ndarray:
        rng, s = self.rng, self.size
        min_sep = 0.6 * s / math.sqrt(k)
        stops = np.zeros((0, 2))
        ends = np.array([self.start, self.end])
        for _ in range(k):
            for _ in range(20):
                p = _r1(rng.uniform(400.0, s - 400.0, size=(_BATCH, 2)))
                ok = np.min(np.hypot(*(p[:, None, :] - ends[None]).transpose(2, 0, 1)), 1) >= 300
                if len(stops):
                    d = np.hypot(*(p[:, None, :] - stops[None]).transpose(2, 0, 1))
                    ok &= np.min(d, axis=1) >= min_sep
                idx = np.flatnonzero(ok)
                if len(idx):
                    idx = idx[self._clear(p[idx], _STOP_NFZ_CLEARANCE)]
                if len(idx):
                    stops = np.vstack([stops, p[idx[0]]])
                    break
            else:
                break  # the area is full: fewer stops
        if len(stops) < max(1, k // 2):
            raise Retry
        return stops

    def _field_stops(self, budget: int) -> np.ndarray:
        rng, s = self.rng, self.size
        n_fields = math.ceil(self.n_sensors / self.cluster_size)
        per = max(2, math.ceil(self.cluster_size / 3))
        per = min(per, budget // n_fields)
        if per < 2:
            raise _Impossible(_ring_shortfall(self.size_m, self.density, self.n_sensors,
                                              self.cluster_size))  # fmt: skip
        reach = RING_RADIUS[1]
        min_sep = 2.0 * reach + 300.0
        ends = np.array([self.start, self.end])
        centres = np.zeros((0, 2))
        for _ in range(n_fields):
            for _ in range(30):
                c = _r1(rng.uniform(reach + _EDGE, s - reach - _EDGE, size=(_BATCH, 2)))
                ok = np.min(np.hypot(*(c[:, None, :] - ends[None]).transpose(2, 0, 1)), 1) >= (
                    FIELD_RADIUS + 300.0
                )
                if len(centres):
                    d = np.hypot(*(c[:, None, :] - centres[None]).transpose(2, 0, 1))
                    ok &= np.min(d, axis=1) >= min_sep
                idx = np.flatnonzero(ok)
                if len(idx):
                    idx = idx[self._clear(c[idx], reach + _RING_NFZ_CLEARANCE)]
                if len(idx):
                    centres = np.vstack([centres, c[idx[0]]])
                    break
            else:
                fixes = ["fewer sensors"] + (["a larger cluster size (fewer fields)"]
                                             if self.cluster_size < 50 else [])
                raise _Impossible(
                    f"only {len(centres)} of {n_fields} fields fit on a {self.size:g} m map "
                    f"(each needs a clear disc of {reach + _RING_NFZ_CLEARANCE:g} m radius, "
                    f"{min_sep:g} m between centres); "
                    + "use " + _either(_roomier(fixes, self.size_m, self.density))
                )
        self.field_centres = centres
        stops = []
        for c in centres:
            rot = rng.uniform(0.0, 2.0 * math.pi)
            ang = rot + 2.0 * math.pi * np.arange(per) / per
            rho = rng.uniform(*RING_RADIUS, size=per)
            stops.append(_r1(c + rho[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)))
        return np.vstack(stops)

    def _corridor_stops(self, budget: int) -> np.ndarray:
        rng = self.rng
        length = float(self.line_cum[-1])
        k = min(budget, math.ceil(2.0 * length / 800.0))
        pos = (np.arange(k) + 0.5 + rng.uniform(-0.2, 0.2, size=k)) * (length / k)
        side = np.where((np.arange(k) + int(rng.integers(0, 2))) % 2 == 0, 1.0, -1.0)
        off = rng.uniform(*CORRIDOR_OFFSET, size=k)
        p, normal = _polyline_point(self.line, self.line_cum, pos)
        cand = _r1(p + (side * off)[:, None] * normal)
        alt = _r1(p - (side * off)[:, None] * normal)
        ok = self._inside(cand, _EDGE) & self._clear(cand, _STOP_NFZ_CLEARANCE)
        ok_alt = self._inside(alt, _EDGE) & self._clear(alt, _STOP_NFZ_CLEARANCE)
        cand = np.where((~ok & ok_alt)[:, None], alt, cand)
        keep = ok | ok_alt
        # a stop off one bend of the polyline may lie over another part of it: C3 would fail
        near = shapely.distance(shapely.points(cand), self.line_shape) >= CORRIDOR_OFFSET[0] - 50
        stops = cand[keep & near]
        if len(stops) < max(1, k // 2):
            raise Retry
        return stops

    # ---------------------------------------------------------------- 4. bends
    def _off_sensor_zone(self, p: np.ndarray) -> bool:
        """Whether a bend at p stays out of where the layout puts sensors (a hover point inside
        a field or over the corridor would break C3 there)."""
        if self.layout == "clustered":
            d = np.hypot(*(self.field_centres - p).T)
            return bool(np.min(d) >= RING_RADIUS[0] - 50.0)
        if self.layout == "corridor":
            return bool(shapely.distance(shapely.points(p), self.line_shape)
                        >= CORRIDOR_OFFSET[0] - 50.0)  # fmt: skip
        return True

    def bend_allowed(self, bend: np.ndarray) -> bool:
        """The paper's bends (`Draw.bends`), none inside a field or over the corridor.

        Args:
            bend: the bend point (2,), local metres.

        Returns:
            Whether it stays out of the layout's sensor zones (always True for "uniform").
        """
        return self._off_sensor_zone(bend)

    # ---------------------------------------------------------------- 5. sensors
    def _propose(self) -> np.ndarray:
        """A batch of candidate sensor positions for the layout (field chosen round-robin)."""
        rng, s = self.rng, self.size
        if self.layout == "uniform":
            return _r1(rng.uniform(30.0, s - 30.0, size=(_BATCH, 2)))
        if self.layout == "clustered":
            c = self.field_centres[self._field % len(self.field_centres)]
            r = FIELD_RADIUS * np.sqrt(rng.uniform(size=_BATCH))
            a = rng.uniform(0.0, 2.0 * math.pi, size=_BATCH)
            return _r1(c + r[:, None] * np.stack([np.cos(a), np.sin(a)], axis=1))
        pos = rng.uniform(0.0, float(self.line_cum[-1]), size=_BATCH)
        p, normal = _polyline_point(self.line, self.line_cum, pos)
        return _r1(p + rng.uniform(-CORRIDOR_BAND, CORRIDOR_BAND, size=_BATCH)[:, None] * normal)

    def sensors(self) -> None:
        """Place sensors by the layout, each where every hover point keeps C3 (with a margin)
        and some hover point hears it at >= `REACH_RATE`; candidates are tried in batches."""
        hover = np.array(self.hover)
        spacing = {"uniform": UNIFORM_SPACING, "clustered": FIELD_SPACING,
                   "corridor": CORRIDOR_SPACING}[self.layout]  # fmt: skip
        limit = self.bandwidth - _C3_MARGIN
        placed = np.zeros((0, 2))
        load = np.zeros(len(hover))
        self._field = 0
        for j in range(self.n_sensors):
            self._field = j
            for _ in range(_BATCHES):
                p = self._propose()
                ok = self._inside(p, 30.0)
                if len(placed):
                    d = np.hypot(*(p[:, None, :] - placed[None]).transpose(2, 0, 1))
                    ok &= np.min(d, axis=1) >= spacing
                idx = np.flatnonzero(ok)
                if not len(idx):
                    continue
                rate = self.rates(hover, p[idx])  # (I, B)
                good = (rate.max(axis=0) >= REACH_RATE) & np.all(
                    load[:, None] + rate <= limit, axis=0
                )
                idx, rate = idx[good], rate[:, good]
                if len(idx):
                    clear = self._clear(p[idx], _SENSOR_NFZ_CLEARANCE)
                    idx, rate = idx[clear], rate[:, clear]
                if len(idx):
                    placed = np.vstack([placed, p[idx[0]]])
                    load += rate[:, 0]
                    break
            else:
                self.placed_best = max(self.placed_best, j)
                raise Retry
        self.placed_best = self.n_sensors
        self.sensor_points = placed

    # ---------------------------------------------------------------- all of it
    def run(self) -> None:
        for stage in ("endpoints", "corridor", "no_fly_zones", "stops", "route", "bends",
                      "sensors", "hover_times", "obstacles"):  # fmt: skip
            self.stage = stage
            getattr(self, stage)()


class _Impossible(Exception):
    """These parameters leave no C3-feasible witness (not a matter of the draw); the message
    ends with what to change."""


def _check_args(size: Any, n_sensors: Any, layout: Any, density: Any, cluster_size: Any) -> None:
    def is_int(v: Any) -> bool:
        return not isinstance(v, bool) and isinstance(v, int | np.integer)

    if not is_int(size) or not MIN_SIZE <= size <= MAX_SIZE:
        raise ValueError(f"size must be an integer {MIN_SIZE}..{MAX_SIZE} m (got {size!r})")
    most = max_sensors()
    if not is_int(n_sensors) or not 1 <= n_sensors <= most:
        raise ValueError(f"sensors must be 1..{most} (got {n_sensors!r}; check and plan read at "
                         "most LAMDE_MAX_SENSORS sensors)")
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)} (got {layout!r})")
    if not is_int(density) or not 0 <= density < N_DENSITIES:
        raise ValueError(f"density must be 0..{N_DENSITIES - 1} (got {density!r})")
    if not is_int(cluster_size) or not 1 <= cluster_size <= 50:
        raise ValueError(f"cluster size must be 1..50 (got {cluster_size!r})")


def generate_large_map(
    size: int,
    n_sensors: int,
    layout: str,
    density: int = 0,
    seed: int = SUITE_SEED,
    *,
    cluster_size: int = CLUSTER_SIZE,
    name: str | None = None,
    origin: dict[str, float] | None = None,
) -> dict[str, Any]:
    """One large map with a stored witness plan (phi == 0), as JSON-ready data.

    Args:
        size: map side, metres (`MIN_SIZE`..`MAX_SIZE`).
        n_sensors: sensors, 1..`max_sensors()` (LAMDE_MAX_SENSORS, what check and plan read).
        layout: one of `LAYOUTS`.
        density: obstacle density 0 (sparse) .. 7 (dense); counts from the paper's 10 km table
            scaled by the area (`large_obstacle_counts`).
        seed: random seed, >= 0; same arguments, same map (and the same bytes via `dumps_map`).
        cluster_size: sensors per field (clustered layout; ignored by the others).
        name: the map's name (default ``large-<layout>-<size>-n<sensors>-d<density>-s<seed>``).
        origin: WGS84 origin {lat, lon, alt} (default `SUITE_ORIGIN`).

    Returns:
        The map as a dict (the map file's schema), its witness included; I_max is
        `large_max_hover_points(n_sensors)`.

    Raises:
        ValueError: a bad argument (the message names it); LAMDE_MAX_SENSORS set to anything
            but a positive integer (`textio.InputError`).
        GenerationError: no map passed every check; the message says why and what to change.
    """
    from planner_core.suite import SUITE_ORIGIN, GenerationError, _witness_ok

    _check_args(size, n_sensors, layout, density, cluster_size)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer (got {seed!r})")
    if name is None:
        name = f"large-{layout}-{size}-n{n_sensors}-d{density}-s{seed}"
    key = [int(seed), int(size), int(density), int(n_sensors), _LAYOUT_CODE[layout],
           int(cluster_size)]  # fmt: skip
    best = 0
    failed: dict[str, int] = {}
    for attempt in range(_MAX_ATTEMPTS):
        draw = LargeDraw(np.random.default_rng([*key, attempt]), size, density, n_sensors,
                         layout, cluster_size)  # fmt: skip
        try:
            draw.run()
        except _Impossible as exc:
            raise GenerationError(f"{layout} layout: {exc}") from None
        except Retry:
            best = max(best, draw.placed_best)
            failed[draw.stage] = failed.get(draw.stage, 0) + 1
            continue
        data = draw.to_dict(name, origin or SUITE_ORIGIN)
        with _sensor_limit(n_sensors):
            if _witness_ok(data):
                return data
        failed["witness check"] = failed.get("witness check", 0) + 1
    why = ", ".join(f"{stage} {k}x" for stage, k in failed.items())
    raise GenerationError(
        f"no C3-feasible {layout} map after {_MAX_ATTEMPTS} attempts (size {size} m, density "
        f"{density}, seed {seed}, {n_sensors} sensors; failed at: {why}; at most {best} sensors "
        "could be placed where a witness hover point hears them and keeps C3); "
        + "use " + _either(_roomier(["fewer sensors"], size, density))
    )


def witness_score(data: dict[str, Any]) -> tuple[float, float]:
    """(f, phi) of a map's stored witness plan, evaluated with `Problem` (any sensor count).

    Args:
        data: a map (the map file's dict) with a `witness`.

    Returns:
        f (the paper's objective, seconds) and phi (0.0 when feasible).

    Raises:
        KeyError: the map has no witness.
    """
    from planner_core.model.problem import Problem

    w = data["witness"]
    with _sensor_limit(len(data["sensors"])):
        problem = Problem(data)
    hp = np.asarray(w["hover_points"], dtype=float).reshape(-1, 2)
    ht = np.asarray(w["hover_times"], dtype=float)
    f, phi = problem.evaluate(problem.encode(hp, ht)[None, :])
    return float(f[0]), float(phi[0])


# ----------------------------------------------------------------------------- the large suite

#: the committed large suite (examples/maps/large/): name -> (size m, sensors, layout, density)
LARGE_SUITE: dict[str, tuple[int, int, str, int]] = {
    "L01": (14000, 80, "uniform", 0),
    "L02": (20000, 160, "uniform", 7),
    "L03": (30000, 400, "uniform", 0),
    "L04": (10000, 80, "clustered", 0),
    "L05": (20000, 240, "clustered", 7),
    "L06": (30000, 400, "clustered", 7),
    "L07": (20000, 120, "corridor", 0),
    "L08": (30000, 300, "corridor", 7),
}


def large_suite_maps(seed: int = SUITE_SEED) -> dict[str, dict[str, Any]]:
    """The large suite's maps by name (L01..L08, `LARGE_SUITE`), each from `seed`.

    Args:
        seed: random seed, >= 0.

    Returns:
        Name -> map data, in name order.
    """
    return {
        name: generate_large_map(size, n, layout, density, seed, name=name)
        for name, (size, n, layout, density) in LARGE_SUITE.items()
    }
