"""`show` of a mission whose DO_JUMP repeats a loop: each distinct leg, hover point and corner
drawn once, labelled with its passes ("1 · 45 s ×24,000"), so the figure's artists and labels
are as many at 24,000 passes as at 3 (one band and label per replayed visit before: a
24,000-pass loop did not finish)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.text import Text

import lamde_mission.plot as plot
from lamde_mission.cli import main
from lamde_mission.formats import home_of
from lamde_mission.formats.qgc_plan import write_qgc_plan
from lamde_mission.items import CMD, MissionItem, plan_to_items
from planner_core.model.mapio import load_map
from sim import replay
from sim.obstacles import distinct_rows, unique_legs
from tests.conftest import drawn_figures, plan_at

MAP = {
    "name": "loop",
    "origin": {"lat": 22.3193, "lon": 114.1694, "alt": 0.0},
    "area": {"width": 2000, "height": 1500},
    "start": [50, 50],
    "end": [1900, 1400],
    "sensors": [{"id": "a", "x": 500, "y": 300}, {"id": "b", "x": 1400, "y": 1000}],
    "obstacles": {"circles": [{"x": 1000, "y": 400, "radius": 70}]},
    "uav": {"max_hover_points": 3},
}
HOVER = [[500, 320], [1400, 980]]
TIMES = [45.0, 50.0]


def _loop(m, passes: int, *, corner: bool = False) -> list[MissionItem]:
    """The plan's items with a DO_JUMP after the second hover back to the first, flying the
    loop `passes` times; with `corner`, a NAV_WAYPOINT without hold (a corner) in the loop."""
    items = plan_to_items(plan_at(m, HOVER, TIMES), m)
    k = [i for i, it in enumerate(items) if it.command == CMD.LOITER_TIME]
    extra = [replace(items[k[1]], command=CMD.WAYPOINT, param1=0.0, x=items[k[1]].x + 0.002)
             ] if corner else []  # fmt: skip
    jump = replace(items[k[1]], command=CMD.DO_JUMP, param1=float(k[0]), param2=passes - 1.0,
                   param3=0.0, param4=0.0, x=0.0, y=0.0, z=0.0)  # fmt: skip
    out = items[:k[1] + 1] + extra + [jump] + items[k[1] + 1:]
    return [replace(it, seq=i) for i, it in enumerate(out)]


def _counts(ax) -> dict[str, int]:
    return {"texts": len(ax.texts), "lines": len(ax.lines), "collections": len(ax.collections),
            "patches": len(ax.patches), "artists": len(ax.artists)}  # fmt: skip


def _map_texts(fig) -> list[str]:
    return [t.get_text() for t in fig.axes[0].texts if t.get_text()]


def _legend(fig) -> list[str]:
    """The legends' entries and titles (a title holds the note of labels left out)."""
    return [t.get_text() for lg in fig.legends for t in (*lg.get_texts(), lg.get_title())]


def test_distinct_rows_in_first_seen_order() -> None:
    rows = np.array([[3.0, 1.0], [1.0, 2.0], [3.0, 1.0], [0.0, 0.0], [1.0, 2.0], [3.0, 1.0]])
    first, counts, inverse = distinct_rows(rows)
    assert first.tolist() == [0, 1, 3] and counts.tolist() == [3, 2, 1]
    assert inverse.tolist() == [0, 1, 0, 2, 1, 0]
    assert [len(x) for x in distinct_rows(np.zeros((0, 3)))] == [0, 0, 0]
    lap = np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 5.0], [0.0, 5.0]])
    path = np.vstack([[-1.0, -1.0], *[lap] * 4, [9.0, 9.0]])
    legs, n = unique_legs([path], flown_order=True)
    assert legs[0].tolist() == [[-1.0, -1.0], [0.0, 0.0]]  # flown first, drawn first
    assert legs[-1].tolist() == [[0.0, 5.0], [9.0, 9.0]] and len(legs) == 6
    assert n.tolist() == [1, 4, 4, 4, 3, 1]
    sorted_legs, sorted_n = unique_legs([path])  # the checks' order: by coordinates
    assert sorted(map(str, sorted_legs.tolist())) == sorted(map(str, legs.tolist()))
    assert sorted(sorted_n.tolist()) == sorted(n.tolist())


