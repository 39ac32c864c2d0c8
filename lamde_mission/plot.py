"""A picture of a map and (optionally) a mission flown on it, saved as PNG or SVG.

Draws the area, circles, rotated rectangles, polygon footprints (courtyards left open), no-fly
zones (holes open), sensors labelled by id and coloured by the share of their required data
collected (short ones ringed with "x of y Mbit", unreached ones crossed), the path with arrows
and numbered hover points ("order · seconds"), the parts of legs inside obstacles in red, start
and end, each distinct leg, hover point and corner drawn once however often a DO_JUMP loop flies
it (a hover point flown k times labelled "order · seconds ×k"; `_visits`), a legend below the
map and a scale bar in the corner where it covers the fewest markers; every label placed where
it covers no other label (`_place_labels`, sensor ids left out where crowded and counted in the
legend; a depot's name never on the side of a depot beside it); with a replay, a panel of
each sensor's data over the mission time against its requirement (the ten tightest named, in
distinct colours, their end labels spread apart: `_spread_end_labels`; a mission that gives no
sensor data says why) and, beyond ten sensors, a panel of sorted bars naming every sensor (up
to `BARS`; the rest summarised). A mission thousands of km from the map's area (the wrong map,
another origin) is not drawn: the view stays on the map and the title says how far it is.
Uses matplotlib's Agg canvas directly (no pyplot state), imported inside the functions so
importing this module stays cheap. Drawn to be cheap on 400-sensor maps: obstacles, leader
lines, direction arrows and the grey data lines are collections (not an artist each), each data
line runs through its bends only (`_bends`), every label is measured and drawn once, the layout
is done once unless the legend's note needs a new row, and a save draws the figure once.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from lamde_mission.atomic import write_bytes_atomic
from planner_core.textio import counted, first_few

__all__ = ["mission_figure", "save_figure", "figure_bytes", "plot_mission", "IMAGE_SUFFIXES",
           "MAX_DPI",
           "check_dpi", "nice_length", "SortieView", "fleet_figure", "plot_fleet",
           "SORTIE_STYLES", "sortie_style"]  # fmt: skip

IMAGE_SUFFIXES = (".png", ".svg")
#: the highest PNG resolution drawn (dots per inch): the image's memory grows as dpi^2. `show`
#: of examples/maps/tiny.json's plan (9 x 11 inches) peaked at 0.29 GB at 150, 0.42 GB at 600,
#: 0.85 GB at 1,200 (the largest figure, 9 x 15 inches, ~1.3 times that); 10,000 ran out
MAX_DPI = 600


def nice_length(span: float) -> float:
    """A round length (1, 2 or 5 x 10^k metres) near a fifth of `span`, for the scale bar.

    Args:
        span: the length the bar is drawn against, metres (a fifth of it at least 1e-9).

    Returns:
        The largest of 5, 2, 1 x 10^k metres not above a fifth of `span`.
    """
    target = max(span / 5.0, 1e-9)
    k = math.floor(math.log10(target))
    for m in (5, 2, 1):
        if m * 10**k <= target:
            return float(m * 10**k)
    return float(10**k)


#: hover points the map panel labels at most, the first in visiting order (a planned mission
#: has at most 200, `uav.max_hover_points`; a file may hold 65,535 items): placing labels costs
#: O(labels^2); the legend counts the hover points left unlabelled
HOVER_LABELS = 200
#: the data panel shades hovers closer than 1/SHADE_CELLS of the mission time apart as one span
#: (finer than the panel's pixels at MAX_DPI), one collection of at most SHADE_CELLS spans
#: however often a DO_JUMP loop hovers
SHADE_CELLS = 8192


@dataclass(frozen=True)
class _Visits:
    """What the map panel draws of a mission, each distinct thing once however often a DO_JUMP
    loop flies it: the legs (U, 2, 2) in the order first flown and the polylines they form
    (`lines`: the flown path itself when no leg repeats); the hover points (H, 2), their hover
    times (H,) and passes (H,), numbered 1..H in the order first visited, and `number` (V,), the
    number of the hover point of each of the V hover visits; the corners (K, 2), each once."""

    legs: np.ndarray
    lines: list[np.ndarray]
    hover_points: np.ndarray
    hover_times: np.ndarray
    passes: np.ndarray
    number: np.ndarray
    corners: np.ndarray


def _visits(path: np.ndarray, hover_points: np.ndarray, hover_times: np.ndarray,
            hover_keys: Any, corners: np.ndarray, corner_keys: Any) -> _Visits:  # fmt: skip
    """The distinct legs, hover points and corners of a flown mission (`_Visits`), found as the
    checks find distinct legs (`sim.obstacles.unique_legs`, `distinct_rows`): a hover visit is
    the same hover point as another when its item (`hover_keys`, the MAVLink seq), position and
    hover time are the same, a corner when its item and position are. O(n log n) in the visits
    and legs; the drawing then costs what the mission's distinct items do, not its passes.

    Args:
        path: (n, 2) the flown path, local metres.
        hover_points: (V, 2) the position of each hover visit.
        hover_times: (V,) its hover time, s.
        hover_keys: (V,) the item of each visit, or None (every visit its own).
        corners: (k, 2) the corners as flown.
        corner_keys: (k,) the item of each, or None (every corner its own).

    Returns:
        The `_Visits`.
    """
    from sim.obstacles import distinct_rows, unique_legs

    path = np.asarray(path, dtype=float).reshape(-1, 2)
    legs, _ = unique_legs([path], flown_order=True)
    if len(legs):
        breaks = np.flatnonzero(np.any(legs[1:, 0] != legs[:-1, 1], axis=1)) + 1
        lines = [np.vstack([g[:1, 0], g[:, 1]]) for g in np.split(legs, breaks)]
    else:
        lines = [path]
    hp = np.asarray(hover_points, dtype=float).reshape(-1, 2)
    ht = np.asarray(hover_times, dtype=float).reshape(-1)
    keys = np.arange(len(hp)) if hover_keys is None else np.asarray(hover_keys, dtype=float)
    first, passes, inverse = distinct_rows(np.column_stack([keys.reshape(-1), hp, ht]))
    cp = np.asarray(corners, dtype=float).reshape(-1, 2)
    ckeys = np.arange(len(cp)) if corner_keys is None else np.asarray(corner_keys, dtype=float)
    cfirst, _, _ = distinct_rows(np.column_stack([ckeys.reshape(-1), cp]))
    return _Visits(legs=legs, lines=lines, hover_points=hp[first], hover_times=ht[first],
                   passes=passes, number=inverse + 1, corners=cp[cfirst])  # fmt: skip


def _joined(lines: Sequence[np.ndarray]) -> np.ndarray:
    """The polylines as one (m, 2) array for one Line2D, a NaN row between two of them."""
    if len(lines) == 1:
        return lines[0]
    gap = np.full((1, 2), np.nan)
    return np.vstack([part for line in lines for part in (gap, line)][1:])


def _passes_text(n: int) -> str:
    """" ×n" for a hover point a DO_JUMP loop visits n > 1 times, else ""."""
    return f" ×{int(n):,}" if n > 1 else ""


def _timeline_visits(timeline: Any) -> _Visits:
    """`_visits` of a sim replay: hover visits keyed by their item's seq, corners
    (NAV_WAYPOINT stops that are not hover points, `lamde_mission.items.corner_indices`) by
    theirs (none without a route)."""
    from lamde_mission.items import corner_indices

    route = getattr(timeline, "route", None)
    ks = np.zeros(0, dtype=np.int64) if route is None else corner_indices(route)
    stops = np.zeros((0, 2)) if route is None else np.asarray(route.stops, dtype=float)
    seqs = np.zeros(0) if route is None else np.asarray(route.seqs, dtype=np.int64)
    return _visits(np.asarray(timeline.path, dtype=float), timeline.hover_points,
                   timeline.hover_times, getattr(timeline, "hover_seqs", None),
                   stops.reshape(-1, 2)[ks], seqs[ks])  # fmt: skip


def _far_km(timeline: Any, map_: Any) -> float | None:
    """How far (km) a replayed mission lies from the map's area when every stop lies farther
    than the area's size (`sim.replay.far_distance`: the wrong map, or another origin), else
    None (no route: None). O(stops)."""
    from sim.replay import far_distance

    route = getattr(timeline, "route", None)
    d = None if route is None else far_distance(route, map_)
    return None if d is None else d / 1000.0


def _far_title(title: str, where: str, ax: Any) -> str:
    """`title` with a line saying where the mission lies (`where`: "the mission lies 6,336.0
    km") and that it is not drawn (the view stays on the map), wrapped to the figure's width."""
    note = f"{where} from this map's area, not drawn: the wrong map, or another origin?"
    return title + "\n" + _fitted(ax, note, 10.0)


def _mission_view(map_: Any, timeline: Any, plan: Any) -> dict[str, Any] | None:
    """Path, the distinct legs, hover points and corners (0-s points, written as NAV_WAYPOINT;
    `_visits`) and data collected, from a sim Timeline or a Plan."""
    if timeline is not None:
        path = np.asarray(timeline.path, dtype=float)
        return {
            "path": path,
            "return_leg": timeline.return_leg,
            "visits": _timeline_visits(timeline),
            "collected": np.asarray(timeline.collected, dtype=float),
            "f": timeline.totals.f,
        }
    if plan is not None:
        hp = np.asarray(plan.hover_points, dtype=float).reshape(-1, 2)
        bd = getattr(plan, "breakdown", None) or {}
        got = bd.get("collected") if isinstance(bd, dict) else None
        collected = (np.array([float(got.get(i, np.nan)) for i in map_.sensor_ids])
                     if isinstance(got, dict) else None)  # fmt: skip
        ht = np.asarray(plan.hover_times, dtype=float).reshape(-1)
        corner = ht == 0.0  # written as NAV_WAYPOINT corners, not hover points
        path = np.vstack([map_.start, hp, map_.end])
        return {
            "path": path,
            "return_leg": None,
            "visits": _visits(path, hp[~corner], ht[~corner], None, hp[corner], None),
            "collected": collected,
            "f": getattr(plan, "f", None),
        }
    return None


def _shape_path(shell: np.ndarray, holes: Any) -> Any:
    """A matplotlib Path for a polygon with holes (holes drawn open: a courtyard is flyable)."""
    from matplotlib.path import Path as MplPath

    verts: list[np.ndarray] = []
    codes: list[np.ndarray] = []
    for ring in [shell, *holes]:
        ring = np.asarray(ring, dtype=float)
        verts.append(np.vstack([ring, ring[:1]]))
        c = np.full(len(ring) + 1, MplPath.LINETO, dtype=np.uint8)
        c[0], c[-1] = MplPath.MOVETO, MplPath.CLOSEPOLY
        codes.append(c)
    return MplPath(np.concatenate(verts), np.concatenate(codes))


def _violation_segments(map_: Any, path: np.ndarray | None,
                        legs: np.ndarray | None = None) -> list[np.ndarray]:  # fmt: skip
    """The parts of the path's legs inside an obstacle or no-fly zone (C5), as (k, 2) polylines,
    measured by the simulator's own shapely geometry.

    Each distinct leg once (a DO_JUMP loop repeats them), cut by the union of only the obstacles
    an STRtree finds it meeting: O(L log L + U log O + P) for L legs, U distinct, O obstacles and
    P (leg, obstacle) pairs that meet (not every leg against the union of every obstacle).

    Args:
        map_: the map (its obstacles and no-fly zones).
        path: (n, 2) the flown path, local metres; not read when `legs` is given.
        legs: (U, 2, 2) the path's distinct legs when the caller has them (`_Visits.legs`).

    Returns:
        The polylines (k, 2), m.
    """
    import shapely

    from sim.obstacles import obstacle_shapes, unique_legs

    shapes = np.array([o.shape for o in obstacle_shapes(map_)], dtype=object)
    if legs is None:
        legs, _ = unique_legs([np.asarray(path, dtype=float)])
    if not len(shapes) or not len(legs):
        return []
    tree = shapely.STRtree(shapes)
    out: list[np.ndarray] = []
    for (a, b), line in zip(legs, shapely.linestrings(legs), strict=True):
        if np.allclose(a, b):
            continue
        near = tree.query(line, predicate="intersects")
        if not len(near):
            continue
        inter = line.intersection(shapely.union_all(shapes[near]))
        for g in getattr(inter, "geoms", [inter]):
            if g.geom_type == "LineString" and g.length > 1e-6:
                out.append(np.asarray(g.coords, dtype=float))
    return out


#: the white box behind labels, `_BOX_PAD` font sizes beyond the text on each side
_BOX_PAD = 0.15
_TEXT_BOX = {"boxstyle": f"round,pad={_BOX_PAD}", "facecolor": "white", "alpha": 0.7,
             "edgecolor": "none"}  # fmt: skip
#: the thin line joining a label placed past the first ring to its marker
_LEADER = {"colors": "0.35", "linewidths": 0.6, "capstyle": "round", "zorder": 8}

#: where a label may go around its marker, in order of preference: (dx, dy, ha, va)
_DIRECTIONS = ((1, 1, "left", "bottom"), (1, -1, "left", "top"), (-1, 1, "right", "bottom"),
               (-1, -1, "right", "top"), (1, 0, "left", "center"), (-1, 0, "right", "center"),
               (0, 1, "center", "bottom"), (0, -1, "center", "top"))  # fmt: skip
#: extra distances (points) tried beyond the marker's edge; past the first, a leader line
_RINGS = (2.0, 12.0, 24.0, 38.0)
#: sensors the data panels name one by one: coloured lines over time, bars at the end
TIME_LINES = 10
BARS = 60


def _swap_text(who: list[tuple[int, int]]) -> str:
    """The label of the battery swaps at one place: [(vehicle, swap number)] as "v1 swap 1"
    or "v1 swaps 1, 2; v3 swap 1", vehicles in order."""
    by: dict[int, list[int]] = {}
    for v, j in who:
        by.setdefault(v, []).append(j)
    return "; ".join(f"v{v} swap{'s' if len(js) > 1 else ''} {', '.join(map(str, sorted(js)))}"
                     for v, js in sorted(by.items()))


@dataclass
class _Label:
    """A label to place beside a marker: its text, anchor (x, y, m), text style, the marker's
    radius there (points), and whether it may be left out when no place is free (sensor ids);
    `rivals` (k, 2; m), markers it could be taken for (another depot nearby): a place without a
    leader line must be nearer its own marker than any of these."""

    text: str
    xy: tuple[float, float]
    style: dict[str, Any]
    radius: float
    optional: bool = False
    short: str | None = None  # a shorter text to try when the full one finds no free place
    rivals: np.ndarray | None = None


@dataclass
class _Scene:
    """What the map panel's labels and scale bar must not cover: markers (x, y, m; radius in
    points), the route's vertices (m), and the labels to place; and the direction arrows to
    draw once the layout is fixed (`_draw_arrows`): each route's (k, 2, 2) arrows (from, to;
    m), colour and head size (points)."""

    points: list[np.ndarray]
    radii: list[np.ndarray]
    route: list[np.ndarray]
    labels: list[_Label]
    arrows: list[tuple[np.ndarray, Any, float]] = field(default_factory=list)

    def marker(self, xy: Any, radius: Any) -> None:
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        self.points.append(xy)
        self.radii.append(np.broadcast_to(np.asarray(radius, dtype=float), (len(xy),)).copy())


def _new_scene() -> _Scene:
    return _Scene([], [], [], [])


def _marker_boxes(ax: Any, scene: _Scene) -> np.ndarray:
    """Every marker's square box in display pixels, (k, 4): x0, y0, x1, y1."""
    if not scene.points:
        return np.zeros((0, 4))
    xy = ax.transData.transform(np.vstack(scene.points))
    r = np.concatenate(scene.radii)[:, None] * ax.figure.dpi / 72.0
    return np.hstack([xy - r, xy + r])


def _overlaps(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Which of `boxes` (k, 4) overlap `box` (4,) (touching edges do not): (k,); for n boxes
    (n, 4) at once, (n, k)."""
    box = np.asarray(box, dtype=float)
    if not len(boxes):
        return np.zeros(box.shape[:-1] + (0,), dtype=bool)
    b = box[..., None, :]
    return ((b[..., 0] < boxes[:, 2]) & (b[..., 2] > boxes[:, 0]) & (b[..., 1] < boxes[:, 3])
            & (b[..., 3] > boxes[:, 1]))  # fmt: skip


def _route_points(ax: Any, scene: _Scene) -> np.ndarray:
    """The route sampled every ~4 pixels along each leg, in display pixels (m, 2)."""
    out = []
    for p in scene.route:
        px = ax.transData.transform(np.asarray(p, dtype=float).reshape(-1, 2))
        for a, b in zip(px[:-1], px[1:], strict=False):
            n = max(int(np.hypot(*(b - a)) / 4.0), 1)
            out.append(a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a))
    return np.vstack(out) if out else np.zeros((0, 2))


def _place_scale_bar(ax: Any, W: float, renderer: Any, markers: np.ndarray,
                     route: np.ndarray) -> np.ndarray:  # fmt: skip
    """Add the scale bar in the axes corner whose box covers the fewest markers, then the
    fewest route samples (ties: lower right, lower left, upper right, upper left). Returns the
    bar's box in display pixels (4,). Cost: O(markers + route samples)."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    bar = nice_length(W)
    label = f"{bar / 1000:g} km" if bar >= 1000 else f"{bar:g} m"
    best = None
    for k, loc in enumerate(("lower right", "lower left", "upper right", "upper left")):
        artist = AnchoredSizeBar(ax.transData, bar, label, loc=loc, pad=0.4, borderpad=0.6,
                                 sep=4, frameon=True, size_vertical=0)  # fmt: skip
        ax.add_artist(artist)
        e = artist.get_window_extent(renderer)
        box = np.array([e.x0, e.y0, e.x1, e.y1])
        inside = (np.sum((route[:, 0] > box[0]) & (route[:, 0] < box[2]) & (route[:, 1] > box[1])
                         & (route[:, 1] < box[3])) if len(route) else 0)  # fmt: skip
        score = (int(_overlaps(box, markers).sum()), int(inside), k)
        if best is None or score < best[0]:
            if best is not None:
                best[1].remove()
            best = (score, artist, box)
        else:
            artist.remove()
    assert best is not None
    return best[2]


@dataclass(frozen=True)
class _Placed:
    """A label given its place: the label, the text shown (its own or its short one), the
    offset of its alignment point from the marker (points), the alignment, the text's box in
    display pixels (x0, y0, x1, y1; the white box around it not included) and whether a leader
    line joins it to its marker."""

    label: _Label
    text: str
    offset: tuple[float, float]
    ha: str
    va: str
    box: np.ndarray
    leader: bool


class _TextSizes:
    """Label texts' (width, height) in display pixels, each text and font measured once: the
    size does not depend on where the text goes, and `_place_labels` tries a label in up to 32
    places, again when the layout is redone. One probe Text per font, its text changed (no
    annotation made and removed to be measured)."""

    def __init__(self, ax: Any) -> None:
        self.ax = ax
        self.probes: dict[Any, Any] = {}
        self.sizes: dict[Any, tuple[float, float]] = {}

    def __call__(self, renderer: Any, text: str, style: dict[str, Any]) -> tuple[float, float]:
        from matplotlib.text import Text

        font = tuple(sorted((k, v) for k, v in style.items()
                            if k not in ("bbox", "color", "zorder")))  # fmt: skip
        key = (text, font)
        if key not in self.sizes:
            probe = self.probes.get(font)
            if probe is None:
                probe = self.probes[font] = Text(0.0, 0.0, "", **dict(font))
                probe.set_figure(self.ax.figure)
            probe.set_text(text)
            e = probe.get_window_extent(renderer)
            self.sizes[key] = (float(e.width), float(e.height))
        return self.sizes[key]


def _place_labels(ax: Any, renderer: Any, labels: Sequence[_Label], avoid: np.ndarray,
                  sizes: _TextSizes) -> tuple[list[_Placed], int, int]:
    """Place each label beside its marker, greedily in the given order: the first candidate
    position (`_DIRECTIONS` x `_RINGS`, inside the axes) whose box overlaps no label placed
    before and no box of `avoid` (markers, the scale bar); past the first ring a thin leader
    line joins label and marker. A label with `rivals` (a depot beside another) takes a place
    without a leader only where its box's centre is nearer its own marker than any rival's,
    so that it cannot be read as the other's (where none is, the rule is dropped). A label that
    is not optional, finding no free place, may cover a marker, never another label: failing
    that, its shorter text is tried, then it is left out; an optional one (a sensor id) is
    tried on the first two rings only, so long leader lines do not crowd the map, and is left
    out when no place is free. Nothing is drawn here (`_draw_labels` draws the places found);
    texts are measured once (`sizes`). Deterministic; cost O(labels^2 + labels x markers).

    Args:
        ax: the map panel, its layout fixed.
        renderer: the figure's renderer (text sizes in its pixels).
        labels: the labels, in the order to place them.
        avoid: (k, 4) boxes in display pixels that labels should not cover.
        sizes: the texts' sizes (`_TextSizes`, shared between calls).

    Returns:
        The labels placed, and how many optional and how many other labels were left out.
    """
    dpi_px = ax.figure.dpi / 72.0
    e = ax.get_window_extent(renderer)
    frame = (e.x0, e.y0, e.x1, e.y1)
    placed = np.zeros((0, 4))
    out: list[_Placed] = []
    dropped = [0, 0]

    directions = np.array([(dx, dy) for dx, dy, _, _ in _DIRECTIONS], dtype=float)
    # the share of the box's width (height) left of (below) the alignment point
    left = np.array([{"left": 0.0, "right": 1.0, "center": 0.5}[ha] for _, _, ha, _ in _DIRECTIONS])
    below = np.array([{"bottom": 0.0, "top": 1.0, "center": 0.5}[va] for *_, va in _DIRECTIONS])

    def search(text: str, lab: _Label) -> Any:
        """Every candidate place at once, in the order of preference (ring, then direction):
        the first that is free of labels and markers, else (a label that must be shown) the
        first free of labels."""
        tw, th = sizes(renderer, text, lab.style)
        pad = 0.2 * float(lab.style.get("fontsize", 8)) * dpi_px
        w, h = tw + 2 * pad, th + 2 * pad
        anchor = ax.transData.transform(lab.xy)
        rings = np.asarray(_RINGS[:2] if lab.optional else _RINGS)
        off = directions[None, :, :] * (lab.radius + rings)[:, None, None]  # (rings, 8, 2) pt
        x0 = (anchor[0] + off[..., 0] * dpi_px - left * w).reshape(-1)
        y0 = (anchor[1] + off[..., 1] * dpi_px - below * h).reshape(-1)
        boxes = np.column_stack([x0, y0, x0 + w, y0 + h])
        free = ((boxes[:, 0] >= frame[0]) & (boxes[:, 1] >= frame[1]) & (boxes[:, 2] <= frame[2])
                & (boxes[:, 3] <= frame[3]))  # fmt: skip
        free &= ~_overlaps(boxes, placed).any(axis=1)
        clear = free & ~_overlaps(boxes, avoid).any(axis=1)
        plain = np.ones(len(boxes), dtype=bool)  # not to be taken for a rival's label
        if lab.rivals is not None and len(lab.rivals):
            centre = (boxes[:, :2] + boxes[:, 2:]) / 2.0
            rival = ax.transData.transform(np.asarray(lab.rivals, dtype=float).reshape(-1, 2))
            nearest = np.min(np.hypot(centre[:, None, 0] - rival[None, :, 0],
                                      centre[:, None, 1] - rival[None, :, 1]), axis=1)
            led = np.arange(len(boxes)) >= len(_DIRECTIONS)  # past the first ring: a leader
            plain = led | (np.hypot(*(centre - anchor).T) < nearest)
        # a sensor id does not cover a marker
        tiers = (clear & plain, clear) if lab.optional else (clear & plain, free & plain,
                                                             clear, free)  # fmt: skip
        tier = next((c for c in tiers if c.any()), None)
        if tier is None:
            return None
        i = int(np.argmax(tier))
        ring, k = divmod(i, len(_DIRECTIONS))
        _, _, ha, va = _DIRECTIONS[k]
        ox, oy = float(off[ring, k, 0]), float(off[ring, k, 1])
        tx = anchor[0] + ox * dpi_px - {"left": 0.0, "right": tw, "center": tw / 2}[ha]
        ty = anchor[1] + oy * dpi_px - {"bottom": 0.0, "top": th, "center": th / 2}[va]
        return _Placed(lab, text, (ox, oy), ha, va, np.array([tx, ty, tx + tw, ty + th]),
                       ring > 0), boxes[i]  # fmt: skip

    for lab in labels:
        found = search(lab.text, lab)
        if found is None and lab.short:
            found = search(lab.short, lab)
        if found is None:
            dropped[0 if lab.optional else 1] += 1
            continue
        out.append(found[0])
        placed = np.vstack([placed, found[1]])
    return out, dropped[0], dropped[1]


def _leader_segments(ax: Any, placed: Sequence[_Placed]) -> np.ndarray:
    """The leader lines of the labels that have one, (k, 2, 2) in data coordinates: from the
    edge of the label's white box, on the line from its centre to the marker, to the marker's
    edge (`_Label.radius` points short of it), as an annotation's arrow would run. Computed
    once the layout is fixed: the figure's size is, so a point is the same data length at any
    dpi."""
    dpi_px = ax.figure.dpi / 72.0
    segs = []
    for p in placed:
        if not p.leader:
            continue
        anchor = ax.transData.transform(p.label.xy)
        centre = (p.box[:2] + p.box[2:]) / 2.0
        pad = _BOX_PAD * float(p.label.style.get("fontsize", 8)) * dpi_px
        half = (p.box[2:] - p.box[:2]) / 2.0 + pad
        d = anchor - centre
        length = float(np.hypot(*d))
        if length == 0.0:
            continue
        start = centre + d * min(half[i] / abs(d[i]) if d[i] else np.inf for i in (0, 1))
        end = anchor - d / length * p.label.radius * dpi_px
        if np.dot(end - start, d) > 0:
            segs.append([start, end])
    if not segs:
        return np.zeros((0, 2, 2))
    return ax.transData.inverted().transform(np.reshape(segs, (-1, 2))).reshape(-1, 2, 2)


def _draw_labels(ax: Any, placed: Sequence[_Placed]) -> None:
    """Draw the placed labels (`_place_labels`), each once: its text in its white box, and
    every leader line together in one collection beneath the labels."""
    from matplotlib.collections import LineCollection

    segs = _leader_segments(ax, placed)
    if len(segs):
        ax.add_collection(LineCollection(segs, **_LEADER), autolim=False)
    for p in placed:
        ax.annotate(p.text, p.label.xy, xytext=p.offset, textcoords="offset points", ha=p.ha,
                    va=p.va, **p.label.style)  # fmt: skip


def _arrow_paths(ax: Any, arrows: np.ndarray, scale: float, linewidth: float) -> list[Any]:
    """The paths (data coordinates) of '-|>' arrows from arrows[:, 0] to arrows[:, 1], as
    `ax.annotate("", xy=to, xytext=from, arrowprops={"arrowstyle": "-|>", "mutation_scale":
    scale, "lw": linewidth})` draws them: each end shrunk 2 points (where the arrow is longer),
    matplotlib's own '-|>' head (`ArrowStyle`); two paths an arrow, its shaft (to stroke) and
    its head (to fill and stroke). Computed once the layout is fixed (a point is then the same
    data length at any dpi)."""
    from matplotlib.patches import ArrowStyle
    from matplotlib.path import Path as MplPath

    px = ax.figure.dpi / 72.0
    style = ArrowStyle("-|>")
    inverse = ax.transData.inverted()
    ends = ax.transData.transform(np.asarray(arrows, dtype=float).reshape(-1, 2)).reshape(-1, 2, 2)
    out = []
    for a, b in ends:
        shrink = 2.0 * px  # FancyArrowPatch's shrinkA, shrinkB: not where the arrow is shorter
        u = (b - a) / max(float(np.hypot(*(b - a))), 1e-300)
        if np.hypot(*(b - a)) > shrink:
            a = a + u * shrink
        if np.hypot(*(b - a)) > shrink:
            b = b - u * shrink
        parts, _ = style(MplPath(np.array([a, b])), scale * px, linewidth * px, None)
        for p in parts:
            v = p.vertices.copy()
            if p.codes is not None:  # CLOSEPOLY's vertex is not read: its subpath's first
                v[p.codes == MplPath.CLOSEPOLY] = v[0]
            out.append(MplPath(inverse.transform(v), p.codes))
    return out


def _draw_arrows(ax: Any, scene: _Scene) -> None:
    """Each route's direction arrows (`_Scene.arrows`) as one collection: shafts stroked and
    '-|>' heads filled, 1.4 points wide in the route's colour, round joins and caps, as a
    FancyArrowPatch draws them."""
    from matplotlib.collections import PathCollection

    for arrows, colour, scale in scene.arrows:
        ax.add_collection(PathCollection(_arrow_paths(ax, arrows, scale, 1.4),
                                         facecolors=["none", colour], edgecolors=[colour],
                                         linewidths=1.4, joinstyle="round", capstyle="round",
                                         zorder=3), autolim=False)  # fmt: skip


def _map_axes(map_: Any, *, has_time: bool, has_bars: bool = False,
              figsize: tuple[float, float] | None) -> Any:  # fmt: skip
    """(figure, map axes, time axes or None, bar axes or None, legend handles): the area
    drawn, sized to its shape (no wide white bands); `figsize` overrides the size."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle as RectanglePatch

    W, H = map_.spec.area.width, map_.spec.area.height
    aspect = H / W if W > 0 else 1.0
    map_w = 7.5
    map_h = float(np.clip(map_w * aspect, 2.5, 9.0))
    if map_w * aspect > 9.0:  # a tall area: narrower figure rather than a taller one
        map_w = 9.0 / aspect if aspect > 0 else map_w
        map_w = max(map_w, 3.0)
    time_h = 2.3 if has_time else 0.0
    bars_h = 2.0 if has_time and has_bars else 0.0
    if figsize is None:
        figsize = (map_w + 1.6, map_h + 1.4 + time_h + bars_h)
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    ax_b = None
    if has_time and has_bars:
        ax, ax_t, ax_b = fig.subplots(3, 1, height_ratios=[map_h, time_h, bars_h])
    elif has_time:
        ax, ax_t = fig.subplots(2, 1, height_ratios=[map_h, time_h])
    else:
        ax, ax_t = fig.add_subplot(1, 1, 1), None
    # the box keeps the figure's shape and the limits grow to fill it: no white bands, and the
    # colour bar is as tall as the map
    ax.set_aspect("equal", adjustable="datalim")
    pad = 0.03 * max(W, H)
    ax.margins(0)  # the view: the area plus a pad, grown along one axis to fill the box
    ax.update_datalim(np.array([[-pad, -pad], [W + pad, H + pad]]))
    ax.autoscale_view()
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.add_patch(RectanglePatch((0, 0), W, H, fill=False, edgecolor="0.3", linewidth=1.2,
                                linestyle="--"))  # fmt: skip
    handles: list[Any] = [Line2D([], [], color="0.3", linestyle="--", label="area")]
    return fig, ax, ax_t, ax_b, handles


def _draw_obstacles(ax: Any, map: Any, handles: list[Any]) -> None:  # noqa: A002
    """Circles, rotated rectangles, footprints and no-fly zones (holes open), with their
    legend entries: the obstacles one collection, the no-fly zones another (each shape its own
    path)."""
    from matplotlib.collections import PathCollection
    from matplotlib.patches import Patch
    from matplotlib.path import Path as MplPath

    spec = map.spec
    shapes = list(getattr(map, "shapes", ()))
    n_footprints = sum(sh.kind != "no_fly_zone" for sh in shapes)
    # thin outlines when there are many footprints (a campus), so neighbours stay apart
    lw = 0.8 if n_footprints < 100 else 0.3
    obstacle_style = {"facecolor": "0.55", "edgecolor": "0.25", "alpha": 0.75, "linewidth": lw}
    nfz_style = {"facecolor": "tab:red", "alpha": 0.18, "edgecolor": "tab:red", "hatch": "//",
                 "linewidth": 1.0}  # fmt: skip
    # one collection for the obstacles, one for the no-fly zones (each shape its own path, so
    # overlaps shade as separate patches would): a 1,000-obstacle campus is two artists
    unit = MplPath.unit_circle()
    solid = [MplPath(unit.vertices * c.radius + (c.x, c.y), unit.codes)
             for c in spec.obstacles.circles]  # fmt: skip
    solid += [MplPath(np.vstack([poly, poly[:1]]), closed=True)
              for poly in (np.asarray(p, dtype=float) for p in map.rectangle_polygons)]
    solid += [_shape_path(sh.shell, sh.holes) for sh in shapes if sh.kind != "no_fly_zone"]
    nfz = [_shape_path(sh.shell, sh.holes) for sh in shapes if sh.kind == "no_fly_zone"]
    for paths, style in ((solid, obstacle_style), (nfz, nfz_style)):
        if paths:
            ax.add_collection(PathCollection(paths, **style))
    if spec.obstacles.circles or spec.obstacles.rectangles or n_footprints:
        handles.append(Patch(label="obstacles", **obstacle_style))
    if len(shapes) > n_footprints:
        handles.append(Patch(facecolor="tab:red", alpha=0.3, edgecolor="tab:red", hatch="//",
                             label="no-fly zones"))  # fmt: skip


#: the style of sensor-id labels, and of the labels of sensors short of data
_ID_STYLE = {"fontsize": 7.5, "zorder": 8, "bbox": _TEXT_BOX}
_SHORT_STYLE = {"fontsize": 8, "color": "tab:red", "fontweight": "bold", "zorder": 8,
                "bbox": _TEXT_BOX}  # fmt: skip


def _draw_sensors(
    fig: Any,
    ax: Any,
    map: Any,  # noqa: A002
    collected: np.ndarray | None,
    handles: list[Any],
    scene: _Scene,
) -> np.ndarray:
    """The sensors; with `collected` (Mbit per sensor) coloured by the share of their
    requirement, short ones ringed, unreached ones crossed, and a colour bar. Their labels go
    to `scene` (placed later, `_place_labels`): "x of y Mbit" on short sensors (always shown),
    the id on the others (left out where crowded; the tightest first). Returns the sensor
    positions (J x 2, m)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.lines import Line2D

    sensors = np.asarray(map.sensors, dtype=float)
    required = np.asarray(map.required_data, dtype=float)
    ids = list(map.sensor_ids)
    scene.marker(sensors, 3.6)
    if collected is not None:
        got = collected
        share = np.where(required > 0, got / np.maximum(required, 1e-300), 1.0)
        norm = Normalize(0.0, 1.0)
        cmap = "RdYlGn"
        ax.scatter(sensors[:, 0], sensors[:, 1], c=np.clip(share, 0, 1), cmap=cmap, norm=norm,
                   marker="o", s=40, edgecolors="k", linewidths=0.6, zorder=4)  # fmt: skip
        short = share < 1.0 - 1e-9
        none = short & (got <= 1e-9)
        if short.any():
            ax.scatter(
                sensors[short, 0],
                sensors[short, 1],
                marker="o",
                s=260,
                facecolors="none",
                edgecolors="tab:red",
                linewidths=2.0,
                zorder=5,
            )
            scene.marker(sensors[short], 9.0)
            handles.append(
                Line2D(
                    [],
                    [],
                    marker="o",
                    linestyle="",
                    markersize=11,
                    markerfacecolor="none",
                    markeredgecolor="tab:red",
                    markeredgewidth=2,
                    label="sensor short of data (C4)",
                )
            )
        if none.any():
            ax.scatter(sensors[none, 0], sensors[none, 1], marker="X", s=160, c="tab:red",
                       edgecolors="k", linewidths=0.8, zorder=6)  # fmt: skip
            handles.append(Line2D([], [], marker="X", linestyle="", markersize=10,
                                  markerfacecolor="tab:red", markeredgecolor="k",
                                  label="sensor not reached (0 Mbit)"))  # fmt: skip
        for j in np.flatnonzero(short):
            scene.labels.append(_Label(f"{ids[j]}: {got[j]:.0f} of {required[j]:.0f} Mbit",
                                       tuple(sensors[j]), _SHORT_STYLE, 9.0,
                                       short=ids[j]))  # fmt: skip
        for j in sorted(np.flatnonzero(~short), key=lambda j: (share[j], j)):
            scene.labels.append(_Label(ids[j], tuple(sensors[j]), _ID_STYLE, 3.6, True))
        cb = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, fraction=0.04, pad=0.01)
        cb.set_label("data collected / required")
        handles.append(
            Line2D(
                [],
                [],
                marker="o",
                linestyle="",
                markerfacecolor="tab:green",
                markeredgecolor="k",
                label="sensors (colour: share collected)",
            )
        )
    else:
        ax.scatter(sensors[:, 0], sensors[:, 1], marker="o", s=30, c="tab:blue",
                   edgecolors="k", linewidths=0.5, zorder=4)  # fmt: skip
        for j, sid in enumerate(ids):
            scene.labels.append(_Label(sid, tuple(sensors[j]), _ID_STYLE, 3.6, True))
        handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="tab:blue",
                              markeredgecolor="k", label="sensors"))  # fmt: skip
    return sensors


