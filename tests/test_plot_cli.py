"""The figure, and the `verify` / `show` commands through a real subprocess."""

from __future__ import annotations

import json
from dataclasses import replace
from types import SimpleNamespace

import pytest

from lamde_mission.formats import write_mission
from lamde_mission.formats.waypoints import write_waypoints
from lamde_mission.items import CMD, plan_to_items
from lamde_mission.plot import nice_length, plot_mission
from planner_core.model.mapio import load_map
from sim import replay
from tests.conftest import one_line_error, plan_at, run_cli, run_cli_many

MAP = {
    "name": "cli",
    "origin": {"lat": 22.3193, "lon": 114.1694, "alt": 0.0},
    "area": {"width": 2000, "height": 1500},
    "start": [50, 50],
    "end": [1900, 1400],
    "sensors": [{"id": "a", "x": 500, "y": 300}, {"id": "b", "x": 1400, "y": 1000}],
    "obstacles": {
        "circles": [{"x": 1000, "y": 400, "radius": 70}],
        "rectangles": [{"x": 400, "y": 1100, "length": 150, "width": 80, "angle_deg": 60}],
        "no_fly_zones": [{"vertices": [[1500, 200], [1800, 250], [1650, 500]]}],
    },
    "uav": {"max_hover_points": 3},
}
HOVER = [[500, 320], [1400, 980]]
TIMES = [45.0, 50.0]


def _plan(m):
    return plan_at(m, HOVER, TIMES)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A map, a feasible .plan, and a .waypoints with one hover time cut (fails C4)."""
    d = tmp_path_factory.mktemp("cli")
    (d / "map.json").write_text(json.dumps(MAP))
    m = load_map(MAP)
    plan = _plan(m)
    assert plan.feasible
    write_mission(d / "good.plan", plan, m)
    items = plan_to_items(plan, m)
    k = next(i for i, it in enumerate(items) if it.command == CMD.LOITER_TIME)
    items[k] = replace(items[k], param1=2.0)
    from lamde_mission.formats import home_of

    write_waypoints(d / "cut.waypoints", items, home_of(m))
    return SimpleNamespace(dir=d, map=d / "map.json", good=d / "good.plan",
                           cut=d / "cut.waypoints", m=m, plan=plan)  # fmt: skip


# ----------------------------------------------------------------------------- figure


def test_nice_length():
    assert nice_length(5000) == 1000
    assert nice_length(10_000) == 2000
    assert nice_length(2000) == 200
    assert nice_length(1200) == 200
    assert nice_length(3000) == 500


@pytest.mark.slow  # measured 1.5 s on a loaded machine (default suite <= 5 min)
def test_plot_png_svg_and_bad_suffix(files, tmp_path):
    tl = replay(plan_to_items(files.plan, files.m, finish="rtl"), files.m)
    png = plot_mission(files.m, tmp_path / "a.png", timeline=tl)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    svg = plot_mission(files.m, tmp_path / "b.svg", plan=files.plan, title="plan")
    head = svg.read_text()[:400]
    assert "<svg" in head or head.startswith("<?xml")
    plot_mission(files.m, tmp_path / "c.png")  # the map alone
    with pytest.raises(ValueError, match="PNG or SVG"):
        plot_mission(files.m, tmp_path / "d.jpg")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.svg", "c.png"]


def test_svg_saves_are_byte_identical_and_leave_rcparams_alone(files, tmp_path):
    """The same figure saved twice as SVG gives the same bytes: matplotlib wrote the time of
    saving (`<dc:date>`) and clip-path ids salted at random; the fixed salt is set for the save
    only, not in the caller's rcParams. PNG was already the same."""
    import matplotlib

    from lamde_mission.plot import SVG_HASHSALT, mission_figure, save_figure

    fig = mission_figure(files.m, plan=files.plan, title="plan")
    before = matplotlib.rcParams["svg.hashsalt"]
    a = save_figure(fig, tmp_path / "a.svg").read_bytes()
    b = save_figure(fig, tmp_path / "b.svg").read_bytes()
    assert b"clip-path=" in a and b"<dc:date>" not in a
    assert a == b
    assert matplotlib.rcParams["svg.hashsalt"] == before != SVG_HASHSALT
    assert save_figure(fig, tmp_path / "a.png").read_bytes() \
        == save_figure(fig, tmp_path / "b.png").read_bytes()


