"""A picture of a map and (optionally) a mission flown on it, saved as PNG or SVG.

Draws the area, circles, rotated rectangles, polygon footprints (courtyards left open), no-fly
zones (holes open), sensors labelled by id and coloured by the share of their required data
collected (short ones ringed with "x of y Mbit", unreached ones crossed), the path with arrows
and numbered hover points ("order · seconds"), the parts of legs inside obstacles in red, start
and end, a legend below the map and a scale bar in the emptiest corner; with a replay, a panel
of each sensor's data over the mission time against its requirement. Uses matplotlib's Agg
canvas directly (no pyplot state), imported inside the functions so importing this module
stays cheap.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lamde_mission.atomic import write_bytes_atomic

__all__ = ["mission_figure", "save_figure", "plot_mission", "IMAGE_SUFFIXES", "nice_length",
           "SortieView", "fleet_figure", "plot_fleet", "SORTIE_STYLES"]  # fmt: skip

IMAGE_SUFFIXES = (".png", ".svg")


def nice_length(span: float) -> float:
    """A round length (1, 2 or 5 x 10^k metres) near a fifth of `span`, for the scale bar."""
    target = max(span / 5.0, 1e-9)
    k = math.floor(math.log10(target))
    for m in (5, 2, 1):
        if m * 10**k <= target:
            return float(m * 10**k)
    return float(10**k)


def _mission_view(map_: Any, timeline: Any, plan: Any) -> dict[str, Any] | None:
    """Path, hover points/times and data collected, from a sim Timeline or a Plan."""
    if timeline is not None:
        return {
            "path": np.asarray(timeline.path, dtype=float),
            "return_leg": timeline.return_leg,
            "hover_points": np.asarray(timeline.hover_points, dtype=float).reshape(-1, 2),
            "hover_times": np.asarray(timeline.hover_times, dtype=float).reshape(-1),
            "collected": np.asarray(timeline.collected, dtype=float),
            "f": timeline.totals.f,
        }
    if plan is not None:
        hp = np.asarray(plan.hover_points, dtype=float).reshape(-1, 2)
        bd = getattr(plan, "breakdown", None) or {}
        got = bd.get("collected") if isinstance(bd, dict) else None
        collected = (np.array([float(got.get(i, np.nan)) for i in map_.sensor_ids])
                     if isinstance(got, dict) else None)  # fmt: skip
        return {
            "path": np.vstack([map_.start, hp, map_.end]),
            "return_leg": None,
            "hover_points": hp,
            "hover_times": np.asarray(plan.hover_times, dtype=float).reshape(-1),
            "collected": collected,
            "f": getattr(plan, "f", None),
        }
    return None


def _shape_patch(shell: np.ndarray, holes: Any, **style: Any) -> Any:
    """A patch for a polygon with holes (holes drawn open: a courtyard is flyable)."""
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath

    verts: list[np.ndarray] = []
    codes: list[np.ndarray] = []
    for ring in [shell, *holes]:
        ring = np.asarray(ring, dtype=float)
        verts.append(np.vstack([ring, ring[:1]]))
        c = np.full(len(ring) + 1, MplPath.LINETO, dtype=np.uint8)
        c[0], c[-1] = MplPath.MOVETO, MplPath.CLOSEPOLY
        codes.append(c)
    return PathPatch(MplPath(np.concatenate(verts), np.concatenate(codes)), **style)


def _violation_segments(map_: Any, path: np.ndarray) -> list[np.ndarray]:
    """The parts of the path's legs inside an obstacle or no-fly zone (C5), as (k, 2) polylines,
    measured by the simulator's own shapely geometry."""
    import shapely
    from shapely.geometry import LineString

    from sim.obstacles import obstacle_shapes

    shapes = [o.shape for o in obstacle_shapes(map_)]
    if not shapes or len(path) < 2:
        return []
    union = shapely.union_all(shapes)
    out: list[np.ndarray] = []
    for a, b in zip(path[:-1], path[1:], strict=True):
        if np.allclose(a, b):
            continue
        inter = LineString([a, b]).intersection(union)
        for g in getattr(inter, "geoms", [inter]):
            if g.geom_type == "LineString" and g.length > 1e-6:
                out.append(np.asarray(g.coords, dtype=float))
    return out


