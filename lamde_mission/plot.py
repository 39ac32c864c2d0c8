"""A picture of a map and (optionally) a mission flown on it, saved as PNG or SVG.

Draws the area, circles, rotated rectangles, polygon footprints (courtyards left open), no-fly
zones (holes open, names on large maps left out), sensors coloured by the share of
their required data collected, the path with hover points sized by hover time, start and end,
a legend and a scale bar in metres. Uses matplotlib's Agg canvas directly (no pyplot state),
imported inside the functions so importing this module stays cheap.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np

from lamde_mission.atomic import write_bytes_atomic

__all__ = ["mission_figure", "save_figure", "plot_mission", "IMAGE_SUFFIXES", "nice_length"]

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


def mission_figure(
    map: Any,  # noqa: A002
    *,
    timeline: Any = None,
    plan: Any = None,
    title: str | None = None,
    figsize: tuple[float, float] = (8.0, 7.5),
) -> Any:
    """A matplotlib Figure (Agg canvas) of `map` with a replayed `timeline` or a `plan`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, Patch
    from matplotlib.patches import Polygon as PolygonPatch
    from matplotlib.patches import Rectangle as RectanglePatch
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    spec = map.spec
    W, H = spec.area.width, spec.area.height
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.set_aspect("equal")
    pad = 0.03 * max(W, H)
    ax.set_xlim(-pad, W + pad)
    ax.set_ylim(-pad, H + pad)
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.add_patch(RectanglePatch((0, 0), W, H, fill=False, edgecolor="0.3", linewidth=1.2,
                                linestyle="--"))  # fmt: skip
    handles: list[Any] = [Line2D([], [], color="0.3", linestyle="--", label="area")]

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

    view = _mission_view(map, timeline, plan)
    sensors = np.asarray(map.sensors, dtype=float)
    required = np.asarray(map.required_data, dtype=float)
    if view is not None and view["collected"] is not None:
        share = np.where(required > 0, view["collected"] / np.maximum(required, 1e-300), 1.0)
        norm = Normalize(0.0, 1.0)
        cmap = "RdYlGn"
        ax.scatter(sensors[:, 0], sensors[:, 1], c=np.clip(share, 0, 1), cmap=cmap, norm=norm,
                   marker="o", s=36, edgecolors="k", linewidths=0.6, zorder=4)  # fmt: skip
        short = share < 1.0 - 1e-9
        if short.any():
            ax.scatter(sensors[short, 0], sensors[short, 1], marker="x", c="k", s=18, zorder=5)
        cb = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.7)
        cb.set_label("data collected / required (x: short)")
        handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="tab:green",
                              markeredgecolor="k", label="sensors"))  # fmt: skip
    else:
        ax.scatter(sensors[:, 0], sensors[:, 1], marker="o", s=30, c="tab:blue",
                   edgecolors="k", linewidths=0.5, zorder=4)  # fmt: skip
        handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="tab:blue",
                              markeredgecolor="k", label="sensors"))  # fmt: skip

    if view is not None:
        p = view["path"]
        ax.plot(p[:, 0], p[:, 1], "-", color="tab:blue", linewidth=1.6, zorder=3)
        handles.append(Line2D([], [], color="tab:blue", linewidth=1.6, label="path"))
        if view["return_leg"] is not None:
            rl = np.asarray(view["return_leg"])
            ax.plot(rl[:, 0], rl[:, 1], ":", color="tab:blue", linewidth=1.2, zorder=3)
            handles.append(Line2D([], [], color="tab:blue", linestyle=":", label="return (RTL)"))
        hp, ht = view["hover_points"], view["hover_times"]
        if len(hp):
            t_max = max(float(spec.uav.max_hover_time), 1e-9)
            size = 25.0 + 275.0 * np.clip(ht / t_max, 0.0, 1.0)
            ax.scatter(hp[:, 0], hp[:, 1], s=size, facecolors="tab:orange", edgecolors="k",
                       alpha=0.85, linewidths=0.6, zorder=6)  # fmt: skip
            handles.append(Line2D([], [], marker="o", linestyle="", markerfacecolor="tab:orange",
                                  markeredgecolor="k",
                                  label=f"hover points ({len(hp)}, size ~ time)"))  # fmt: skip

    ax.plot(*map.start, marker="^", markersize=11, color="tab:green", markeredgecolor="k",
            zorder=7, linestyle="")  # fmt: skip
    ax.plot(*map.end, marker="s", markersize=10, color="tab:purple", markeredgecolor="k",
            zorder=7, linestyle="")  # fmt: skip
    handles.append(Line2D([], [], marker="^", linestyle="", markerfacecolor="tab:green",
                          markeredgecolor="k", label="start"))  # fmt: skip
    handles.append(Line2D([], [], marker="s", linestyle="", markerfacecolor="tab:purple",
                          markeredgecolor="k", label="end"))  # fmt: skip

    bar = nice_length(W)
    label = f"{bar / 1000:g} km" if bar >= 1000 else f"{bar:g} m"
    ax.add_artist(AnchoredSizeBar(ax.transData, bar, label, loc="lower right", pad=0.4,
                                  borderpad=0.6, sep=4, frameon=True, size_vertical=0))  # fmt: skip
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 5),
               fontsize=8, frameon=False)  # fmt: skip
    if title is None:
        title = f"map '{spec.name}'"
        if view is not None and view.get("f") is not None:
            title += f"  (f = {float(view['f']):.6g})"
    ax.set_title(title)
    return fig


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