# ----------------------------------------------------------------------------- verify


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_verify_good_mission_exits_0(files):
    r, rj = run_cli_many(("verify", files.map, files.good),
                         ("verify", files.map, files.good, "--json"))
    assert r.returncode == 0, r.stdout + r.stderr
    for name in ("C1", "C2", "C3", "C4", "C5"):
        line = next(ln for ln in r.stdout.splitlines() if ln.startswith(name))
        assert "PASS" in line
    assert "all constraints hold" in r.stdout
    assert rj.returncode == 0
    out = json.loads(rj.stdout)
    assert out["passed"] is True
    # the file holds the storable plan (points on the 1e-7 degree grid, float32 values)
    assert out["totals"]["f"] == pytest.approx(files.plan.f, rel=1e-5)


@pytest.mark.slow  # measured 1.4 s on a loaded machine (default suite <= 5 min)
def test_verify_cut_mission_exits_1_naming_c4(files):
    r = run_cli("verify", files.map, files.cut)
    assert r.returncode == 1, r.stdout + r.stderr
    line = next(ln for ln in r.stdout.splitlines() if ln.startswith("C4"))
    assert "FAIL" in line
    assert "FAILED C4" in r.stdout


@pytest.mark.slow  # measured 6 s (issue 35: default suite <= 5 min)
def test_verify_bad_input_exits_2_with_one_line(files, tmp_path):
    junk = tmp_path / "junk.plan"
    junk.write_text("{not json")
    geo = write_mission(tmp_path / "m.geojson", files.plan, files.m)
    results = run_cli_many(
        ("verify", files.map, junk),
        ("verify", tmp_path / "nomap.json", files.good),
        ("verify", files.map, geo),
    )
    lines = [one_line_error(r) for r in results]
    assert "junk.plan" in lines[0] and "not valid JSON" in lines[0]
    assert "nomap.json" in lines[1]
    assert "GeoJSON" in lines[2]


# ----------------------------------------------------------------------------- show


@pytest.mark.slow  # measured 7 s (issue 35: default suite <= 5 min)
def test_show_writes_png(files, tmp_path):
    out, out2 = tmp_path / "fig.png", tmp_path / "map.svg"
    r, r2 = run_cli_many(("show", files.map, files.good, "-o", out),
                         ("show", files.map, "-o", out2))
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:4] == b"\x89PNG"
    assert r2.returncode == 0, r2.stderr
    assert "<svg" in out2.read_text()[:400]


@pytest.mark.slow  # measured 1.8 s on a loaded machine (default suite <= 5 min)
def test_show_bad_input_leaves_no_file(files, tmp_path):
    junk = tmp_path / "junk.waypoints"
    junk.write_text("QGC WPL 110\n0\t1\t0\n")
    r1, r2 = run_cli_many(("show", files.map, junk, "-o", tmp_path / "fig.png"),
                      ("show", files.map, files.good, "-o", tmp_path / "fig.jpg"))  # fmt: skip
    assert "junk.waypoints" in one_line_error(r1)
    assert ".png or .svg" in one_line_error(r2)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["junk.waypoints"]


@pytest.mark.parametrize("dpi", ["10000", "601", "0", "-5"])
def test_show_dpi_is_bounded_one_line_exit_2(files, tmp_path, capsys, dpi):
    """--dpi outside 1..MAX_DPI (600) is refused before any drawing (6,000 took 11 GB, 10,000
    a MemoryError traceback); the API's save_figure refuses it too."""
    from lamde_mission.cli import main
    from lamde_mission.plot import MAX_DPI, mission_figure, save_figure

    out = tmp_path / "fig.png"
    assert main(["show", str(files.map), str(files.good), "-o", str(out), "--dpi", dpi]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"--dpi: must be an integer from 1 to {MAX_DPI}" in err[0], err
    assert not out.exists()
    with pytest.raises(ValueError, match=r"^dpi: must be an integer from 1 to 600"):
        save_figure(mission_figure(files.m), out, dpi=int(dpi))
    assert not out.exists()