def _emptiest_corner(points: np.ndarray, W: float, H: float) -> str:
    """Which corner of the area ("lower right", ...) holds the fewest of `points` within a
    quarter of the area's size: where the scale bar covers the least data."""
    corners = {"lower right": (W, 0.0), "lower left": (0.0, 0.0), "upper right": (W, H),
               "upper left": (0.0, H)}  # fmt: skip
    if not len(points):
        return "lower right"
    reach = np.array([0.3 * W, 0.15 * H])
    count = {k: int(np.sum(np.all(np.abs(points - np.array(c)) < reach, axis=1)))
             for k, c in corners.items()}  # fmt: skip
    return min(count, key=lambda k: (count[k], list(corners).index(k)))


#: the white box behind labels
_TEXT_BOX = {"boxstyle": "round,pad=0.15", "facecolor": "white", "alpha": 0.7, "edgecolor": "none"}


def _map_axes(map_: Any, *, has_time: bool, figsize: tuple[float, float] | None) -> Any:
    """(figure, map axes, time axes or None, legend handles): the area drawn, sized to its
    shape (no wide white bands); `figsize` overrides the size."""
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
    if figsize is None:
        figsize = (map_w + 1.6, map_h + 1.4 + time_h)
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    if has_time:
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
    return fig, ax, ax_t, handles


def _draw_obstacles(ax: Any, map: Any, handles: list[Any]) -> None:  # noqa: A002
    """Circles, rotated rectangles, footprints and no-fly zones (holes open), with their
    legend entries."""
    from matplotlib.patches import Circle, Patch
    from matplotlib.patches import Polygon as PolygonPatch

    spec = map.spec
    shapes = list(getattr(map, "shapes", ()))
    n_footprints = sum(sh.kind != "no_fly_zone" for sh in shapes)
    # thin outlines when there are many footprints (a campus), so neighbours stay apart
    lw = 0.8 if n_footprints < 100 else 0.3
    obstacle_style = {"facecolor": "0.55", "edgecolor": "0.25", "alpha": 0.75, "linewidth": lw}
    nfz_style = {"facecolor": "tab:red", "alpha": 0.18, "edgecolor": "tab:red", "hatch": "//",
                 "linewidth": 1.0}  # fmt: skip
    for c in spec.obstacles.circles:
        ax.add_patch(Circle((c.x, c.y), c.radius, **obstacle_style))
    for poly in map.rectangle_polygons:
        ax.add_patch(PolygonPatch(poly, closed=True, **obstacle_style))
    for sh in shapes:
        style = nfz_style if sh.kind == "no_fly_zone" else obstacle_style
        ax.add_patch(_shape_patch(sh.shell, sh.holes, **style))
    if spec.obstacles.circles or spec.obstacles.rectangles or n_footprints:
        handles.append(Patch(label="obstacles", **obstacle_style))
    if len(shapes) > n_footprints:
        handles.append(Patch(facecolor="tab:red", alpha=0.3, edgecolor="tab:red", hatch="//",
                             label="no-fly zones"))  # fmt: skip


