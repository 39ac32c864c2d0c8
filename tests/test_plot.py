"""The pictures a pilot reads (issue 19): rendered in the test, then checked for the file and
the annotations in the figure's text artists (sensor ids, numbered hover points with seconds,
"x of y Mbit" on short sensors, the C5 overlap, the data-over-time panel)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from matplotlib.text import Text

from lamde_mission.items import plan_to_items
from lamde_mission.plot import _violation_segments, mission_figure, plot_mission
from planner_core import Problem
from planner_core.model.mapio import load_map
from sim import replay
from tests.conftest import plan_at

MAP = {
    "name": "plot-check",
    "origin": {"lat": 23.0, "lon": 113.0, "alt": 0.0},
    "area": {"width": 3000, "height": 1000},  # wide: no white bands, colour bar fits
    "start": [100, 500], "end": [2900, 500],
    "sensors": [{"id": "north", "x": 800, "y": 700}, {"id": "far", "x": 2600, "y": 900},
                {"id": "big", "x": 1500, "y": 450, "required_data": 5000}],
    "obstacles": {"circles": [{"x": 1900, "y": 500, "radius": 100}]},
    "uav": {"max_hover_points": 3},
}
HOVER = [[800, 600], [1500, 500]]
TIMES = [40.0, 30.0]


def _texts(fig) -> list[str]:
    return [t.get_text() for t in fig.findobj(Text) if t.get_text()]


def _plan(m):
    return plan_at(m, HOVER, TIMES)


def test_infeasible_plan_shows_where_and_why(tmp_path) -> None:
    m = load_map(MAP)
    plan = _plan(m)
    timeline = replay(plan_to_items(plan, m), m)
    fig = mission_figure(m, timeline=timeline)
    texts = _texts(fig)
    # sensor ids and hover points "order · seconds"
    assert "north" in texts
    assert "1 · 40 s" in texts and "2 · 30 s" in texts
    # short sensors ringed with what they got; the one out of reach got nothing
    got = timeline.collected
    big = m.sensor_ids.index("big")
    assert f"big: {got[big]:.0f} of 5000 Mbit" in texts
    assert "far: 0 of 200 Mbit" in texts
    labels = [t for t in texts if "not reached" in t or "inside obstacles (C5)" in t]
    assert any("not reached" in t for t in labels)
    # the last leg (1500, 500) -> end crosses the circle: 200 m drawn in red, named in the legend
    segs = _violation_segments(m, np.asarray(timeline.path))
    assert abs(sum(np.hypot(*np.diff(s, axis=0).T).sum() for s in segs) - 200.0) < 1.0
    assert any(t.startswith("path inside obstacles (C5): 200 m") for t in texts)
    # the data-over-time panel from the replay
    assert "mission time (s)" in texts and "required" in texts
    out = plot_mission(m, tmp_path / "bad.png", timeline=timeline)
    assert out.stat().st_size > 10_000
    # the figure follows the area's shape: 3:1 area, the map panel is wider than tall
    ax = fig.axes[0]
    bbox = ax.get_position()
    w, h = fig.get_size_inches()
    assert bbox.width * w > 1.8 * bbox.height * h * (2 / 3)  # map panel, not the time panel


def test_feasible_plan_and_map_alone(tmp_path) -> None:
    m = load_map({**MAP, "sensors": MAP["sensors"][:1]})
    p = Problem(m)
    b = p.breakdown(p.encode([[800, 650]], [30.0]))
    plan = SimpleNamespace(hover_points=np.array(b["hover_points"]),
                           hover_times=np.array(b["hover_times"]), f=b["f"], breakdown=b)
    fig = mission_figure(m, plan=plan)
    texts = _texts(fig)
    assert "north" in texts and "1 · 30 s" in texts
    assert not any("Mbit" in t for t in texts)  # nothing short, nothing ringed
    svg = plot_mission(m, tmp_path / "map.svg")  # the map alone
    assert b"north" in svg.read_bytes()
