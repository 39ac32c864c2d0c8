"""`show` on 400-sensor maps took 7-9 s: every label was measured by a probe annotation and
placed twice (a second layout for the legend's note), leader lines and direction arrows were
one FancyArrowPatch each (clipped by bisection at every draw), every obstacle a patch, every
sensor's data line every replay sample (26,000 x 400 on L03), and `savefig` drew the whole
figure once more before drawing it into the file. These tests pin what replaced that: each
label annotated once, leaders and arrows and obstacles in collections, each data line through
its bends only (the same line), one layout unless the note needs a new legend row, and one
draw per save; an arrow covers the pixels the annotation arrow did, and the same mission still
saves to the same PNG and SVG bytes."""

from __future__ import annotations

import matplotlib.axes
import matplotlib.figure
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PathCollection
from matplotlib.figure import Figure
from matplotlib.text import Annotation, Text

from lamde_mission import plot
from lamde_mission.items import plan_to_items
from planner_core.model.mapio import load_map
from sim import replay
from tests.conftest import plan_at
from tests.test_plot_dense import _dense_map


def _dense(nfz: bool = False, tall: bool = False):
    """The 28-sensor cluster of test_plot_dense, 12 hover points of 30 s (labels crowd: some
    sensor ids are left out, some labels need a leader line); with `nfz`, a no-fly zone away
    from the cluster (one more legend entry); with `tall`, on a 1.4 x 5 km area (a narrow
    figure)."""
    d = _dense_map()
    if tall:
        d["area"] = {"width": 1400, "height": 5000}
        d["obstacles"]["circles"] = [{"x": 700, "y": 3000, "radius": 80}]
    if nfz:
        d["obstacles"]["no_fly_zones"] = [{"vertices": [[1600, 100], [1900, 100], [1900, 250],
                                                        [1600, 250]]}]  # fmt: skip
    m = load_map(d)
    s = np.asarray(m.sensors)
    hover = [s[j].tolist() for j in range(0, 24, 2)]
    return m, replay(plan_to_items(plan_at(m, hover, [30.0] * 12), m), m)


def _counting(monkeypatch, cls, name: str) -> list[object]:
    """Record each call of `cls.name` (its first argument after self, if any)."""
    calls: list[object] = []
    real = getattr(cls, name)

    def wrapper(self, *args, **kw):
        calls.append(args[0] if args else None)
        return real(self, *args, **kw)

    monkeypatch.setattr(cls, name, wrapper)
    return calls


def test_each_label_is_annotated_once_and_leaders_are_one_collection(monkeypatch) -> None:
    """Each map label is one Annotation made once (none made to be measured or removed), no
    annotation carries an arrow, and the leader lines are one LineCollection: each runs from
    the edge of its label's white box towards its marker and stops short of it."""
    m, tl = _dense()
    made = _counting(monkeypatch, matplotlib.axes.Axes, "annotate")
    fig = plot.mission_figure(m, timeline=tl)
    ax = fig.axes[0]
    labels = [t for t in ax.texts if isinstance(t, Annotation) and t.get_text()]
    texts = [t.get_text() for t in labels]
    assert len(texts) > 20 and len(set(texts)) == len(texts)
    on_map = [t for t in made if t in set(texts)]
    assert sorted(on_map) == sorted(texts)  # each annotated once: no probes, no second try
    assert all(t.arrow_patch is None for t in ax.texts if isinstance(t, Annotation))
    leaders = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(leaders) == 1 and len(leaders[0].get_segments()) >= 1
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    px = fig.dpi / 72.0
    boxes = []
    for t in labels:
        e = Text.get_window_extent(t, r)
        pad = plot._BOX_PAD * t.get_fontsize() * px
        boxes.append(([e.x0 - pad, e.y0 - pad, e.x1 + pad, e.y1 + pad],
                      ax.transData.transform(t.xy)))  # fmt: skip
    for seg in leaders[0].get_segments():
        start, end = ax.transData.transform(seg)
        # the label whose padded box the leader starts on (within a pixel of its edge)
        hits = [(b, a) for b, a in boxes
                if b[0] - 1 <= start[0] <= b[2] + 1 and b[1] - 1 <= start[1] <= b[3] + 1
                and min(abs(start[0] - b[0]), abs(start[0] - b[2]), abs(start[1] - b[1]),
                        abs(start[1] - b[3])) <= 1.0]  # fmt: skip
        assert hits, "a leader that starts on no label's box"
        anchor = min((a for _, a in hits), key=lambda a: np.hypot(*(a - end)))
        gap = np.hypot(*(anchor - end))  # the marker's radius: > 0 and at most a hover disc's
        assert 0.5 * px < gap <= 10.0 * px
        assert np.dot(end - start, anchor - start) > 0  # towards the marker