def _draw_ends(ax: Any, map: Any, hover_points: np.ndarray, hover_radii: np.ndarray,  # noqa: A002
               scene: _Scene, handles: list[Any]) -> None:  # fmt: skip
    """Start (triangle) and end (square). Where a hover point lies at the same place (within
    its marker), the start or end is drawn hollow and larger, around the hover point, so
    neither hides the other."""
    from matplotlib.lines import Line2D

    W, H = map.spec.area.width, map.spec.area.height
    near = 0.015 * max(W, H)
    for xy, marker, size, colour, name in ((map.start, "^", 11.0, "tab:green", "start"),
                                           (map.end, "s", 10.0, "tab:purple", "end")):  # fmt: skip
        xy = np.asarray(xy, dtype=float)
        d = np.hypot(*(hover_points - xy).T) if len(hover_points) else np.zeros(0)
        if len(d) and d.min() < near:
            around = 2.0 * float(hover_radii[int(np.argmin(d))]) + 6.0
            size = around * (1.9 if marker == "^" else 1.0)
            ax.plot(
                *xy,
                marker=marker,
                markersize=size,
                markerfacecolor="none",
                markeredgecolor=colour,
                markeredgewidth=2.2,
                zorder=7,
                linestyle="",
            )
        else:
            ax.plot(*xy, marker=marker, markersize=size, color=colour, markeredgecolor="k",
                    zorder=7, linestyle="")  # fmt: skip
        scene.marker(xy, size / 2.0)
        handles.append(Line2D([], [], marker=marker, linestyle="", markerfacecolor=colour,
                              markeredgecolor="k", label=name))  # fmt: skip