def _draw_sensors(
    fig: Any,
    ax: Any,
    map: Any,  # noqa: A002
    collected: np.ndarray | None,
    handles: list[Any],
) -> np.ndarray:
    """The sensors, labelled by id; with `collected` (Mbit per sensor) coloured by the share of
    their requirement, short ones ringed with "x of y Mbit", unreached ones crossed, and a
    colour bar. Returns the sensor positions (J x 2, m)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.lines import Line2D

    text_box = _TEXT_BOX
    sensors = np.asarray(map.sensors, dtype=float)
    required = np.asarray(map.required_data, dtype=float)
    ids = list(map.sensor_ids)
    many = len(ids) > 60  # label only the sensors that need attention on crowded maps
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
            ax.scatter(sensors[short, 0], sensors[short, 1], marker="o", s=260,
                       facecolors="none", edgecolors="tab:red", linewidths=2.0, zorder=5)
            handles.append(Line2D([], [], marker="o", linestyle="", markersize=11,
                                  markerfacecolor="none", markeredgecolor="tab:red",
                                  markeredgewidth=2, label="sensor short of data (C4)"))
        if none.any():
            ax.scatter(sensors[none, 0], sensors[none, 1], marker="X", s=160, c="tab:red",
                       edgecolors="k", linewidths=0.8, zorder=6)  # fmt: skip
            handles.append(Line2D([], [], marker="X", linestyle="", markersize=10,
                                  markerfacecolor="tab:red", markeredgecolor="k",
                                  label="sensor not reached (0 Mbit)"))  # fmt: skip
        for j, sid in enumerate(ids):
            if short[j]:
                ax.annotate(f"{sid}: {got[j]:.0f} of {required[j]:.0f} Mbit", sensors[j],
                            xytext=(8, -12), textcoords="offset points", fontsize=8,
                            color="tab:red", fontweight="bold", zorder=8, bbox=text_box)
            elif not many:
                ax.annotate(sid, sensors[j], xytext=(5, 5), textcoords="offset points",
                            fontsize=7.5, zorder=8, bbox=text_box)  # fmt: skip
        cb = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, fraction=0.04, pad=0.01)
        cb.set_label("data collected / required")
        handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="tab:green",
                              markeredgecolor="k", label="sensors (colour: share collected)"))
    else:
        ax.scatter(sensors[:, 0], sensors[:, 1], marker="o", s=30, c="tab:blue",
                   edgecolors="k", linewidths=0.5, zorder=4)  # fmt: skip
        if not many:
            for j, sid in enumerate(ids):
                ax.annotate(sid, sensors[j], xytext=(5, 5), textcoords="offset points",
                            fontsize=7.5, zorder=8, bbox=text_box)  # fmt: skip
        handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="tab:blue",
                              markeredgecolor="k", label="sensors"))  # fmt: skip
    return sensors


def _scale_bar_and_legend(
    fig: Any, ax: Any, W: float, H: float, data_points: list[np.ndarray], handles: list[Any]
) -> None:
    """A scale bar in the corner with the fewest of `data_points`, the legend below."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    bar = nice_length(W)
    label = f"{bar / 1000:g} km" if bar >= 1000 else f"{bar:g} m"
    corner = _emptiest_corner(np.vstack(data_points), W, H)
    ax.add_artist(AnchoredSizeBar(ax.transData, bar, label, loc=corner, pad=0.4,
                                  borderpad=0.6, sep=4, frameon=True, size_vertical=0))  # fmt: skip
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 4),
               fontsize=8, frameon=False)  # fmt: skip