def test_a_loop_is_drawn_once_labelled_with_its_passes() -> None:
    """The map panel holds as many artists and labels at 300 passes as at 3; the hover points
    are numbered in the order first visited, with their passes; the data panel shades the
    hovers as one collection and numbers them as the map does."""
    m = load_map(MAP)
    figs = {n: plot.mission_figure(m, timeline=replay(_loop(m, n, corner=True), m))
            for n in (3, 300)}  # fmt: skip
    assert _counts(figs[3].axes[0]) == _counts(figs[300].axes[0])
    for n, fig in figs.items():
        texts = _map_texts(fig)
        assert f"1 · 45 s ×{n:,}" in texts and f"2 · 50 s ×{n:,}" in texts
        assert not any(t.startswith("3 ·") for t in texts)
        assert "hover point: order · seconds ×passes (DO_JUMP)" in _legend(fig)
        assert "corner, flown through (1)" in _legend(fig)
        # the distinct legs, in the order first flown: start 1 2 corner 1, then (a break)
        # corner end end (the landing), not 3 stops per pass
        path = fig.axes[0].lines[0].get_xydata()
        assert len(path) == 9 and np.isnan(path[5]).all()
        np.testing.assert_allclose(path[[0, 1, 2, 4, 7]], [MAP["start"], *HOVER, HOVER[0],
                                                           MAP["end"]], atol=0.05)  # fmt: skip
        ax_t = fig.axes[1]
        bands = [c for c in ax_t.collections if isinstance(c, PolyCollection)]
        assert len(bands) == 1 and not ax_t.patches
        numbers = [t.get_text() for t in ax_t.texts if t.get_text().isdigit()]
        assert set(numbers) == {"1", "2"} and len(numbers) <= 60
    assert _legend(figs[3]) == _legend(figs[300])


def test_a_normal_mission_keeps_its_labels() -> None:
    m = load_map(MAP)
    tl = replay(plan_to_items(plan_at(m, HOVER, TIMES), m), m)
    fig = plot.mission_figure(m, timeline=tl)
    texts = _map_texts(fig)
    assert "1 · 45 s" in texts and "2 · 50 s" in texts and not any("×" in t for t in texts)
    assert "hover point: order · seconds" in _legend(fig)
    line = fig.axes[0].lines[0].get_xydata()
    np.testing.assert_array_equal(line, tl.path)  # the path itself, no break
    numbers = [t.get_text() for t in fig.axes[1].texts if t.get_text().isdigit()]
    assert numbers == ["1", "2"]


def test_hover_labels_are_capped_and_counted(monkeypatch) -> None:
    m = load_map(MAP)
    monkeypatch.setattr(plot, "HOVER_LABELS", 1)
    tl = replay(plan_to_items(plan_at(m, HOVER, TIMES), m), m)
    fig = plot.mission_figure(m, timeline=tl)
    texts = _map_texts(fig)
    assert "1 · 45 s" in texts and not any(t.startswith("2 ") for t in texts)
    assert any(t.startswith("hover points past the first 1 unlabelled (1)")
               for t in _legend(fig))  # fmt: skip
    fleet = plot.fleet_figure(m, [plot.SortieView(1, 1, tl)])
    assert "1.1 · 45 s" in _map_texts(fleet) and not any(
        t.startswith("1.2") for t in _map_texts(fleet))
    assert any(t.startswith("hover points past the first 1 unlabelled (1)")
               for t in _legend(fleet))  # fmt: skip


def test_the_fleet_figure_draws_a_looping_sortie_once() -> None:
    m = load_map(MAP)
    figs = {n: plot.fleet_figure(m, [plot.SortieView(1, 1, replay(_loop(m, n), m))])
            for n in (3, 300)}  # fmt: skip
    assert _counts(figs[3].axes[0]) == _counts(figs[300].axes[0])
    assert "1.2 · 50 s ×300" in _map_texts(figs[300])


def _show(tmp_path: Path, passes: int, monkeypatch) -> tuple[object, Path]:
    """`lamde-mission show MAP MISSION -o OUT` in this process on the loop of `passes`; the
    figure it drew and the image."""
    m = load_map(MAP)
    (tmp_path / "map.json").write_text(json.dumps(MAP))
    mission = write_qgc_plan(tmp_path / f"loop{passes}.plan", _loop(m, passes),
                             home=home_of(m), cruise_speed=20.0)  # fmt: skip
    out = tmp_path / f"loop{passes}.png"
    drawn = drawn_figures(monkeypatch)
    assert main(["show", str(tmp_path / "map.json"), str(mission), "-o", str(out)]) == 0
    return drawn[0], out


@pytest.mark.slow  # measured 10 s: the sim replays 72,000 items (issue 35: default suite <= 5 min)
def test_show_of_a_24000_pass_loop_exits_0_with_the_artists_of_3(tmp_path, monkeypatch) -> None:
    few, _ = _show(tmp_path, 3, monkeypatch)
    many, out = _show(tmp_path, 24_000, monkeypatch)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert _counts(few.axes[0]) == _counts(many.axes[0])
    assert "1 · 45 s ×24,000" in _map_texts(many)
    total = sum(len(ax.findobj(Text)) for ax in many.axes)
    assert total <= sum(len(ax.findobj(Text)) for ax in few.axes) + 60  # the panel's numbers