def _fix_layout(fig: Any) -> None:
    """Keep the figure's panels where its layout put them: no layout engine at all, not
    matplotlib's placeholder ("none"), for which `savefig` draws the whole figure once more,
    every label and tick measured again, before drawing it into the file. The rcParams that
    would make None mean a layout engine are off while it is set."""
    import matplotlib

    with matplotlib.rc_context({"figure.autolayout": False,
                                "figure.constrained_layout.use": False}):  # fmt: skip
        fig.set_layout_engine(None)


def _finish_map(fig: Any, ax: Any, W: float, handles: list[Any], scene: _Scene, n_sensors: int,
                named_below: bool, unlabelled: int = 0) -> tuple[int, int]:  # fmt: skip
    """The legend below, the layout fixed, the scale bar in the emptiest corner, then every
    label placed (`_place_labels`: the ones always shown first, then sensor ids). When labels
    were left out, or `unlabelled` hover points past `HOVER_LABELS` got none, the legend says
    how many in the legend's title, a line kept for it (the layout redone only where the
    note needs more lines: a narrow figure; the note's counts are the final ones). The legend
    takes four columns, fewer where four would run past the figure's edges. The direction
    arrows (`_draw_arrows`) and the labels (`_draw_labels`) are drawn last, once, where the
    final layout put them. Returns how many sensor ids and other labels were left out."""
    labels = sorted(scene.labels, key=lambda lab: lab.optional)  # stable: order kept within
    sizes = _TextSizes(ax)  # the labels' text sizes, measured once for both attempts

    def legend_with() -> Any:
        # four columns where they fit the figure's width, fewer where long entries (a narrow
        # figure: a tall map) would run past its edges; a title line kept for the note of
        # labels left out, so that writing it there needs no new layout
        renderer = fig.canvas.get_renderer()
        for ncol in range(min(len(handles), 4), 0, -1):
            legend = fig.legend(handles=handles, loc="outside lower center", ncol=ncol,
                                fontsize=8, frameon=False, title=" ", title_fontsize=8)
            if ncol == 1 or legend.get_window_extent(renderer).width <= fig.bbox.width:
                return legend
            legend.remove()
        raise AssertionError("unreachable: one column is always kept")

    def set_note(legend: Any, text: str) -> None:
        # the note on one line where it fits the figure's width, else a line per clause
        legend.set_title(text)
        if legend.get_window_extent(fig.canvas.get_renderer()).width > fig.bbox.width:
            legend.set_title(text.replace("; ", ";\n"))

    def attempt() -> tuple[tuple[int, int], list[Any], list[_Placed]]:
        fig.set_layout_engine("constrained")
        fig.draw_without_rendering()
        _fix_layout(fig)  # positions fixed: the pixels the labels are fitted in
        renderer = fig.canvas.get_renderer()
        markers = _marker_boxes(ax, scene)
        n_artists = len(ax.artists)
        bar = _place_scale_bar(ax, W, renderer, markers, _route_points(ax, scene))
        placed, *dropped = _place_labels(ax, renderer, labels,
                                         np.vstack([markers, bar[None, :]]), sizes)  # fmt: skip
        return (dropped[0], dropped[1]), list(ax.artists[n_artists:]), placed

    def note(k: tuple[int, int]) -> str:
        parts = []
        if k[0]:
            parts.append(f"{k[0]} of {n_sensors} sensor ids")
        if k[1]:
            parts.append(f"{k[1]} other labels")
        where = "; the panels below name every sensor" if named_below else ""
        crowded = " and ".join(parts or ["no labels"]) + f" left out where crowded{where}"
        if not unlabelled:
            return crowded
        capped = f"hover points past the first {HOVER_LABELS} unlabelled ({unlabelled:,})"
        return f"{capped}; {crowded}" if parts else capped

    legend = legend_with()
    dropped, added, placed = attempt()
    if any(dropped) or unlabelled:
        renderer = fig.canvas.get_renderer()
        height = legend.get_tightbbox(renderer).height
        set_note(legend, note(dropped))
        # the layout leaves the legend below the panels its height, nothing else of it: where
        # the note fits the title line kept for it, the layout and every place found stand
        if legend.get_tightbbox(renderer).height != height:
            for artist in added:
                artist.remove()
            dropped, _, placed = attempt()
        set_note(legend, note(dropped))
    _draw_arrows(ax, scene)
    _draw_labels(ax, placed)  # once, where the last attempt placed them
    return dropped