def test_direction_arrows_are_one_collection_shaped_as_annotation_arrows() -> None:
    """A shaft and a '-|>' head per leg longer than 2 % of the area, in one collection per
    route; drawn, an arrow covers the same pixels as the annotation arrow it replaces."""
    m, tl = _dense()
    fig = plot.mission_figure(m, timeline=tl)
    ax = fig.axes[0]
    legs = plot._timeline_visits(tl).legs
    long = legs[np.hypot(*(legs[:, 1] - legs[:, 0]).T) > 0.02 * max(m.spec.area.width,
                                                                      m.spec.area.height)]
    arrows = [c for c in ax.collections if isinstance(c, PathCollection)
              and len(c.get_paths()) == 2 * len(long) and c.get_linewidths()[0] == 1.4]
    assert len(arrows) == 1 and len(long) >= 5
    # one arrow drawn both ways on a bare copy of the map panel's view: the same pixels
    a, b = long[0]
    images = []
    for ours in (True, False):
        f = Figure(figsize=fig.get_size_inches(), dpi=fig.dpi)
        FigureCanvasAgg(f)
        bx = f.add_axes(ax.get_position().bounds)
        bx.set_xlim(ax.get_xlim())
        bx.set_ylim(ax.get_ylim())
        bx.set_axis_off()
        tail, tip = a + 0.45 * (b - a), a + 0.55 * (b - a)
        if ours:
            bx.add_collection(PathCollection(
                plot._arrow_paths(bx, np.array([[tail, tip]]), 14.0, 1.4),
                facecolors=["none", "k"], edgecolors="k", linewidths=1.4, joinstyle="round",
                capstyle="round"), autolim=False)  # fmt: skip
        else:
            bx.annotate("", xy=tip, xytext=tail, arrowprops={"arrowstyle": "-|>", "color": "k",
                                                             "lw": 1.4, "mutation_scale": 14})
        f.canvas.draw()
        images.append(np.asarray(f.canvas.buffer_rgba())[..., 0].astype(int))
    ink = [(im < 128).sum() for im in images]
    assert ink[1] > 20
    assert (np.abs(images[0] - images[1]) > 96).sum() <= 0.05 * ink[1]


def test_obstacles_and_no_fly_zones_are_two_collections() -> None:
    """300 circles, 100 rectangles and a no-fly zone: the map panel holds no patch per
    obstacle (only the area's outline), one collection of the 400 obstacles and one of the
    zone, hatched."""
    d = _dense_map(4)
    rng = np.random.default_rng(0)
    xy = rng.uniform([50, 50], [1950, 950], size=(400, 2)).round(1)
    d["obstacles"] = {
        "circles": [{"x": float(x), "y": float(y), "radius": 3.0} for x, y in xy[:300]],
        "rectangles": [{"x": float(x), "y": float(y), "length": 6.0, "width": 3.0,
                        "angle_deg": 30.0} for x, y in xy[300:]],
    }  # fmt: skip
    d["obstacles"]["no_fly_zones"] = [{"vertices": [[10, 900], [40, 900], [40, 990]]}]
    m = load_map(d)
    fig = plot.mission_figure(m)
    ax = fig.axes[0]
    assert len(ax.patches) == 1  # the area
    sizes = sorted(len(c.get_paths()) for c in ax.collections
                   if isinstance(c, PathCollection) and not len(c.get_sizes()))
    assert sizes == [1, 400]
    zone = next(c for c in ax.collections if isinstance(c, PathCollection)
                and len(c.get_paths()) == 1)
    assert zone.get_hatch() == "//"


def test_data_lines_are_drawn_through_their_bends_only() -> None:
    """The grey lines of the data panel are one collection, each sensor's line a few vertices
    (not every replay sample) that pass through every sample's share to 1e-6 %."""
    m, tl = _dense()
    t = np.asarray(tl.t)
    share = 100.0 * np.asarray(tl.data) / np.asarray(m.required_data)[None, :]
    fig = plot.mission_figure(m, timeline=tl)
    ax_t = fig.axes[1]
    grey = [c for c in ax_t.collections if isinstance(c, LineCollection)]
    assert len(grey) == 1
    lines = grey[0].get_segments()
    named = [ln for ln in ax_t.get_lines() if ln.get_linewidth() == 1.2]
    assert len(lines) + len(named) == len(m.sensor_ids) and len(t) > 500
    drawn = [np.asarray(s) for s in lines] + [np.c_[ln.get_xdata(), ln.get_ydata()]
                                              for ln in named]  # fmt: skip
    assert max(len(d) for d in drawn) <= 4 * 12 + 2  # a rise's two ends per hover, at most
    for d in drawn:  # the same line: it matches one sensor's share at every sample
        y = np.interp(t, d[:, 0], d[:, 1])
        assert np.min(np.max(np.abs(share - y[:, None]), axis=0)) < 1e-6


