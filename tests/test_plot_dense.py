"""Pictures a user reads on dense maps (issue 35): no two labels overlap (their boxes measured
from the drawn artists), no label or scale bar covers a marker, every sensor is named in the map
or the data panels (or counted in their summary), the named lines have distinct colours, and a
hover point at the start or end is not hidden under its marker. Same figure, same bytes."""

from __future__ import annotations

import io

import numpy as np
import pytest
from matplotlib.lines import Line2D
from matplotlib.text import Annotation, Text

from lamde_mission import plot
from lamde_mission.items import plan_to_items
from planner_core.model.mapio import load_map
from sim import replay
from tests.conftest import ROOT, plan_at


def _dense_map(n: int = 28) -> dict:
    """`n` sensors in a tight cluster on a 2 x 1 km area, the end on the last hover point."""
    rng = np.random.default_rng(3)
    xy = rng.uniform([300, 200], [1300, 800], size=(n, 2)).round(1)
    return {
        "name": "dense",
        "origin": {"lat": 23.0, "lon": 113.0, "alt": 0.0},
        "area": {"width": 2000, "height": 1000},
        "start": [50, 50],
        "end": [float(xy[-1, 0]), float(xy[-1, 1])],
        "sensors": [
            {"id": f"S{j + 1:02d}", "x": float(x), "y": float(y)} for j, (x, y) in enumerate(xy)
        ],  # fmt: skip
        "obstacles": {"circles": [{"x": 1700, "y": 500, "radius": 80}]},
        "uav": {"max_hover_points": 12},
    }


def _figure(m, hover, times):
    plan = plan_at(m, hover, times)
    return plot.mission_figure(m, timeline=replay(plan_to_items(plan, m), m))