def _draw_route(ax: Any, scene: _Scene, map_: Any, visits: _Visits,
                return_leg: Any, *, colour: Any, linestyle: str, arrow_scale: float,
                return_width: float, corner_edge: Any, hover_face: Any,
                hover_alpha: float) -> tuple[list[float], np.ndarray]:  # fmt: skip
    """Draw one flown route on the map panel, each distinct leg, hover point and corner once
    (`_Visits`), and note its route and markers in `scene`: the legs as one line, an arrow
    along each leg longer than 2 % of the area (noted in `scene.arrows`, drawn once the layout
    is fixed: `_draw_arrows`), the parts of its legs inside obstacles (C5) in
    red, the return leg (RTL) dotted, the corners as small white diamonds, the hover points as
    discs of area 40 + 260 T / T_max points^2. Legend entries and labels are the caller's.

    Args:
        ax: the map panel.
        scene: what the labels must not cover (route vertices and markers added here).
        map_: the map (its area, T_max and obstacles).
        visits: the route's distinct legs, hover points and corners.
        return_leg: (m, 2) the RTL return leg, or None.
        colour, linestyle: the route's line; arrows and the return leg in `colour` too.
        arrow_scale: the arrows' mutation scale.
        return_width: the return leg's line width, points.
        corner_edge, hover_face: matplotlib colours of the corners' edges and the hover discs.
        hover_alpha: the hover discs' opacity.

    Returns:
        The lengths (m) of the parts of its legs inside obstacles, in drawing order, and the hover
        discs' radii (H,), points.
    """
    spec = map_.spec
    W, H = spec.area.width, spec.area.height
    scene.route.extend(visits.lines)
    line = _joined(visits.lines)  # each distinct leg once (the path when none repeats)
    ax.plot(line[:, 0], line[:, 1], linestyle=linestyle, color=colour, linewidth=1.6, zorder=3)
    legs = visits.legs.reshape(-1, 2, 2)
    long = legs[np.hypot(*(legs[:, 1] - legs[:, 0]).T) > 0.02 * max(W, H)]
    if len(long):  # one arrow per distinct leg, drawn once the layout is fixed
        a, b = long[:, 0], long[:, 1]
        scene.arrows.append((np.stack([a + 0.45 * (b - a), a + 0.55 * (b - a)], axis=1),
                             colour, float(arrow_scale)))  # fmt: skip
    lengths = []
    for seg in _violation_segments(map_, None, visits.legs):  # the legs already made distinct
        ax.plot(seg[:, 0], seg[:, 1], "-", color="red", linewidth=4.0, zorder=7,
                solid_capstyle="butt")  # fmt: skip
        lengths.append(float(np.sum(np.hypot(*np.diff(seg, axis=0).T))))
    if return_leg is not None:
        rl = np.asarray(return_leg, dtype=float)
        scene.route.append(rl)
        ax.plot(rl[:, 0], rl[:, 1], ":", color=colour, linewidth=return_width, zorder=3)
    cp = visits.corners
    if len(cp):  # corners (NAV_WAYPOINT, flown through)
        scene.marker(cp, 3.0)
        ax.scatter(cp[:, 0], cp[:, 1], s=14, marker="D", facecolors="white",
                   edgecolors=corner_edge, linewidths=0.8, zorder=7)  # fmt: skip
    hp, ht = visits.hover_points, visits.hover_times
    radius = np.zeros(0)
    if len(hp):
        t_max = max(float(spec.uav.max_hover_time), 1e-9)
        size = 40.0 + 260.0 * np.clip(ht / t_max, 0.0, 1.0)
        radius = np.sqrt(size) / 2.0 + 0.5
        scene.marker(hp, radius)
        ax.scatter(hp[:, 0], hp[:, 1], s=size, facecolors=hover_face, edgecolors="k",
                   alpha=hover_alpha, linewidths=0.6, zorder=6)  # fmt: skip
    return lengths, radius