def mission_figure(
    map: Any,  # noqa: A002
    *,
    timeline: Any = None,
    plan: Any = None,
    title: str | None = None,
    figsize: tuple[float, float] | None = None,
) -> Any:
    """A matplotlib Figure (Agg canvas) of `map` with a replayed `timeline` or a `plan`.

    The map panel labels sensors by id and hover points by visiting order and hover seconds
    ("2 · 41 s"), shows the route's direction with arrows, draws the parts of legs inside an
    obstacle (C5) in red, rings sensors short of data with "x of y Mbit" and crosses those that
    got nothing. With a `timeline` (the simulator's replay) a second panel shows each sensor's
    data collected over the mission time against its requirement (100 %). The figure's size
    follows the area's shape (no wide white bands); `figsize` overrides it.
    """
    from matplotlib.lines import Line2D

    spec = map.spec
    W, H = spec.area.width, spec.area.height
    view = _mission_view(map, timeline, plan)
    has_time = timeline is not None and len(getattr(timeline, "t", ())) > 1
    fig, ax, ax_t, handles = _map_axes(map, has_time=has_time, figsize=figsize)
    _draw_obstacles(ax, map, handles)
    sensors = _draw_sensors(fig, ax, map, None if view is None else view["collected"], handles)
    text_box = _TEXT_BOX

    data_points = [sensors, np.asarray([map.start, map.end], dtype=float)]
    if view is not None:
        p = view["path"]
        data_points.append(p)
        ax.plot(p[:, 0], p[:, 1], "-", color="tab:blue", linewidth=1.6, zorder=3)
        handles.append(Line2D([], [], color="tab:blue", linewidth=1.6,
                              label="path (arrows: direction)"))  # fmt: skip
        for a, b in zip(p[:-1], p[1:], strict=True):  # the route's order: one arrow per leg
            if np.hypot(*(b - a)) > 0.02 * max(W, H):
                mid = a + 0.55 * (b - a)
                ax.annotate("", xy=mid, xytext=a + 0.45 * (b - a), zorder=3,
                            arrowprops={"arrowstyle": "-|>", "color": "tab:blue", "lw": 1.4,
                                        "mutation_scale": 14})  # fmt: skip
        bad = _violation_segments(map, p)
        for seg in bad:
            ax.plot(seg[:, 0], seg[:, 1], "-", color="red", linewidth=4.0, zorder=7,
                    solid_capstyle="butt")  # fmt: skip
        if bad:
            total = sum(float(np.sum(np.hypot(*np.diff(s, axis=0).T))) for s in bad)
            handles.append(Line2D([], [], color="red", linewidth=4,
                                  label=f"path inside obstacles (C5): {total:.0f} m"))
        if view["return_leg"] is not None:
            rl = np.asarray(view["return_leg"])
            ax.plot(rl[:, 0], rl[:, 1], ":", color="tab:blue", linewidth=1.2, zorder=3)
            handles.append(Line2D([], [], color="tab:blue", linestyle=":", label="return (RTL)"))
        hp, ht = view["hover_points"], view["hover_times"]
        if len(hp):
            t_max = max(float(spec.uav.max_hover_time), 1e-9)
            size = 40.0 + 260.0 * np.clip(ht / t_max, 0.0, 1.0)
            ax.scatter(hp[:, 0], hp[:, 1], s=size, facecolors="tab:orange", edgecolors="k",
                       alpha=0.85, linewidths=0.6, zorder=6)  # fmt: skip
            for i, (xy, t) in enumerate(zip(hp, ht, strict=True)):
                ax.annotate(f"{i + 1} · {t:.0f} s", xy, xytext=(7, -3), textcoords="offset points",
                            fontsize=8, color="saddlebrown", fontweight="bold", zorder=8,
                            bbox=text_box)  # fmt: skip
            handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="tab:orange",
                                  markeredgecolor="k",
                                  label="hover point: order · seconds"))  # fmt: skip

    ax.plot(*map.start, marker="^", markersize=11, color="tab:green", markeredgecolor="k",
            zorder=7, linestyle="")  # fmt: skip
    ax.plot(*map.end, marker="s", markersize=10, color="tab:purple", markeredgecolor="k",
            zorder=7, linestyle="")  # fmt: skip
    handles.append(Line2D([], [], marker="^", linestyle="", markerfacecolor="tab:green",
                          markeredgecolor="k", label="start"))  # fmt: skip
    handles.append(Line2D([], [], marker="s", linestyle="", markerfacecolor="tab:purple",
                          markeredgecolor="k", label="end"))  # fmt: skip

    _scale_bar_and_legend(fig, ax, W, H, data_points, handles)
    if title is None:
        title = f"map '{spec.name}'"
        if view is not None and view.get("f") is not None:
            title += f"  (f = {float(view['f']):.6g})"
    ax.set_title(title)
    if ax_t is not None:
        _data_panel(ax_t, timeline, map)
    return fig