def _label_boxes(fig) -> tuple[list[str], np.ndarray]:
    """The map panel's labels (text and box in display pixels, the text's own box: a leader
    line is not part of it), measured after a full draw."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    anns = [t for t in fig.axes[0].texts if isinstance(t, Annotation) and t.get_text()]
    boxes = [Text.get_window_extent(t, r) for t in anns]
    return [t.get_text() for t in anns], np.array([[b.x0, b.y0, b.x1, b.y1] for b in boxes])


def _marker_boxes(fig) -> np.ndarray:
    """Every scatter and marker of the map panel as a square box in display pixels."""
    ax = fig.axes[0]
    out = []
    for coll in ax.collections:  # a scatter has sizes; leader lines and obstacles have none
        offs = coll.get_offsets()
        if len(offs) and len(getattr(coll, "get_sizes", lambda: ())()):
            px = ax.transData.transform(offs)
            r = np.sqrt(np.broadcast_to(coll.get_sizes(), (len(px),))) / 2 * fig.dpi / 72
            out.append(np.hstack([px - r[:, None], px + r[:, None]]))
    for line in ax.get_lines():
        if line.get_marker() not in ("None", None, "") and line.get_linestyle() in ("None", ""):
            px = ax.transData.transform(np.c_[line.get_xdata(), line.get_ydata()])
            r = line.get_markersize() / 2 * fig.dpi / 72
            out.append(np.hstack([px - r, px + r]))
    return np.vstack(out)


def _overlapping_pairs(boxes: np.ndarray) -> list[tuple[int, int]]:
    a, b = boxes[:, None, :], boxes[None, :, :]
    hit = (a[..., 0] < b[..., 2]) & (a[..., 2] > b[..., 0]) & (a[..., 1] < b[..., 3]) \
        & (a[..., 3] > b[..., 1])  # fmt: skip
    return [(i, j) for i, j in zip(*np.nonzero(np.triu(hit, 1)), strict=True)]


def _scale_bar_box(fig) -> np.ndarray:
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    bars = [a for a in fig.axes[0].artists if isinstance(a, AnchoredSizeBar)]
    assert len(bars) == 1
    e = bars[0].get_window_extent(fig.canvas.get_renderer())
    return np.array([e.x0, e.y0, e.x1, e.y1])


def _check_readable(fig, m) -> None:
    texts, boxes = _label_boxes(fig)
    pairs = _overlapping_pairs(boxes)
    assert not pairs, [(texts[i], texts[j]) for i, j in pairs[:5]]
    markers = _marker_boxes(fig)
    bar = _scale_bar_box(fig)
    covered = ((bar[0] < markers[:, 2]) & (bar[2] > markers[:, 0]) & (bar[1] < markers[:, 3])
               & (bar[3] > markers[:, 1]))  # fmt: skip
    assert not covered.any(), "the scale bar covers a marker"
    # every sensor named: on the map, in the bar panel, or counted in its summary
    ids = set(m.sensor_ids)
    on_map = ids & ({t.split(":")[0] for t in texts} | set(texts))
    ax_b = fig.axes[2]
    in_bars = {t.get_text() for t in ax_b.get_xticklabels()}
    assert in_bars <= ids
    title = ax_b.get_title()
    rest = int(title.split("; ")[1].split(" more")[0]) if "more:" in title else 0
    assert len(in_bars) + rest == len(ids)
    legend = fig.legends[0].get_title().get_text()  # the note of labels left out
    left_out = len(ids - on_map)
    if left_out:  # short sensors whose label found no place are counted as other labels
        assert f"of {len(ids)} sensor ids" in legend or "other labels left out" in legend
    # the named lines of the time panel: distinct (colour, style)
    styles = [(tuple(ln.get_color()), ln.get_linestyle()) for ln in fig.axes[1].get_lines()
              if ln.get_color() != "0.7" and ln.get_linewidth() == 1.2]  # fmt: skip
    assert len(styles) == min(plot.TIME_LINES, len(ids)) == len(set(styles))


@pytest.mark.slow
def test_dense_cluster_labels_apart_and_sensors_named() -> None:
    """28 sensors in a 1 x 0.6 km cluster, 12 hover points over them: labels apart, every id in
    the bar panel (dropped map labels counted in the legend), the end marker hollow around the
    hover point under it (~4 s)."""
    m = load_map(_dense_map())
    s = np.asarray(m.sensors)
    hover = [s[j].tolist() for j in range(0, 24, 2)]
    hover[-1] = s[-1].tolist()  # the last hover point where the mission ends
    fig = _figure(m, hover, [30.0] * 12)
    _check_readable(fig, m)
    assert {t.get_text() for t in fig.axes[2].get_xticklabels()} == set(m.sensor_ids)
    texts = _label_boxes(fig)[0]
    assert all(f"{i + 1} · " in " ".join(texts) for i in range(12))  # every hover point named
    ends = [ln for ln in fig.axes[0].get_lines() if ln.get_marker() == "s"]
    assert len(ends) == 1 and ends[0].get_markerfacecolor() == "none"  # hollow, around it
    assert ends[0].get_markersize() > np.sqrt(40.0 + 260.0 * 30.0 / m.spec.uav.max_hover_time)


def test_few_sensors_keep_one_data_panel_and_all_labels() -> None:
    """Up to TIME_LINES sensors: no bar panel, every sensor labelled on the map (no two labels
    overlapping, the scale bar on no marker) and named at the end of its line, colours all
    different."""
    d = _dense_map(6)
    d["sensors"] = [{**s, "x": 300 + 250 * j, "y": 500} for j, s in enumerate(d["sensors"])]
    m = load_map(d)
    fig = _figure(m, [[550, 520], [1050, 520]], [40.0, 40.0])
    assert len(fig.axes) == 3  # map, colour bar, time panel
    texts, boxes = _label_boxes(fig)
    assert set(m.sensor_ids) <= {t.split(":")[0] for t in texts}
    assert not _overlapping_pairs(boxes)
    bar, markers = _scale_bar_box(fig), _marker_boxes(fig)
    assert not ((bar[0] < markers[:, 2]) & (bar[2] > markers[:, 0]) & (bar[1] < markers[:, 3])
                & (bar[3] > markers[:, 1])).any()  # fmt: skip
    ends = [t.get_text().split()[0] for t in fig.axes[1].texts if "%" in t.get_text()]
    assert sorted(ends) == sorted(m.sensor_ids)
    colours = [tuple(ln.get_color()) for ln in fig.axes[1].get_lines() if ln.get_linewidth() == 1.2]
    assert len(colours) == 6 == len(set(colours))


def _spread_plan(m, k: int):
    """k hover points on every other sensor (a drawing load, not a good plan)."""
    s = np.asarray(m.sensors)
    idx = np.linspace(0, len(s) - 1, k).round().astype(int)
    return [s[j].tolist() for j in idx], [25.0] * k


@pytest.mark.slow
@pytest.mark.parametrize("name", ["suite/T16", "large/L02"])
def test_suite_and_large_maps_are_readable(name) -> None:
    """T16 (29 sensors, 20 hover points) and L02 (160 sensors, 80 hover points): no two labels
    overlap, the scale bar covers no marker, every sensor named or counted; drawn twice, the
    same PNG bytes (T16; ~6 s and ~15 s)."""
    m = load_map(ROOT / "examples" / "maps" / f"{name}.json")
    hover, times = _spread_plan(m, m.spec.uav.max_hover_points)
    fig = _figure(m, hover, times)
    _check_readable(fig, m)
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "end" in legend and isinstance(fig.legends[0].legend_handles[0], Line2D)
    if name != "suite/T16":
        return
    pngs = []
    for f in (fig, _figure(m, hover, times)):
        buf = io.BytesIO()
        f.savefig(buf, format="png", dpi=80)
        pngs.append(buf.getvalue())
    assert pngs[0] == pngs[1]