def mission_figure(
    map: Any,  # noqa: A002
    *,
    timeline: Any = None,
    plan: Any = None,
    title: str | None = None,
    figsize: tuple[float, float] | None = None,
) -> Any:
    """A matplotlib Figure (Agg canvas) of `map` with a replayed `timeline` or a `plan`.

    The map panel labels hover points by visiting order and hover seconds ("2 · 41 s") and
    sensors by id, each label placed where it covers no other label, marker or the scale bar
    (`_place_labels`; sensor ids that find no free place are left out and counted in the
    legend; hover points past the first `HOVER_LABELS` get none, counted there too); draws each
    distinct leg, hover point and corner once however often a DO_JUMP loop flies it (`_visits`:
    a hover point visited k times is labelled "2 · 41 s ×k", numbered in the order first
    visited); shows the route's direction with arrows, draws the parts of legs inside an
    obstacle (C5) in red, rings sensors short of data with "x of y Mbit" and crosses those that
    got nothing; the scale bar goes to the corner where it covers the fewest markers. With a
    `timeline` (the simulator's replay) a second panel shows each sensor's data over the
    mission time against its requirement (the `TIME_LINES` tightest sensors in distinct
    colours, named; the others grey), and with more than `TIME_LINES` sensors a third panel
    names every sensor with its final share as sorted bars (the `BARS` tightest; the rest
    summarised as min / median / max); the end labels of the named lines are spread apart
    once the layout is fixed (`_spread_end_labels`), and a mission that gives no sensor any
    data says why in that panel's title. A replayed mission that lies thousands of km from the
    map's area (`sim.replay.far_distance`: the wrong map, another origin) is not drawn: the
    view stays on the map, and a second title line says how far the mission is. The figure's
    size follows the area's shape (no wide white bands); `figsize` overrides it. Cost: O(J^2)
    for the label placement (J sensors plus at most `HOVER_LABELS` hover points), O(J x
    samples) to find where the data lines bend, and an artist per label; legs, arrows,
    obstacles and data lines are a few collections.

    Args:
        map: the map (`planner_core.model.mapio.load_map`).
        timeline: the simulator's replay of the stored mission (`sim.replay`), or None.
        plan: a plan (hover points, m; hover times, s), used when there is no timeline.
        title: the title (default: the map's name and f).
        figsize: inches (default: from the area's shape).

    Returns:
        The Figure (Agg canvas; its layout fixed).
    """
    from matplotlib.lines import Line2D

    spec = map.spec
    W = spec.area.width
    view = _mission_view(map, timeline, plan)
    # a mission thousands of km away (the wrong map, another origin) is not drawn: the view
    # stays on the map, and the title says where the mission is
    far_km = None if timeline is None else _far_km(timeline, map)
    has_time = timeline is not None and len(getattr(timeline, "t", ())) > 1
    has_bars = has_time and len(map.sensor_ids) > TIME_LINES
    fig, ax, ax_t, ax_b, handles = _map_axes(map, has_time=has_time, has_bars=has_bars,
                                             figsize=figsize)  # fmt: skip
    scene = _new_scene()
    _draw_obstacles(ax, map, handles)
    sensors = _draw_sensors(fig, ax, map, None if view is None else view["collected"], handles,
                            scene)  # fmt: skip
    hover_labels: list[_Label] = []
    hp = np.zeros((0, 2))
    hover_r = np.zeros(0)
    unlabelled = 0
    visits = None
    if view is not None and far_km is not None:
        visits = view["visits"]  # the data panel numbers the hovers as they are
    elif view is not None:
        visits = view["visits"]
        lengths, hover_r = _draw_route(ax, scene, map, visits, view["return_leg"],
                                       colour="tab:blue", linestyle="-", arrow_scale=14,
                                       return_width=1.2, corner_edge="tab:blue",
                                       hover_face="tab:orange", hover_alpha=0.85)  # fmt: skip
        handles.append(Line2D([], [], color="tab:blue", linewidth=1.6,
                              label="path (arrows: direction)"))  # fmt: skip
        if lengths:
            handles.append(
                Line2D(
                    [],
                    [],
                    color="red",
                    linewidth=4,
                    label=f"path inside obstacles (C5): {sum(lengths):.0f} m",
                )
            )
        if view["return_leg"] is not None:
            handles.append(Line2D([], [], color="tab:blue", linestyle=":", label="return (RTL)"))
        hp, ht, passes = visits.hover_points, visits.hover_times, visits.passes
        cp = visits.corners
        if len(cp):
            handles.append(Line2D([], [], marker="D", linestyle="", markerfacecolor="white",
                                  markeredgecolor="tab:blue",
                                  label=f"corner, flown through ({len(cp)})"))  # fmt: skip
        if len(hp):
            style = {"fontsize": 8, "color": "saddlebrown", "fontweight": "bold", "zorder": 8,
                     "bbox": _TEXT_BOX}  # fmt: skip
            unlabelled = max(len(hp) - HOVER_LABELS, 0)
            for i in range(min(len(hp), HOVER_LABELS)):
                many = _passes_text(passes[i])
                hover_labels.append(_Label(f"{i + 1} · {ht[i]:.0f} s{many}", tuple(hp[i]), style,
                                           float(hover_r[i]), short=f"{i + 1}{many}"))  # fmt: skip
            looped = bool(np.any(passes > 1))
            handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="tab:orange",
                                  markeredgecolor="k",
                                  label="hover point: order · seconds"
                                  + (" ×passes (DO_JUMP)" if looped else "")))  # fmt: skip
    # placing order: short sensors' "x of y Mbit", hover points, then sensor ids
    n_short = sum(not lab.optional for lab in scene.labels)
    scene.labels[n_short:n_short] = hover_labels
    _draw_ends(ax, map, hp, hover_r, scene, handles)
    if title is None:
        title = f"map '{spec.name}'"
        if view is not None and view.get("f") is not None:
            title += f"  (f = {float(view['f']):.6g})"
    if far_km is not None:
        title = _far_title(title, f"the mission lies {far_km:,.1f} km", ax)
    ax.set_title(title)
    ends: list[tuple[Any, float]] = []
    if ax_t is not None:
        ends = _data_panel(ax_t, timeline, map, None if visits is None else visits.number)
    if ax_b is not None:
        _bars_panel(ax_b, timeline, map)
    _finish_map(fig, ax, W, handles, scene, len(sensors), named_below=ax_b is not None
                and len(sensors) <= BARS, unlabelled=unlabelled)  # fmt: skip
    if ends:  # the layout is fixed: the end labels are spread apart in its pixels
        _spread_end_labels(ax_t, ends)
    return fig