def _data_panel(ax: Any, timeline: Any, map_: Any) -> None:
    """Each sensor's data collected along the mission time, as a share of its requirement
    (the simulator's replay samples); the requirement is the 100 % line."""
    t = np.asarray(timeline.t, dtype=float)
    data = np.asarray(timeline.data, dtype=float)
    required = np.asarray(map_.required_data, dtype=float)
    share = 100.0 * data / np.maximum(required, 1e-300)[None, :]
    share[:, required <= 0] = 100.0
    ids = list(timeline.sensor_ids)
    top = max(110.0, float(np.nanmax(share)) * 1.05)
    labelled = [j for j in range(len(ids)) if len(ids) <= 12 or share[-1, j] < 100.0 - 1e-6]
    # end labels spread apart vertically (at least 7 % of the axis) so close lines stay legible
    ys = {}
    for j in sorted(labelled, key=lambda j: share[-1, j]):
        y = float(share[-1, j])
        if ys:
            y = max(y, max(ys.values()) + 0.07 * top)
        ys[j] = y
    colors = {}
    for j in range(len(ids)):
        (line,) = ax.plot(t, share[:, j], linewidth=1.2)
        colors[j] = line.get_color()
    for j, y in ys.items():
        final = share[-1, j]
        ax.annotate(f"{ids[j]}" + ("" if final >= 100.0 - 1e-6 else f" {final:.0f} %"),
                    (t[-1], final), xytext=(t[-1] + 0.01 * (t[-1] - t[0]), y), fontsize=7.5,
                    color=colors[j], va="center", annotation_clip=False,
                    ha="left")  # fmt: skip
    ax.axhline(100.0, color="k", linestyle="--", linewidth=1.0)
    ax.text(t[0], 101.0, "required", fontsize=7.5, va="bottom")
    phase = np.asarray(timeline.phase)
    hover = phase == "hover"
    if hover.any():  # shade the hovers, numbered like the map
        edges = np.flatnonzero(np.diff(np.r_[0, hover.astype(int), 0]))
        for k, (i0, i1) in enumerate(zip(edges[::2], edges[1::2], strict=True)):
            ax.axvspan(t[i0], t[i1 - 1], color="tab:orange", alpha=0.15, linewidth=0)
            ax.text((t[i0] + t[i1 - 1]) / 2, 3.0, str(k + 1), fontsize=7, ha="center",
                    color="saddlebrown")
    ax.set_xlim(t[0], t[-1] + 0.1 * max(t[-1] - t[0], 1e-9))
    ax.set_ylim(0, max(top, max(ys.values(), default=0.0) + 0.05 * top))
    ax.set_xlabel("mission time (s)")
    ax.set_ylabel("collected / required (%)")
    ax.set_title("data collected over the mission (simulator replay; shaded: hovering)",
                 fontsize=9)