def test_bends_keep_the_samples_a_line_needs() -> None:
    """`_bends`: a flat line and a straight rise come down to their ends, a change of slope and
    a jump (two samples at one time, as at a phase boundary) keep their samples, a NaN keeps
    its neighbours (the gap is drawn), a curve keeps every sample, and a slope that drifts too
    little per sample to count but too much in all is not straightened."""
    t = np.array([0.0, 1, 2, 3, 3, 4, 5, 6, 7, 8, 9, 10])  # time 3 sampled twice
    flat = np.zeros(12)
    rise = np.array([0.0, 0, 1, 2, 2, 3, 4, 6, 8, 8, 8, 8])  # slope 1 from 1, 2 from 6, 0 from 8
    jump = np.array([0.0, 0, 0, 0, 5, 5, 5, 5, 5, 5, 5, 5])  # 5 more at time 3
    gap = np.array([0.0, 1, 2, np.nan, 4, 5, 6, 7, 8, 9, 10, 11])
    curve = t**2
    y = np.column_stack([flat, rise, jump, gap, curve])
    k = plot._bends(t, y, 1e-9)
    assert k[0].tolist() == [0, 11]
    assert k[1].tolist() == [0, 1, 3, 4, 6, 8, 11]  # the repeated time ends a run: both stay
    assert k[2].tolist() == [0, 3, 4, 11]
    assert k[3].tolist() == [0, 2, 3, 4, 11]
    assert k[4].tolist() == list(range(12))
    for j in (0, 1, 4):
        assert np.allclose(np.interp(t, t[k[j]], y[k[j], j]), y[:, j])
    # a slope that drifts by less than rtol per sample but more than tol in all: kept
    tt = np.arange(2001.0)
    drift = np.cumsum(1.0 + 1e-10 * np.arange(2000.0))
    k = plot._bends(tt, np.r_[0.0, drift][:, None], 1e-6)
    assert np.max(np.abs(np.interp(tt, tt[k[0]], np.r_[0.0, drift][k[0]])
                         - np.r_[0.0, drift])) <= 1e-6  # fmt: skip


@pytest.mark.parametrize(("nfz", "tall", "layouts"), [(False, False, 1), (True, False, 1),
                                                     (False, True, 2)])  # fmt: skip
def test_layout_once_unless_the_note_needs_more_lines(monkeypatch, nfz, tall, layouts) -> None:
    """Labels left out are counted in a note, the legend's title, a line kept for it from the
    first layout: with seven entries or eight (a no-fly zone), the layout is not redone and
    the places found stand. On a narrow figure (a tall map) the note takes a line per clause:
    laid out again, the labels placed again."""
    m, tl = _dense(nfz, tall)
    done = _counting(monkeypatch, matplotlib.figure.Figure, "draw_without_rendering")
    fig = plot.mission_figure(m, timeline=tl)
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    note = fig.legends[0].get_title().get_text()
    assert len(legend) == (8 if nfz else 7) and "left out where crowded" in note
    assert note.count("\n") == (1 if tall else 0)
    assert len(done) == layouts


@pytest.mark.parametrize("fmt", ["png", "svg"])
def test_a_save_draws_the_figure_once_and_svg_stays_deterministic(monkeypatch, fmt) -> None:
    """`figure_bytes` draws the figure once (its layout is fixed: no engine left for
    `savefig` to run a dry draw for), and two figures of the same mission save to the same
    bytes."""
    m, tl = _dense()
    figs = [plot.mission_figure(m, timeline=tl) for _ in range(2)]
    draws = _counting(monkeypatch, matplotlib.figure.Figure, "draw")
    out = [plot.figure_bytes(f, fmt, dpi=60) for f in figs]
    assert len(draws) == 2  # one per save
    assert out[0] == out[1]


def test_the_legend_and_titles_stay_inside_a_narrow_figure() -> None:
    """On a tall, narrow map (1.4 x 5 km) four legend columns ran past both edges of the
    figure, and so did the note of labels left out, the panels' titles and the data panel's
    end labels: the legend takes fewer columns until it fits and keeps every entry, the note a
    line per clause, the titles wrap before the layout (into the room it gives them), and the
    data panel leaves room at its right for its labels."""
    m, tl = _dense(tall=True)
    fig = plot.mission_figure(m, timeline=tl)
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    legend = fig.legends[0]
    box = legend.get_window_extent(r)
    assert box.x0 >= 0.0 and box.x1 <= fig.bbox.width, (box.bounds, fig.bbox.width)
    assert legend._ncols < 4 and len(legend.get_texts()) == 7
    for ax in fig.axes[1:3]:
        title = ax.title.get_window_extent(r)
        assert title.x0 >= 0.0 and title.x1 <= fig.bbox.width, (ax.get_title(), title.bounds)
        # a wrapped title takes room from the layout, not from the panel above it
        above = fig.axes[fig.axes.index(ax) - 1].get_tightbbox(r)
        assert title.y1 <= above.y0 + 1.0, (ax.get_title(), title.bounds, above.bounds)
    # the data panel's end labels ("S24 679 %") stay inside its frame
    frame = fig.axes[1].get_window_extent(r)
    ends = [a for a in fig.axes[1].texts if isinstance(a, Annotation) and "%" in a.get_text()]
    assert ends and all(a.get_window_extent(r).x1 <= frame.x1 + 1.0 for a in ends)