def _share(data: Any, required: Any) -> np.ndarray:
    """Data collected as a share of the requirement, %: `data` (Mbit; (..., J) against
    `required` (J,), or any shape against one sensor's scalar); a sensor that requires
    nothing is at 100 %."""
    required = np.asarray(required, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(required > 0, 100.0 * np.asarray(data, dtype=float)
                        / np.maximum(required, 1e-300), 100.0)  # fmt: skip


def _bends(t: np.ndarray, y: np.ndarray, tol: Any, rtol: float = 1e-9) -> list[np.ndarray]:
    """For each column of `y`, the samples its polyline over `t` needs: the first and the last,
    and the ends of every interval where the column changes, except where two such intervals
    in a row have the same slope (within `rtol`). Through those only it draws the same line
    as through every sample: where a column does not change it is flat, and a sample dropped
    inside a straight run is checked to lie within `tol` of the thinned line (a column where
    one does not keeps every interval's ends). NaN and jumps (a change in no time) keep their
    samples. A replay's data is flat while flying and rises straight while hovering
    (`sim.replay`), so tens of thousands of samples per sensor come down to a few. Cost: two
    passes over `y`, then O(changes log changes) for the changing (interval, column) pairs.

    Args:
        t: (n,) sample times, s, non-decreasing.
        y: (n, J) each column's value at each sample.
        tol: the largest distance of a dropped sample from the thinned line, in units of `y`
            (a scalar, or (J,) one per column).
        rtol: slopes this close (relative) are one straight run.

    Returns:
        J increasing index arrays into the samples, each starting at 0 and ending at n - 1.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float).reshape(len(t), -1)
    n, J = y.shape
    if n <= 2:
        return [np.arange(n) for _ in range(J)]
    dt = np.diff(t)
    dy = np.diff(y, axis=0)
    r, c = np.nonzero(dy)  # the (interval, column) pairs that change: NaN included
    if not len(r):  # no column changes (no sensor gets data): each line its two ends
        return [np.array([0, n - 1]) for _ in range(J)]
    order = np.lexsort((r, c))  # by column, then time
    r, c = r[order], c[order]
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = dy[r, c] / dt[r]  # not finite for a jump or a NaN: never straight
    tols = np.broadcast_to(np.asarray(tol, dtype=float), (J,))
    # straight[m]: pair m and m + 1 are adjacent intervals of one column with the same slope
    straight = ((c[1:] == c[:-1]) & (r[1:] == r[:-1] + 1) & np.isfinite(slope[1:])
                & np.isfinite(slope[:-1]) & (np.abs(slope[1:] - slope[:-1])
                <= rtol * np.maximum(np.abs(slope[1:]), np.abs(slope[:-1]))))  # fmt: skip

    def vertices(straight: np.ndarray) -> np.ndarray:
        """The sorted keys column * n + sample of every column's vertices."""
        ends = np.r_[~straight, True]  # interval m's end, unless the run goes on straight
        starts = np.r_[True, ~straight]
        cols = np.arange(J) * n
        return np.unique(np.concatenate([cols, cols + n - 1, c[starts] * n + r[starts],
                                         c[ends] * n + r[ends] + 1]))  # fmt: skip

    keys = vertices(straight)
    inner = np.flatnonzero(straight)  # the samples dropped: the end of interval m
    if len(inner):
        at = c[inner] * n + r[inner] + 1
        hi = np.searchsorted(keys, at)
        k0, k1 = keys[hi - 1] - c[inner] * n, keys[hi] - c[inner] * n
        w = (t[r[inner] + 1] - t[k0]) / np.maximum(t[k1] - t[k0], 1e-300)
        line = y[k0, c[inner]] + w * (y[k1, c[inner]] - y[k0, c[inner]])
        far = np.abs(line - y[r[inner] + 1, c[inner]]) > tols[c[inner]]
        if far.any():  # not straight within tol: that column keeps every interval's ends
            straight = straight & ~np.isin(c[:-1], c[inner][far])
            keys = vertices(straight)
    cols = keys // n
    return np.split(keys - cols * n, np.cumsum(np.bincount(cols, minlength=J))[:-1])


def _tightest(final: np.ndarray, k: int) -> list[int]:
    """The indices of the `k` smallest final shares (ties: map order), smallest first."""
    return sorted(range(len(final)), key=lambda j: (float(final[j]), j))[:k]


def _series_colour(k: int) -> Any:
    """The k-th named series' colour (tab10; beyond 10 the cycle repeats, see `_series_dash`)."""
    from matplotlib import colormaps

    return colormaps["tab10"](k % 10)


def _series_dash(k: int) -> str:
    """The k-th named series' line style: solid for the first 10, then dashed, dotted, ..."""
    return ("-", "--", ":", "-.")[(k // 10) % 4]


def _hover_run_numbers(timeline: Any, number: Any, n_runs: int) -> np.ndarray:
    """The number to show on each of the `n_runs` runs of hover samples of a replay: that of
    the hover point of the run's first visit (`number`, per visit: `_Visits.number`). Hover
    visits with no leg of positive time between them (a loop of one hover point) are one run
    of samples. Without `number`, or should the runs not match the visits, 1..n_runs."""
    plain = np.arange(1, n_runs + 1)
    route = getattr(timeline, "route", None)
    if number is None or route is None:
        return plain
    stops = np.flatnonzero(np.asarray(route.is_hover, dtype=bool))
    moved = np.cumsum(np.asarray(timeline.leg_times, dtype=float) > 0.0)
    starts = np.ones(len(stops), dtype=bool)
    starts[1:] = moved[stops[1:]] > moved[stops[:-1]]
    first = np.flatnonzero(starts)
    number = np.asarray(number).reshape(-1)
    if len(first) != n_runs or len(number) != len(stops):
        return plain
    return number[first]


def _data_panel(ax: Any, timeline: Any, map_: Any,
                number: Any = None) -> list[tuple[Any, float]]:  # fmt: skip
    """Each sensor's data collected along the mission time, as a share of its requirement
    (the simulator's replay samples); the requirement is the 100 % line, drawn over the
    mission's time (not under the end labels). The `TIME_LINES` sensors with the smallest
    final share are drawn in distinct colours and named at the end (their labels spread apart
    once the layout is fixed: `_spread_end_labels`); the others are thin grey lines, counted in
    the panel. The hovers are shaded, one collection (spans less than 1/`SHADE_CELLS` of the
    mission time apart drawn as one), and numbered as on the map (`number`: the map's number of
    each hover visit; numbers thinned where they touch). A mission that gives no sensor any data
    (no hover point, none in range) or a map that requires none says so in the panel's title.

    Returns:
        The end labels (Annotations) and the share each names, %, as (label, share) pairs.
    """
    from matplotlib.collections import LineCollection, PolyCollection

    t = np.asarray(timeline.t, dtype=float)
    data = np.asarray(timeline.data, dtype=float)
    required = np.asarray(map_.required_data, dtype=float)
    ids = list(timeline.sensor_ids)
    # each sensor's line through the samples where it bends only (`_bends`: the same line to
    # within 1e-6 % of its requirement, a few vertices instead of every sample)
    bends = _bends(t, data, np.where(required > 0, 1e-8 * required, np.inf))
    lines = [np.column_stack([t[k], _share(data[k, j], required[j])])
             for j, k in enumerate(bends)]  # fmt: skip
    final = _share(data[-1], required)
    top = max(110.0, float(np.nanmax(np.concatenate([ln[:, 1] for ln in lines]))) * 1.05)
    named = _tightest(final, TIME_LINES)
    others = [j for j in range(len(ids)) if j not in set(named)]
    if others:  # the grey lines, one collection
        ax.add_collection(LineCollection([lines[j] for j in others], linewidths=0.7,
                                         colors="0.7", zorder=1))  # fmt: skip
    ends: list[tuple[Any, float]] = []
    for k, j in enumerate(named):  # smallest final share first
        colour = _series_colour(k)
        ax.plot(lines[j][:, 0], lines[j][:, 1], linewidth=1.2, color=colour,
                linestyle=_series_dash(k), zorder=2)  # fmt: skip
        # a thin line joins a label moved off its line's end to it (`_spread_end_labels`)
        label = ax.annotate(f"{ids[j]} {final[j]:.0f} %", (t[-1], final[j]),
                            xytext=(t[-1] + 0.01 * (t[-1] - t[0]), final[j]), fontsize=7.5,
                            color=colour, va="center", annotation_clip=False, ha="left",
                            arrowprops={"arrowstyle": "-", "color": colour, "linewidth": 0.6,
                                        "shrinkA": 0.0, "shrinkB": 0.0,
                                        "relpos": (0.0, 0.5)})  # fmt: skip
        label.arrow_patch.set_visible(False)
        ends.append((label, float(final[j])))
    title = "data collected over the mission (simulator replay; shaded: hovering)"
    hover = np.asarray(timeline.phase) == "hover"
    if np.all(required <= 0):
        title += "\nevery sensor requires 0 Mbit: each is at 100 % from the start"
    elif not np.any(data[-1][required > 0] > 0):
        title += ("\nno sensor got any data: "
                  + ("the mission has no hover point (LOITER)" if not hover.any()
                     else "none within range of a hover point"))  # fmt: skip
    if others:
        lo, hi = float(final[others].min()), float(final[others].max())
        title += (f"\ngrey: {len(others)} more sensors, each {lo:.0f}-{hi:.0f} % at the end"
                  + (" (all named below)" if len(ids) <= BARS else ""))  # fmt: skip
    ax.plot([t[0], t[-1]], [100.0, 100.0], color="k", linestyle="--", linewidth=1.0)
    ax.text(t[0], 101.0, "required", fontsize=7.5, va="bottom")
    if hover.any():  # shade the hovers, numbered like the map (numbers thinned where they touch)
        edges = np.flatnonzero(np.diff(np.r_[0, hover.astype(int), 0]))
        lo, hi = t[edges[::2]], t[edges[1::2] - 1]
        # one collection, at most SHADE_CELLS spans: a DO_JUMP loop hovers thousands of times
        total = max(float(t[-1] - t[0]), 1e-9)
        g = np.flatnonzero(np.r_[True, lo[1:] - hi[:-1] >= total / SHADE_CELLS])
        ax.add_collection(PolyCollection(
            [((a, 0.0), (a, 1.0), (b, 1.0), (b, 0.0))
             for a, b in zip(lo[g], np.maximum.reduceat(hi, g), strict=True)],
            transform=ax.get_xaxis_transform(), color="tab:orange", alpha=0.15, linewidth=0),
            autolim=False)  # fmt: skip
        shown = _hover_run_numbers(timeline, number, len(lo))
        span = total * 1.1
        width_in = ax.figure.get_size_inches()[0] - 1.6
        last = -np.inf
        for k, (a, b) in enumerate(zip(lo, hi, strict=True)):
            x = (a + b) / 2
            label = str(int(shown[k]))
            gap = (len(label) + 1.5) * 7 * 0.6 / 72.0 * span / width_in  # in seconds
            if x - last >= gap or k == 0:
                ax.text(x, 3.0, label, fontsize=7, ha="center", color="saddlebrown")
                last = x
    # room at the right for the end labels: a tenth of the axis, or what the longest label
    # takes on a narrow figure (a tall map's: "S3 104 %" ran over the frame)
    total = max(float(t[-1] - t[0]), 1e-9)
    width_in = max(ax.figure.get_size_inches()[0] - 1.6, 1.0)
    label_in = max((len(f"{ids[j]} {final[j]:.0f} %") for j in named), default=0) \
        * 7.5 * 0.6 / 72.0 + 0.05
    room = min(label_in / width_in, 0.5)  # the labels' share of the axis, at most half
    ax.set_xlim(t[0], t[0] + max(1.1 * total, 1.01 * total / (1.0 - room)))
    ax.set_ylim(-0.02 * top, top)  # a line at 0 % (no data) above the frame, not under it
    ax.set_xlabel("mission time (s)")
    ax.set_ylabel("collected / required (%)")
    ax.set_title(_fitted(ax, title, 9.0), fontsize=9)
    return ends


def _spread(targets: np.ndarray, heights: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Centres for labels of `heights` wanted at `targets` (display pixels along one axis),
    in the targets' order, neighbours at least their mean height apart, all inside [lo, hi]:
    the least-squares nearest such centres (pool adjacent violators on target - offset, then
    the whole stack clamped into the range; where it does not fit, it starts at lo and runs
    past hi). O(n log n).

    Args:
        targets: (n,) where each label's centre is wanted, px.
        heights: (n,) each label's height, px, gaps included.
        lo, hi: the range the labels' boxes should stay inside, px.

    Returns:
        (n,) the centres, px, in the order of `targets`.
    """
    targets = np.asarray(targets, dtype=float)
    order = np.argsort(targets, kind="stable")
    h = np.asarray(heights, dtype=float)[order]
    offset = np.r_[0.0, np.cumsum((h[1:] + h[:-1]) / 2.0)]  # each centre above the first's
    blocks: list[list[float]] = []  # [sum, count] of runs pooled to their mean
    for v in targets[order] - offset:
        blocks.append([float(v), 1.0])
        while len(blocks) > 1 and blocks[-2][0] * blocks[-1][1] > blocks[-1][0] * blocks[-2][1]:
            total, count = blocks.pop()
            blocks[-1][0] += total
            blocks[-1][1] += count
    z = np.concatenate([np.full(int(c), s / c) for s, c in blocks])
    first = lo + h[0] / 2.0
    z = np.clip(z, first, max(hi - h[-1] / 2.0 - offset[-1], first))
    out = np.empty_like(z)
    out[order] = z + offset
    return out


#: the smallest font (points) the data panel's end labels shrink to where they do not fit
#: its height at 7.5 points (a figure made small with `figsize`)
_END_FONT_MIN = 5.0


def _spread_end_labels(ax: Any, ends: Sequence[tuple[Any, float]]) -> None:
    """Move the data panel's end labels (`_data_panel`: (label, share %) pairs) apart
    vertically so that no two overlap and each stays inside the panel's frame, each as near
    its line's end as that allows (`_spread`), in display pixels of the fixed layout; a label
    moved off its line's end is joined to it by a thin line. Where the labels do not fit the
    panel's height their font shrinks (to `_END_FONT_MIN`). Cost O(n log n) for n <= `TIME_LINES`
    labels, each measured once or twice.

    Args:
        ax: the data panel, its layout fixed.
        ends: the end labels and the share each names, %.
    """
    from matplotlib.text import Text

    renderer = ax.figure.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    gap = 1.0 * ax.figure.dpi / 72.0  # a point between two labels

    def heights() -> np.ndarray:  # the text's own box, not its (hidden) line's
        return np.array([Text.get_window_extent(lab, renderer).height + gap
                         for lab, _ in ends])  # fmt: skip

    h = heights()
    if h.sum() > frame.height:  # too many for the panel's height at this size: smaller
        size = float(ends[0][0].get_fontsize())
        small = max(size * frame.height / h.sum(), _END_FONT_MIN)
        for lab, _ in ends:
            lab.set_fontsize(small)
        h = heights()
    x_end = ends[0][0].xy[0]
    targets = ax.transData.transform([(x_end, share) for _, share in ends])[:, 1]
    centres = _spread(targets, h, frame.y0, frame.y1)
    inverse = ax.transData.inverted()
    for (lab, _), y, target, height in zip(ends, centres, targets, h, strict=True):
        lab.xyann = (lab.xyann[0], float(inverse.transform((0.0, y))[1]))
        lab.arrow_patch.set_visible(abs(y - target) > 0.6 * height)  # off its line's end


def _bars_panel(ax: Any, timeline: Any, map_: Any) -> None:
    """Every sensor named with its final share of its requirement, as bars sorted from the
    smallest share (coloured as on the map); the `TIME_LINES` named in the panel above carry
    their line's colour. Past `BARS` sensors the rest (the largest shares) are summarised as
    count, min, median and max."""
    from matplotlib import colormaps

    final = _share(np.asarray(timeline.data)[-1], map_.required_data)
    ids = list(timeline.sensor_ids)
    order = _tightest(final, len(ids))
    shown, rest = order[:BARS], order[BARS:]
    cmap = colormaps["RdYlGn"]
    x = np.arange(len(shown))
    vals = final[shown]
    ax.bar(x, vals, color=[cmap(float(np.clip(v / 100.0, 0, 1))) for v in vals],
           edgecolor="0.3", linewidth=0.4, width=0.8)  # fmt: skip
    ax.axhline(100.0, color="k", linestyle="--", linewidth=1.0)
    ax.set_xticks(x, [ids[j] for j in shown], rotation=90, fontsize=6.5 if len(shown) > 30 else 7.5)
    colours = {j: _series_colour(k) for k, j in enumerate(_tightest(final, TIME_LINES))}
    for tick, j in zip(ax.get_xticklabels(), shown, strict=True):
        if j in colours:
            tick.set_color(colours[j])
            tick.set_fontweight("bold")
    ax.set_xlim(-0.7, max(len(shown), 10) - 0.3)
    ax.set_ylim(0, max(110.0, float(vals.max()) * 1.08))
    ax.set_ylabel("at the end (%)")
    title = "data collected / required at the end, by sensor (smallest share first)"
    if rest:
        r = final[rest]
        title += (f"; {len(rest)} more: min {r.min():.0f} %, median {np.median(r):.0f} %, "
                  f"max {r.max():.0f} %")  # fmt: skip
    ax.set_title(_fitted(ax, title, 9.0), fontsize=9)


def _fitted(ax: Any, text: str, fontsize: float) -> str:
    """`text` with each of its lines wrapped to the figure's width (an estimate: 0.55 em a
    character), so that a narrow figure's (a tall map's) panel titles stay inside it; explicit
    line breaks, which the layout makes room for (matplotlib's own wrap is done at draw time,
    after the layout, and the wrapped lines ran into the panel above)."""
    import textwrap

    chars = max(int(ax.figure.get_size_inches()[0] * 72.0 / (0.55 * fontsize)), 20)
    return "\n".join(textwrap.fill(line, chars) for line in text.split("\n"))


def check_dpi(dpi: Any, name: str = "dpi") -> int:
    """`dpi` if it is an integer in 1..`MAX_DPI`.

    Args:
        dpi: the resolution asked for, dots per inch.
        name: the option's name in the message (e.g. "--dpi").

    Returns:
        `dpi` as an int.

    Raises:
        ValueError: one line naming `name`, for a bool, a non-integer or a value outside
            1..MAX_DPI.
    """
    if isinstance(dpi, bool) or not isinstance(dpi, (int, np.integer)) \
            or not 1 <= dpi <= MAX_DPI:
        raise ValueError(f"{name}: must be an integer from 1 to {MAX_DPI} dots per inch (the "
                         f"image's memory grows as its square), got {dpi!r}")
    return int(dpi)


#: the salt of an SVG's element ids (matplotlib's rcParam `svg.hashsalt`, random per save when
#: unset), fixed so that the same figure saves to the same bytes
SVG_HASHSALT = "lamde-mission"


def figure_bytes(fig: Any, fmt: str, *, dpi: int) -> bytes:
    """Render `fig` in memory as PNG or SVG, the same figure always to the same bytes.

    An SVG carries no date (matplotlib writes the time of saving as `<dc:date>` unless told
    not to) and its clip-path ids are hashed with `SVG_HASHSALT` instead of a random salt; the
    rcParam is set for this save only (`matplotlib.rc_context`), not for the caller's session.

    Args:
        fig: a matplotlib Figure.
        fmt: "png" or "svg".
        dpi: dots per inch (not checked here: `check_dpi`).

    Returns:
        The image file's bytes.

    Raises:
        ValueError: `fmt` is neither "png" nor "svg".
    """
    import matplotlib

    if fmt not in ("png", "svg"):
        raise ValueError(f"image format must be png or svg, got {fmt!r}")
    metadata = {"Date": None} if fmt == "svg" else None
    buf = io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": SVG_HASHSALT}):
        fig.savefig(buf, format=fmt, dpi=dpi, metadata=metadata)
    return buf.getvalue()


def save_figure(fig: Any, path: str | Path, *, dpi: int = 150) -> Path:
    """Render `fig` to PNG or SVG by suffix (`figure_bytes`: the same figure, the same bytes) and
    write it atomically (no partial file).

    Memory and time grow as the figure's area times dpi^2 (`MAX_DPI`).

    Args:
        fig: a matplotlib Figure.
        path: the image file, .png or .svg.
        dpi: dots per inch, 1..MAX_DPI.

    Returns:
        The path written.

    Raises:
        ValueError: one line, a suffix other than .png/.svg or `dpi` outside 1..MAX_DPI.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in IMAGE_SUFFIXES:
        raise ValueError(f"{path}: image format must be PNG or SVG (suffix .png or .svg)")
    check_dpi(dpi)
    return write_bytes_atomic(path, figure_bytes(fig, suffix[1:], dpi=dpi))


def plot_mission(
    map: Any,  # noqa: A002
    out: str | Path,
    *,
    timeline: Any = None,
    plan: Any = None,
    title: str | None = None,
    dpi: int = 150,
) -> Path:
    """Draw `map` (with a replayed `timeline` or a `plan`, if given) and save it to `out`.

    Args:
        map: the map (`planner_core.model.mapio.load_map`).
        out: the image file, .png or .svg.
        timeline: the simulator's replay of the stored mission (`sim.replay`), or None.
        plan: a plan (hover points, m; hover times, s), used when there is no timeline.
        title: the title (default: the map's name and f).
        dpi: dots per inch, 1..MAX_DPI.

    Returns:
        The path written.

    Raises:
        ValueError: a suffix other than .png/.svg, or `dpi` outside 1..MAX_DPI.
    """
    if Path(out).suffix.lower() not in IMAGE_SUFFIXES:
        raise ValueError(f"{out}: image format must be PNG or SVG (suffix .png or .svg)")
    fig = mission_figure(map, timeline=timeline, plan=plan, title=title)
    return save_figure(fig, out, dpi=dpi)


# ----------------------------------------------------------------------------- fleets


#: the line style of sortie j (1-based) of a vehicle, `sortie_style(j)`: matplotlib's solid,
#: dashed, dash-dot and dotted, then long dashes, dash-dot-dot, sparse dots and paired short
#: dashes (dash patterns in line widths, each period within the legend's sample line). A
#: vehicle's sorties 9, 10, ... take them again; the legend names every sortie number that
#: shares a style ("sorties 1, 9"), and the hover labels "sortie.order" tell them apart
SORTIE_STYLES: tuple[Any, ...] = ("-", "--", "-.", ":", (0, (6.0, 1.5)),
                                  (0, (3.0, 1.2, 1.0, 1.2, 1.0, 1.2)), (0, (1.0, 3.0)),
                                  (0, (2.0, 1.0, 2.0, 4.0)))  # fmt: skip


def sortie_style(sortie: int) -> Any:
    """The line style of a vehicle's sortie number `sortie` (1-based): SORTIE_STYLES, again
    from sortie len(SORTIE_STYLES) + 1 on.

    Args:
        sortie: the sortie's number, 1-based.

    Returns:
        A matplotlib linestyle (a name or an (offset, dashes) pair).
    """
    return SORTIE_STYLES[(int(sortie) - 1) % len(SORTIE_STYLES)]


def _style_label(first: int, most: int) -> str:
    """The legend's words for style `first` (1-based) when a vehicle flies up to `most`
    sorties: "sortie 3", or every sortie sharing it, "sorties 1, 9, 17" (past four numbers,
    the first three, "...", and the last)."""
    share = list(range(first, most + 1, len(SORTIE_STYLES)))
    if len(share) == 1:
        return f"sortie {first}"
    shown = [str(j) for j in share] if len(share) <= 4 else \
        [*(str(j) for j in share[:3]), "...", str(share[-1])]
    return "sorties " + ", ".join(shown)


@dataclass(frozen=True)
class SortieView:
    """One sortie to draw: vehicle and sortie numbers (1-based), the simulator's replay of its
    mission on the whole map, and the names of the depots it leaves and lands at (None:
    unnamed)."""

    vehicle: int
    sortie: int
    timeline: Any
    depot_start: str | None = None
    depot_end: str | None = None


def _vehicle_colour(vehicle: int) -> Any:
    from matplotlib import colormaps

    return colormaps["tab10"]((vehicle - 1) % 10)


def _map_depots(map: Any) -> list[tuple[str, tuple[float, float]]]:  # noqa: A002
    """The map's depots as the sortie planner names them (`FleetSettings`: `fleet.depots`, or
    "home" and, where it differs, "end"), with their positions (m)."""
    from planner_core.fleet import FleetSettings

    st = FleetSettings.from_map(map)
    return [(n, (float(x), float(y))) for n, (x, y) in zip(st.depot_names, st.depots,
                                                            strict=True)]  # fmt: skip


def fleet_figure(
    map: Any,  # noqa: A002
    sorties: Sequence[SortieView],
    *,
    title: str | None = None,
    figsize: tuple[float, float] | None = None,
) -> Any:
    """A matplotlib Figure of `map` with every sortie of a fleet, each replayed by the sim.

    One colour per vehicle (tab10), one line style per sortie of a vehicle (`sortie_style`:
    solid, dashed, dash-dot, dotted and four dash patterns; a vehicle's sorties 9, 10, ... take
    them again, the legend naming each style's sorties), arrows along each leg, hover points in
    the vehicle's colour labelled "sortie.order · seconds" (up to 40 hover points in all; past
    40 left out where crowded, past `HOVER_LABELS` unlabelled; "×k" on one a DO_JUMP loop visits
    k times: each distinct leg, hover point and corner is drawn once, `_visits`), detour corners
    (NAV_WAYPOINT, flown through) as white diamonds edged in it, the parts of legs inside
    obstacles (C5) in red; depots (where sorties take off and land) as black-edged hexagons with
    their names, the map's depots no sortie uses as lighter grey ones (named beside them and in
    the legend), and each battery swap (a vehicle landing from sortie j and leaving on
    sortie j + 1) as a star in the vehicle's colour with "v1 swap 1"; a depot's label is placed
    where it cannot be read as a nearby depot's (`_Label.rivals`). Sensors are coloured by the
    data collected over all sorties together (C4 over the whole plan). A sortie that lies
    thousands of km from the map's area (`sim.replay.far_distance`: the wrong map, or another
    origin) is not drawn, so the view stays on the map; the title says which and how far.
    Cost: O(sorties x samples) to read the replays, a few collections per sortie (its distinct
    legs' arrows, hover points and corners) and at most `HOVER_LABELS` hover labels.

    Args:
        map: the map the sorties fly on.
        sorties: the sorties, each with its replay (`SortieView`).
        title: the figure's title (default: map, vehicles, sorties, swaps).
        figsize: inches (default: from the area's shape).

    Returns:
        The Figure (Agg canvas).

    Raises:
        ValueError: no sorties.
    """
    from matplotlib.lines import Line2D

    if not sorties:
        raise ValueError("no sorties to draw")
    spec = map.spec
    W = spec.area.width
    fig, ax, _ax_t, _ax_b, handles = _map_axes(map, has_time=False, figsize=figsize)
    scene = _new_scene()
    _draw_obstacles(ax, map, handles)
    collected = np.sum([np.asarray(sv.timeline.collected, dtype=float) for sv in sorties], axis=0)
    sensors = _draw_sensors(fig, ax, map, collected, handles, scene)
    far = {id(sv): km for sv in sorties if (km := _far_km(sv.timeline, map)) is not None}
    shown = [sv for sv in sorties if id(sv) not in far]  # drawn: near the map's area
    visits = [_timeline_visits(sv.timeline) for sv in shown]  # each distinct thing once
    n_hover = sum(len(v.hover_points) for v in visits)
    labelled = 0
    bad: list[float] = []  # lengths (m) of the parts of legs inside obstacles, all sorties
    n_corner = 0
    vehicles = sorted({sv.vehicle for sv in sorties})
    for sv, vis in zip(shown, visits, strict=True):
        colour = _vehicle_colour(sv.vehicle)
        style = sortie_style(sv.sortie)
        lengths, radius = _draw_route(ax, scene, map, vis, sv.timeline.return_leg,
                                      colour=colour, linestyle=style, arrow_scale=12,
                                      return_width=1.0, corner_edge=[colour],
                                      hover_face=[colour], hover_alpha=0.8)  # fmt: skip
        bad.extend(lengths)
        n_corner += len(vis.corners)
        hp, ht = vis.hover_points, vis.hover_times
        if len(hp):
            style = {"fontsize": 7.5, "color": colour, "fontweight": "bold", "zorder": 8,
                     "bbox": _TEXT_BOX}  # fmt: skip
            for i in range(min(len(hp), HOVER_LABELS - labelled)):
                # past 40 hover points in all, a hover label may be left out where crowded
                many = _passes_text(vis.passes[i])
                scene.labels.append(_Label(f"{sv.sortie}.{i + 1} · {ht[i]:.0f} s{many}",
                                           tuple(hp[i]), style, float(radius[i]), n_hover > 40,
                                           f"{sv.sortie}.{i + 1}{many}"))  # fmt: skip
                labelled += 1
    bad_total = sum(bad)
    if bad_total > 0:
        handles.append(
            Line2D(
                [],
                [],
                color="red",
                linewidth=4,
                label=f"path inside obstacles (C5): {bad_total:.0f} m",
            )
        )
    # depots: every take-off and landing position, named as fleet.json names them; a named
    # depot of the map is drawn once, at the depot, each vehicle's own pad beside it (a
    # vehicle's pad: planner_core.model.pads) as a small square in the vehicle's colour
    where = dict(_map_depots(map))
    depots: dict[tuple[float, float], set[str]] = {}
    pads: dict[tuple[float, float], int] = {}
    for sv in sorties:
        p = np.asarray(sv.timeline.path, dtype=float)
        for xy, name in ((p[0], sv.depot_start), (p[-1], sv.depot_end)):
            home = where.get(name) if name else None
            if id(sv) in far:  # not drawn: only the map's depot it names
                if home is not None:
                    depots.setdefault((round(home[0], 1), round(home[1], 1)), set()).add(name)
                continue
            if home is not None and np.hypot(xy[0] - home[0], xy[1] - home[1]) > 1.0:
                pads[(round(float(xy[0]), 1), round(float(xy[1]), 1))] = sv.vehicle
                xy = home
            key = (round(float(xy[0]), 1), round(float(xy[1]), 1))
            depots.setdefault(key, set())
            if name:
                depots[key].add(name)
    # the map's other depots, where no sortie takes off or lands: lighter, named in the legend
    used = {n for names in depots.values() for n in names}
    idle = [(name, xy) for name, xy in _map_depots(map) if name not in used and not any(
        np.hypot(xy[0] - x, xy[1] - y) <= 1.0 for x, y in depots)]  # fmt: skip
    # every depot's marker: a depot's label (and a swap's there) must not read as another's
    depot_xy = np.array([*depots, *(xy for _, xy in idle)], dtype=float).reshape(-1, 2)

    def rivals(xy: Any) -> np.ndarray:
        return depot_xy[np.hypot(*(depot_xy - np.asarray(xy, dtype=float)).T) > 1.0]

    for (x, y), names in depots.items():
        ax.plot(x, y, marker="h", markersize=14, color="white", markeredgecolor="k",
                markeredgewidth=1.6, zorder=7, linestyle="")  # fmt: skip
        scene.marker((x, y), 7.5)
        if names:
            scene.labels.append(_Label(" / ".join(sorted(names)), (x, y),
                                       {"fontsize": 8, "fontweight": "bold", "zorder": 9,
                                        "bbox": _TEXT_BOX}, 7.5,
                                       rivals=rivals((x, y))))  # fmt: skip
    for (x, y), v in pads.items():  # above the swap stars and depots drawn there
        ax.plot(x, y, marker="s", markersize=6, color=_vehicle_colour(v), markeredgecolor="k",
                markeredgewidth=0.8, zorder=8.5, linestyle="")  # fmt: skip
        scene.labels.append(_Label(f"v{v} pad", (x, y), {"fontsize": 6.5, "zorder": 9,
                                                         "color": _vehicle_colour(v),
                                                         "bbox": _TEXT_BOX}, 3.0))  # fmt: skip
    for name, (x, y) in idle:
        ax.plot(x, y, marker="h", markersize=12, color="0.93", markeredgecolor="0.55",
                markeredgewidth=1.0, zorder=5, linestyle="")  # fmt: skip
        scene.marker((x, y), 6.5)
        scene.labels.append(_Label(name, (x, y), {"fontsize": 7.5, "color": "0.45", "zorder": 9,
                                                  "bbox": _TEXT_BOX}, 6.5,
                                   rivals=rivals((x, y))))  # fmt: skip
    # swaps: a vehicle lands from sortie j and leaves on sortie j + 1
    swaps = stars = 0  # the swaps, and the stars drawn (none for a sortie not drawn)
    by_vehicle: dict[int, list[SortieView]] = {}
    for sv in sorties:
        by_vehicle.setdefault(sv.vehicle, []).append(sv)
    # one label per place: several swaps at one depot ("v1 swaps 1, 2; v3 swap 1") overlapped
    # as labels of their own
    here: dict[tuple[float, float], list[tuple[int, int]]] = {}
    leave: dict[tuple[float, float], list[tuple[int, int]]] = {}
    for v, svs in by_vehicle.items():
        svs = sorted(svs, key=lambda s: s.sortie)
        for j, (a, b) in enumerate(zip(svs[:-1], svs[1:], strict=True), start=1):
            at = np.asarray(a.timeline.path, dtype=float)[-1]
            swaps += 1
            if id(a) in far or id(b) in far:  # counted, not drawn: off the map's view
                continue
            stars += 1
            ax.plot(*at, marker="*", markersize=15, color=_vehicle_colour(v),
                    markeredgecolor="k", zorder=8, linestyle="")  # fmt: skip
            scene.marker(at, 7.5)
            # the label at the depot (the vehicles' pads around it share it)
            label_at = where.get(a.depot_end, at) if a.depot_end else at
            here.setdefault((round(float(label_at[0])), round(float(label_at[1]))),
                            []).append((v, j))
            off = np.asarray(b.timeline.path, dtype=float)[0]
            if a.depot_end != b.depot_start or (not a.depot_end
                                                and not np.allclose(at, off, atol=1.0)):
                leave_at = where.get(b.depot_start, off) if b.depot_start else off
                leave.setdefault((round(float(leave_at[0])), round(float(leave_at[1]))),
                                 []).append((v, j))
    for places, tail in ((here, ""), (leave, " (takes off here)")):
        for xy, who in places.items():
            colours = {_vehicle_colour(v) for v, _ in who}
            style = {"fontsize": 7.5, "color": colours.pop() if len(colours) == 1 else "k",
                     "zorder": 9, "bbox": _TEXT_BOX}  # fmt: skip
            scene.labels.append(_Label(_swap_text(who) + tail, (float(xy[0]), float(xy[1])),
                                       style, 7.5, rivals=rivals(xy)))  # fmt: skip
    for v in vehicles:
        n = len(by_vehicle[v])
        handles.append(
            Line2D(
                [],
                [],
                color=_vehicle_colour(v),
                linewidth=2.2,
                label=f"vehicle {v}: {counted(n, 'sortie')}",
            )
        )
    most = max(len(svs) for svs in by_vehicle.values())
    for j in range(1, min(most, len(SORTIE_STYLES)) + 1):  # every style a sortie flies
        handles.append(
            Line2D(
                [],
                [],
                color="0.2",
                linewidth=1.6,
                linestyle=sortie_style(j),
                label=_style_label(j, most),
            )
        )
    handles.append(
        Line2D(
            [],
            [],
            marker="h",
            linestyle="",
            markersize=11,
            markerfacecolor="white",
            markeredgecolor="k",
            label="depot",
        )
    )
    if pads:
        handles.append(Line2D([], [], marker="s", linestyle="", markersize=6,
                              markerfacecolor=_vehicle_colour(min(pads.values())),
                              markeredgecolor="k",
                              label="vN pad: vehicle N's own pad"))
    if idle:
        handles.append(Line2D([], [], marker="h", linestyle="", markersize=10,
                              markerfacecolor="0.93", markeredgecolor="0.55",
                              label="depot no sortie uses: "
                              + ", ".join(n for n, _ in idle)))  # fmt: skip
    if stars:
        handles.append(Line2D([], [], marker="*", linestyle="", markersize=13,
                              markerfacecolor="0.6", markeredgecolor="k",
                              label="battery swap"))  # fmt: skip
    handles.append(
        Line2D(
            [],
            [],
            marker="o",
            linestyle="",
            markerfacecolor="0.6",
            markeredgecolor="k",
            label="hover point: sortie.order · seconds"
            + (" ×passes (DO_JUMP)" if any(np.any(v.passes > 1) for v in visits) else ""),
        )
    )
    if n_corner:
        handles.append(Line2D([], [], marker="D", linestyle="", markerfacecolor="white",
                              markeredgecolor="0.2",
                              label=f"corner, flown through ({n_corner})"))  # fmt: skip
    if title is None:
        nv = len(vehicles)
        title = (f"map '{spec.name}': {counted(nv, 'vehicle')}, "
                 f"{counted(len(sorties), 'sortie')}, {counted(swaps, 'swap')}")  # fmt: skip
    if far:
        names = [f"{sv.vehicle}.{sv.sortie}" for sv in sorties if id(sv) in far]
        what = ("every sortie lies" if len(names) == len(sorties) > 1
                else f"sortie {names[0]} lies" if len(names) == 1
                else f"sorties {first_few(names)} lie")  # fmt: skip
        km = min(far.values())
        title = _far_title(title, f"{what} {km:,.1f} km{' or more' if len(far) > 1 else ''}", ax)
    ax.set_title(title)
    _finish_map(fig, ax, W, handles, scene, len(sensors), named_below=False,
                unlabelled=n_hover - labelled)
    return fig


def plot_fleet(
    map: Any,  # noqa: A002
    out: str | Path,
    sorties: Sequence[SortieView],
    *,
    title: str | None = None,
    dpi: int = 150,
) -> Path:
    """Draw every sortie of a fleet on `map` (`fleet_figure`) and save it to `out` (.png/.svg).

    Args:
        map: the map the sorties fly on.
        out: the image file (written atomically).
        sorties: the replayed sorties.
        title: the figure's title (default: map, vehicles, sorties, swaps).
        dpi: PNG resolution.

    Returns:
        The path written.

    Raises:
        ValueError: a suffix other than .png/.svg, or no sorties.
    """
    if Path(out).suffix.lower() not in IMAGE_SUFFIXES:
        raise ValueError(f"{out}: image format must be PNG or SVG (suffix .png or .svg)")
    return save_figure(fleet_figure(map, sorties, title=title), out, dpi=dpi)