def save_figure(fig: Any, path: str | Path, *, dpi: int = 150) -> Path:
    """Render `fig` to PNG or SVG by suffix and write it atomically (no partial file)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in IMAGE_SUFFIXES:
        raise ValueError(f"{path}: image format must be PNG or SVG (suffix .png or .svg)")
    buf = io.BytesIO()
    fig.savefig(buf, format=suffix[1:], dpi=dpi)
    return write_bytes_atomic(path, buf.getvalue())


def plot_mission(
    map: Any,  # noqa: A002
    out: str | Path,
    *,
    timeline: Any = None,
    plan: Any = None,
    title: str | None = None,
    dpi: int = 150,
) -> Path:
    """Draw `map` (with a replayed `timeline` or a `plan`, if given) and save it to `out`."""
    if Path(out).suffix.lower() not in IMAGE_SUFFIXES:
        raise ValueError(f"{out}: image format must be PNG or SVG (suffix .png or .svg)")
    fig = mission_figure(map, timeline=timeline, plan=plan, title=title)
    return save_figure(fig, out, dpi=dpi)


# ----------------------------------------------------------------------------- fleets


#: the line style of sortie j (1-based) of a vehicle: SORTIE_STYLES[(j - 1) % 4]
SORTIE_STYLES = ("-", "--", "-.", ":")


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


def fleet_figure(
    map: Any,  # noqa: A002
    sorties: Sequence[SortieView],
    *,
    title: str | None = None,
    figsize: tuple[float, float] | None = None,
) -> Any:
    """A matplotlib Figure of `map` with every sortie of a fleet, each replayed by the sim.

    One colour per vehicle (tab10), one line style per sortie of a vehicle (`SORTIE_STYLES`:
    solid, dashed, dash-dot, dotted), arrows along each leg, hover points in the vehicle's
    colour labelled "sortie.order · seconds" (up to 40 hover points in all), the parts of legs
    inside obstacles (C5) in red; depots (where sorties take off and land) as black-edged
    hexagons with their names, and each battery swap (a vehicle landing from sortie j and
    leaving on sortie j + 1) as a star in the vehicle's colour with "v1 swap 1". Sensors are
    coloured by the data collected over all sorties together (C4 over the whole plan).
    Cost: O(sorties x samples) for the drawing.

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
    W, H = spec.area.width, spec.area.height
    fig, ax, _ax_t, handles = _map_axes(map, has_time=False, figsize=figsize)
    _draw_obstacles(ax, map, handles)
    collected = np.sum([np.asarray(sv.timeline.collected, dtype=float) for sv in sorties], axis=0)
    sensors = _draw_sensors(fig, ax, map, collected, handles)
    data_points = [sensors]
    n_hover = sum(len(sv.timeline.hover_points) for sv in sorties)
    t_max = max(float(spec.uav.max_hover_time), 1e-9)
    bad_total = 0.0
    vehicles = sorted({sv.vehicle for sv in sorties})
    for sv in sorties:
        colour = _vehicle_colour(sv.vehicle)
        style = SORTIE_STYLES[(sv.sortie - 1) % len(SORTIE_STYLES)]
        p = np.asarray(sv.timeline.path, dtype=float)
        data_points.append(p)
        ax.plot(p[:, 0], p[:, 1], linestyle=style, color=colour, linewidth=1.6, zorder=3)
        for a, b in zip(p[:-1], p[1:], strict=True):
            if np.hypot(*(b - a)) > 0.02 * max(W, H):
                ax.annotate("", xy=a + 0.55 * (b - a), xytext=a + 0.45 * (b - a), zorder=3,
                            arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 1.4,
                                        "mutation_scale": 12})  # fmt: skip
        for seg in _violation_segments(map, p):
            ax.plot(seg[:, 0], seg[:, 1], "-", color="red", linewidth=4.0, zorder=7,
                    solid_capstyle="butt")  # fmt: skip
            bad_total += float(np.sum(np.hypot(*np.diff(seg, axis=0).T)))
        rl = sv.timeline.return_leg
        if rl is not None:
            rl = np.asarray(rl, dtype=float)
            ax.plot(rl[:, 0], rl[:, 1], ":", color=colour, linewidth=1.0, zorder=3)
        hp = np.asarray(sv.timeline.hover_points, dtype=float).reshape(-1, 2)
        ht = np.asarray(sv.timeline.hover_times, dtype=float).reshape(-1)
        if len(hp):
            size = 40.0 + 260.0 * np.clip(ht / t_max, 0.0, 1.0)
            ax.scatter(hp[:, 0], hp[:, 1], s=size, facecolors=[colour], edgecolors="k",
                       alpha=0.8, linewidths=0.6, zorder=6)  # fmt: skip
            if n_hover <= 40:
                for i, (xy, t) in enumerate(zip(hp, ht, strict=True)):
                    ax.annotate(f"{sv.sortie}.{i + 1} · {t:.0f} s", xy, xytext=(7, -3),
                                textcoords="offset points", fontsize=7.5, color=colour,
                                fontweight="bold", zorder=8, bbox=_TEXT_BOX)  # fmt: skip
    if bad_total > 0:
        handles.append(Line2D([], [], color="red", linewidth=4,
                              label=f"path inside obstacles (C5): {bad_total:.0f} m"))
    # depots: every take-off and landing position, named as fleet.json names them
    depots: dict[tuple[float, float], set[str]] = {}
    for sv in sorties:
        p = np.asarray(sv.timeline.path, dtype=float)
        for xy, name in ((p[0], sv.depot_start), (p[-1], sv.depot_end)):
            key = (round(float(xy[0]), 1), round(float(xy[1]), 1))
            depots.setdefault(key, set())
            if name:
                depots[key].add(name)
    for (x, y), names in depots.items():
        ax.plot(x, y, marker="h", markersize=14, color="white", markeredgecolor="k",
                markeredgewidth=1.6, zorder=7, linestyle="")  # fmt: skip
        if names:
            ax.annotate(" / ".join(sorted(names)), (x, y), xytext=(9, 8),
                        textcoords="offset points", fontsize=8, fontweight="bold", zorder=9,
                        bbox=_TEXT_BOX)  # fmt: skip
    data_points.append(np.asarray(list(depots), dtype=float).reshape(-1, 2))
    # swaps: a vehicle lands from sortie j and leaves on sortie j + 1
    swaps = 0
    by_vehicle: dict[int, list[SortieView]] = {}
    for sv in sorties:
        by_vehicle.setdefault(sv.vehicle, []).append(sv)
    for v, svs in by_vehicle.items():
        svs = sorted(svs, key=lambda s: s.sortie)
        for j, (a, b) in enumerate(zip(svs[:-1], svs[1:], strict=True), start=1):
            at = np.asarray(a.timeline.path, dtype=float)[-1]
            swaps += 1
            ax.plot(*at, marker="*", markersize=15, color=_vehicle_colour(v),
                    markeredgecolor="k", zorder=8, linestyle="")  # fmt: skip
            ax.annotate(f"v{v} swap {j}", at, xytext=(9, -14 - 9 * (j - 1)),
                        textcoords="offset points", fontsize=7.5, color=_vehicle_colour(v),
                        zorder=9, bbox=_TEXT_BOX)  # fmt: skip
            if not np.allclose(at, np.asarray(b.timeline.path, dtype=float)[0], atol=1.0):
                ax.annotate(f"v{v} swap {j} (takes off here)",
                            np.asarray(b.timeline.path, dtype=float)[0], xytext=(9, -14),
                            textcoords="offset points", fontsize=7.5,
                            color=_vehicle_colour(v), zorder=9, bbox=_TEXT_BOX)  # fmt: skip
    for v in vehicles:
        n = len(by_vehicle[v])
        handles.append(Line2D([], [], color=_vehicle_colour(v), linewidth=2.2,
                              label=f"vehicle {v}: {n} sortie{'s' if n > 1 else ''}"))
    most = max(len(svs) for svs in by_vehicle.values())
    for j in range(1, min(most, len(SORTIE_STYLES)) + 1):
        handles.append(Line2D([], [], color="0.2", linewidth=1.6,
                              linestyle=SORTIE_STYLES[j - 1], label=f"sortie {j}"))
    handles.append(Line2D([], [], marker="h", linestyle="", markersize=11,
                          markerfacecolor="white", markeredgecolor="k", label="depot"))
    if swaps:
        handles.append(Line2D([], [], marker="*", linestyle="", markersize=13,
                              markerfacecolor="0.6", markeredgecolor="k",
                              label="battery swap"))  # fmt: skip
    handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="0.6",
                          markeredgecolor="k", label="hover point: sortie.order · seconds"))
    _scale_bar_and_legend(fig, ax, W, H, data_points, handles)
    if title is None:
        nv = len(vehicles)
        title = (f"map '{spec.name}': {nv} vehicle{'s' if nv > 1 else ''}, "
                 f"{len(sorties)} sorties, {swaps} swap{'' if swaps == 1 else 's'}")  # fmt: skip
    ax.set_title(title)
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
