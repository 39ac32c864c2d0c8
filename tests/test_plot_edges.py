"""Figures of missions at the edges: `show` of a mission that gives no sensor any data (no hover
point, or none in range), of a map that requires no data, and of a mission on the wrong map
(thousands of km from its area) exits 0 and writes the picture, each saying so in the figure
(an IndexError traceback in the data panel before: `_bends` of lines that never change); two
depots 30 m apart are each named on their own side; the data panel's end labels of sensors
finishing at close shares do not overlap."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.text import Annotation, Text

import lamde_mission.plot as plot
from lamde_mission.cli import main
from lamde_mission.commands.verify import replay_mission_file
from lamde_mission.formats import home_of
from lamde_mission.formats.qgc_plan import write_qgc_plan
from lamde_mission.items import plan_to_items
from planner_core.model.mapio import load_map
from sim import replay
from tests.conftest import drawn_figures, plan_at

#: twelve sensors (past TIME_LINES: the bar panel is drawn too) on a 2 x 1.5 km area
MAP = {
    "name": "edges",
    "origin": {"lat": 22.3193, "lon": 114.1694, "alt": 0.0},
    "area": {"width": 2000, "height": 1500},
    "start": [50, 50],
    "end": [1900, 1400],
    "sensors": [{"id": f"s{k + 1}", "x": 300.0 + 450.0 * (k % 4), "y": 300.0 + 400.0 * (k // 4)}
                for k in range(12)],  # fmt: skip
    "obstacles": {"circles": [{"x": 1000, "y": 500, "radius": 60}]},
    "uav": {"max_hover_points": 3},
}
#: the same map 9,000 km away (another origin): a mission written for MAP lies far from it
FAR = {**MAP, "name": "elsewhere", "origin": {"lat": 52.0, "lon": 5.1, "alt": 0.0}}
#: the same map with links of 100 m (R_c / xi = 10 / 0.1): a hover 150 m from every sensor
#: gets nothing
SHORT_RANGE = {**MAP, "name": "short-range", "radio": {"decay": 0.1}}
#: no sensor requires any data
NONE_REQUIRED = {**MAP, "name": "none-required",
                 "sensors": [{**s, "required_data": 0} for s in MAP["sensors"]]}  # fmt: skip

#: (map, hover points, hover times): a corner only (no hover point), a hover out of every
#: sensor's range (between four of them), a hover beside a sensor drawn on the map that
#: requires nothing and on the map far away
CASES = {
    "no-hover": (MAP, [[1000, 700]], [0.0]),
    "out-of-range": (SHORT_RANGE, [[525, 500]], [30.0]),
    "none-required": (NONE_REQUIRED, [[320, 320]], [30.0]),
    "far": (FAR, [[320, 320]], [30.0]),
}


def _show(tmp_path: Path, case: str, monkeypatch, capsys) -> tuple[object, Path]:
    """`lamde-mission show MAP MISSION -o OUT` in this process for `CASES[case]` (the mission
    written for MAP, drawn on the case's map); the figure it drew and the image."""
    spec, hover, times = CASES[case]
    m = load_map(MAP)
    mission = write_qgc_plan(tmp_path / f"{case}.plan",
                             plan_to_items(plan_at(m, hover, times), m), home=home_of(m),
                             cruise_speed=20.0)  # fmt: skip
    (tmp_path / f"{case}.json").write_text(json.dumps(spec))
    drawn = drawn_figures(monkeypatch)
    out = tmp_path / f"{case}.png"
    assert main(["show", str(tmp_path / f"{case}.json"), str(mission), "-o", str(out)]) == 0
    assert "Traceback" not in capsys.readouterr().err
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return drawn[0], out


@pytest.mark.parametrize("case", list(CASES))
def test_show_draws_a_mission_without_data_or_far_away(tmp_path, monkeypatch, capsys,
                                                       case) -> None:  # fmt: skip
    """Every panel drawn (map, colour bar, data, bars), the figure written, exit 0; the data
    panel's title says why no sensor got data (or that none needs any), and the map's title
    that the mission lies far away, the view kept on the map's area."""
    fig, _ = _show(tmp_path, case, monkeypatch, capsys)
    ax, ax_t = fig.axes[0], fig.axes[1]
    assert len(fig.axes) == 4  # map, colour bar, data over time, bars
    data_title = ax_t.get_title().replace("\n", " ")
    expected = {"no-hover": "no sensor got any data: the mission has no hover point (LOITER)",
                "out-of-range": "no sensor got any data: none within range of a hover point",
                "none-required": "every sensor requires 0 Mbit",
                "far": "no sensor got any data"}[case]  # fmt: skip
    assert expected in data_title, data_title
    title = ax.get_title().replace("\n", " ")
    if case == "far":
        assert "the mission lies" in title and "km from this map's area, not drawn" in title
        km = float(title.split("the mission lies ")[1].split(" km")[0].replace(",", ""))
        assert km > 5000.0
        # the view stays on the area (2 x 1.5 km and a pad), not 9,000 km wide
        assert ax.get_xlim()[1] - ax.get_xlim()[0] < 5000.0
        assert ax.get_ylim()[1] - ax.get_ylim()[0] < 5000.0
    else:
        assert "km from this map's area" not in title
    # every named line's end label inside the data panel
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    frame = ax_t.get_window_extent(r)
    ends = [a for a in ax_t.texts if isinstance(a, Annotation) and "%" in a.get_text()]
    assert len(ends) == plot.TIME_LINES
    for a in ends:
        e = Text.get_window_extent(a, r)
        assert frame.y0 - 0.5 <= e.y0 and e.y1 <= frame.y1 + 0.5, (a.get_text(), e.bounds)


def test_bends_of_lines_that_never_change_are_their_ends() -> None:
    """`_bends` of columns none of which changes (no sensor gets data): each line its first
    and last sample (an IndexError before: no changing pair at all)."""
    t = np.linspace(0.0, 10.0, 50)
    k = plot._bends(t, np.zeros((50, 3)), 1e-9)
    assert [x.tolist() for x in k] == [[0, 49]] * 3


def test_a_fleet_far_from_the_map_is_not_drawn_and_the_title_says_so(tmp_path) -> None:
    """Sorties replayed on the wrong map (9,000 km away) leave the view on the map's area and
    their depots at the map's; the title names how far they are."""
    m = load_map(MAP)
    items = plan_to_items(plan_at(m, [[320, 320]], [30.0]), m)
    path = write_qgc_plan(tmp_path / "m.plan", items, home=home_of(m), cruise_speed=20.0)
    far = load_map(FAR)
    tl = replay_mission_file(str(path), far)  # the same lat/lon: 9,000 km from FAR's area
    fig = plot.fleet_figure(far, [plot.SortieView(1, 1, tl, "home", "end"),
                                  plot.SortieView(1, 2, tl, "home", "end")])  # fmt: skip
    ax = fig.axes[0]
    title = ax.get_title().replace("\n", " ")
    assert "every sortie lies" in title and "km or more from this map's area, not drawn" in title
    assert "2 sorties, 1 swap" in title
    assert ax.get_xlim()[1] - ax.get_xlim()[0] < 5000.0
    assert {t.get_text() for t in ax.texts} >= {"home", "end"}
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "battery swap" not in legend  # no star drawn for a sortie not drawn


def test_close_depots_are_each_named_on_their_own_side() -> None:
    """Two depots 30 m apart (home (50, 50) and end (50, 80), their hexagons touching): each
    name's box is nearer its own depot than the other, in display pixels ("home" sat beside
    end's hexagon before, and "end" beside home's)."""
    d = {**MAP, "start": [50, 50], "end": [50, 80]}
    m = load_map(d)
    tl = replay(plan_to_items(plan_at(m, [[320, 320], [1200, 700]], [30.0, 30.0]), m), m)
    fig = plot.fleet_figure(m, [plot.SortieView(1, 1, tl, "home", "end"),
                                plot.SortieView(1, 2, tl, "home", "end")])  # fmt: skip
    ax = fig.axes[0]
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    depots = {"home": ax.transData.transform((50.0, 50.0)),
              "end": ax.transData.transform((50.0, 80.0))}  # fmt: skip
    assert np.hypot(*(depots["home"] - depots["end"])) < 30.0  # closer than a label's height
    for name, own in depots.items():
        (label,) = [t for t in ax.texts if t.get_text() == name]
        e = Text.get_window_extent(label, r)
        centre = np.array([(e.x0 + e.x1) / 2, (e.y0 + e.y1) / 2])
        other = depots["end" if name == "home" else "home"]
        assert np.hypot(*(centre - own)) < np.hypot(*(centre - other)), (name, e.bounds)


def _close_shares(n: int = 8):
    """A map of `n` sensors in a row, a hover point beside each, each sensor's requirement
    set so that it ends at 100 + k/2 % (k = 0..n-1): close lines, close end labels."""
    d = {**MAP, "sensors": [{"id": f"soil-{k + 1}", "x": 200.0 + 220.0 * k, "y": 600.0}
                            for k in range(n)], "uav": {"max_hover_points": n}}  # fmt: skip
    m = load_map(d)
    hover = [[200.0 + 220.0 * k, 620.0] for k in range(n)]
    items = plan_to_items(plan_at(m, hover, [20.0] * n), m)
    got = replay(items, m).collected
    for k, s in enumerate(d["sensors"]):
        s["required_data"] = float(got[k]) / (1.0 + 0.005 * k)
    m = load_map(d)
    return m, replay(plan_to_items(plan_at(m, hover, [20.0] * n), m), m)


def test_end_labels_of_close_lines_do_not_overlap() -> None:
    """Eight sensors ending at 100.0-103.5 %: their end labels ("soil-1 102 %") are apart (no
    two boxes overlap, in display pixels), inside the panel, in the order of their shares, and
    each moved off its line's end joined to it by a thin line (they were spread by 7 % of the
    axis before, less than a label's height: drawn over one another)."""
    m, tl = _close_shares()
    final = 100.0 * tl.collected / np.asarray(m.required_data)
    assert np.ptp(final) < 5.0
    fig = plot.mission_figure(m, timeline=tl)
    ax_t = fig.axes[1]
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    ends = [a for a in ax_t.texts if isinstance(a, Annotation) and "%" in a.get_text()]
    assert len(ends) == 8
    boxes = [Text.get_window_extent(a, r) for a in ends]
    for (a, ea), (b, eb) in itertools.combinations(zip(ends, boxes, strict=True), 2):
        assert not ea.overlaps(eb), (a.get_text(), b.get_text(), ea.bounds, eb.bounds)
    frame = ax_t.get_window_extent(r)
    assert all(frame.y0 - 0.5 <= e.y0 and e.y1 <= frame.y1 + 0.5 for e in boxes)
    share = {a.get_text().split()[0]: final[m.sensor_ids.index(a.get_text().split()[0])]
             for a in ends}  # fmt: skip
    by_height = [a.get_text().split()[0] for _, a in sorted(zip([e.y0 for e in boxes], ends,
                                                                strict=True),
                                                            key=lambda p: p[0])]  # fmt: skip
    assert by_height == sorted(share, key=lambda s: (share[s], by_height.index(s)))
    moved = [a for a, e in zip(ends, boxes, strict=True)
             if abs((e.y0 + e.y1) / 2 - ax_t.transData.transform(a.xy)[1]) > e.height]
    assert moved and all(a.arrow_patch.get_visible() for a in moved)


def test_spread_keeps_labels_apart_near_their_targets_and_inside() -> None:
    """`_spread`: labels far apart stay where they are; a crowd is spread about its targets,
    each neighbour its mean height apart, in the targets' order; a crowd at an edge is pushed
    inside."""
    h = np.full(3, 10.0)
    assert plot._spread(np.array([50.0, 10.0, 90.0]), h, 0.0, 100.0).tolist() == [50, 10, 90]
    y = plot._spread(np.array([50.0, 50.0, 51.0]), h, 0.0, 100.0)
    assert np.allclose(np.diff(y), 10.0) and np.isclose(y.mean(), 151.0 / 3)
    assert np.allclose(plot._spread(np.array([0.0, 1.0, 0.5]), h, 0.0, 100.0), [5, 25, 15])
    assert np.allclose(plot._spread(np.array([99.0, 100.0, 98.0]), h, 0.0, 100.0), [85, 95, 75])
