"""The benchmark generator: committed suite maps and their witnesses, determinism, the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planner_core import Problem, load_map
from planner_core.model.geometry import points_inside
from planner_core.suite import (
    SIZES,
    SUITE_SEED,
    default_sensor_count,
    dumps_map,
    generate_map,
    obstacle_counts,
    suite_tasks,
)
from tests.conftest import MAPS, SUITE, run_cli

TASKS = suite_tasks()


def _witness(problem: Problem, data: dict) -> dict:
    w = data["witness"]
    return problem.breakdown(problem.encode(w["hover_points"], w["hover_times"]))


def test_suite_table() -> None:
    assert [t[0] for t in TASKS] == [f"T{k:02d}" for k in range(1, 17)]
    assert [t[1] for t in TASKS] == [5000] * 8 + [10000] * 8
    assert sorted(p.name for p in SUITE.glob("*.json")) == [f"{t[0]}.json" for t in TASKS]
    from lamde_mission.commands.generate import _DEFAULT_SEED

    assert _DEFAULT_SEED == SUITE_SEED  # the CLI's default reproduces the committed suite


@pytest.mark.parametrize(("name", "size", "density"), TASKS)
def test_committed_map(name: str, size: int, density: int) -> None:
    data = json.loads((SUITE / f"{name}.json").read_text())
    m = load_map(data)
    assert m.name == name and m.width == m.height == size
    assert data["uav"] == {"max_hover_points": SIZES[size]}  # the rest at defaults
    assert set(data) == {"name", "origin", "area", "start", "end", "sensors", "obstacles", "uav",
                         "safety", "witness"}  # fmt: skip
    # the paper's model as it is: the suite says so explicitly
    assert data["safety"] == {"clearance": 0, "data_margin": 0}
    lo, hi = (8, 15) if size == 5000 else (15, 30)
    assert lo <= len(m.sensors) <= hi
    assert len(m.sensors) == default_sensor_count(size, density)
    obs = m.spec.obstacles
    counts = (len(obs.circles), len(obs.rectangles), len(obs.no_fly_zones))
    assert counts == obstacle_counts(size, density)

    # paper Sec. 3.2 dimensions; no-fly zones written counter-clockwise
    assert all(40 <= c.radius <= 100 for c in obs.circles)
    assert all(80 <= r.length <= 180 and 80 <= r.width <= 180 for r in obs.rectangles)
    assert all(0 <= r.angle_deg < 180 for r in obs.rectangles)
    assert not m.notes  # no "reordered counter-clockwise" note
    for z in m.nfz_polygons:
        assert 3 <= len(z) <= 7
        diameter = np.max(np.linalg.norm(z[:, None, :] - z[None, :, :], axis=2))
        assert 3000 <= diameter <= 4000
        assert np.all((z >= 0) & (z <= size))
    # sensors in the open; start and end too (load_map checks those)
    assert not np.any(points_inside(m.sensors, m.obstacles))

    problem = Problem(m)
    b = _witness(problem, data)
    assert b["phi"] == 0.0 and b["l_vio"] == 0.0
    w = m.spec.witness
    hp, ht = np.array(w.hover_points), np.array(w.hover_times)
    assert 1 <= len(hp) <= SIZES[size]
    assert np.all((ht >= 0) & (ht <= m.spec.uav.max_hover_time))
    assert np.all((hp >= 0) & (hp <= size))
    # realistic hover times: every sensor gets its data, none hovers much longer than needed
    collected = np.array(list(b["collected"].values()))
    assert np.all(collected >= 200) and np.min(collected) < 1.05 * 200
    rates = problem.rates(hp)
    for i in np.flatnonzero(ht > 0):  # each hover is just long enough for a sensor it serves
        assert np.any((rates[i] > 0) & (collected < 1.05 * 200))


def test_density_grows_and_densest_is_dense() -> None:
    for size in SIZES:
        rows = [obstacle_counts(size, d) for d in range(8)]
        totals = [c + r for c, r, _ in rows]
        assert all(a < b for a, b in zip(totals, totals[1:], strict=False))
        for k in range(3):
            assert all(a[k] <= b[k] for a, b in zip(rows, rows[1:], strict=False))
    circles, rects, nfz = obstacle_counts(10000, 7)
    assert 50 <= circles <= 60 and 50 <= rects <= 60 and 3 <= nfz <= 4


def test_densest_maps_block_the_straight_line() -> None:
    for name in ("T08", "T16"):
        p = Problem(SUITE / f"{name}.json")
        straight = p.breakdown(p.encode(np.zeros((0, 2)), []))
        assert straight["l_vio"] > 1000  # flying start -> end directly crosses obstacles


def test_deterministic_and_seed_sensitive() -> None:
    a = generate_map(5000, 3, 7)
    assert generate_map(5000, 3, 7) == a
    assert dumps_map(generate_map(5000, 3, 7)) == dumps_map(a)
    b = generate_map(5000, 3, 8)
    assert b["sensors"] != a["sensors"] and b["witness"] != a["witness"]
    assert json.loads(dumps_map(a)) == a
    assert max(len(line) for line in dumps_map(a).splitlines()) <= 100


def test_many_sensors_and_names() -> None:
    data = generate_map(5000, 7, 11, name="crowded", n_sensors=20)
    assert data["name"] == "crowded" and len(data["sensors"]) == 20
    b = _witness(Problem(data), data)
    assert b["phi"] == 0.0


@pytest.mark.parametrize(
    "kwargs",
    [
        {"size": 7000, "density": 0},
        {"size": 5000, "density": 8},
        {"size": 5000, "density": -1},
        {"size": 5000, "density": 0, "seed": -1},
        {"size": 5000, "density": 0, "n_sensors": 0},
        {"size": 5000, "density": 0, "n_sensors": 21},
    ],
)
def test_bad_arguments_raise(kwargs: dict) -> None:
    with pytest.raises(ValueError):
        generate_map(**kwargs)


@pytest.mark.slow  # measured 1.4 s on a loaded machine (default suite <= 5 min)
def test_cli_suite_reproduces_committed_files(tmp_path: Path) -> None:
    out = run_cli("generate", "--suite", str(tmp_path / "suite"))
    assert out.returncode == 0, out.stderr
    differ = [
        p.name
        for p in sorted(SUITE.glob("*.json"))
        if (tmp_path / "suite" / p.name).read_bytes() != p.read_bytes()
    ]
    assert not differ, f"committed suite maps differ from `generate --suite`: {differ}"
    assert sorted(p.name for p in (tmp_path / "suite").iterdir()) == [f"{t[0]}.json" for t in TASKS]


@pytest.mark.slow  # measured 1.3 s on a loaded machine (default suite <= 5 min)
def test_cli_one_map(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "m.json"
    args = ("generate", str(path), "--size", "5000", "--density", "2", "--seed", "5")
    out = run_cli(*args, "--sensors", "9", "--name", "mine")
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith(f"wrote {path}")
    assert path.read_text() == dumps_map(generate_map(5000, 2, 5, name="mine", n_sensors=9))
    from lamde_mission.cli import main

    assert main(["check", str(path)]) == 0
    assert "witness" in capsys.readouterr().out


@pytest.mark.parametrize(
    "args",
    [
        ["x.json", "--size", "7000", "--density", "1"],
        ["x.json", "--size", "abc", "--density", "1"],
        ["x.json", "--size", "5000"],
        ["x.json", "--size", "5000", "--density", "8"],
        ["x.json", "--size", "5000", "--density", "1", "--sensors", "0"],
        ["x.json", "--size", "5000", "--density", "1", "--seed", "-3"],
        ["--suite", "out", "x.json"],
        [],
    ],
)
def test_cli_bad_arguments(args: list[str], tmp_path: Path) -> None:
    out = run_cli("generate", *args, cwd=tmp_path)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("lamde-mission generate: "), out.stderr
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.parametrize(("args", "line"), [
    # said "one map needs --size (5000 or 10000) and --density (0..7)", as if --size were missing
    (["--size", "7000"], "--size must be 5000 or 10000 without --layout (got 7000)"),
    (["--size", "7000", "--density", "1"],
     "--size must be 5000 or 10000 without --layout (got 7000)"),
    (["--density", "9"], "--density must be 0..7 (got 9)"),
    (["--size", "5000", "--density", "-1"], "--density must be 0..7 (got -1)"),
    (["--size", "10000"], "one map without --layout needs --density (0..7)"),
    (["--density", "3"], "one map without --layout needs --size (5000 or 10000)"),
    ([], "one map without --layout needs --size (5000 or 10000) and --density (0..7)"),
])
def test_cli_one_map_names_the_wrong_or_missing_option(
    args: list[str], line: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A value given is judged before what is missing: one line naming the option and the
    value, exit 2, nothing written."""
    from lamde_mission.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["generate", "x.json", *args]) == 2
    assert capsys.readouterr().err.splitlines() == [f"lamde-mission generate: {line}"]
    assert not list(tmp_path.iterdir())


def test_examples_load() -> None:
    demo = load_map(MAPS / "small-demo.json")
    assert demo.width <= 3000 and 2 <= len(demo.sensors) <= 8
    p = Problem(demo)
    assert _witness(p, json.loads((MAPS / "small-demo.json").read_text()))["phi"] == 0.0
    assert p.breakdown(p.encode(np.zeros((0, 2)), []))["l_vio"] > 0  # the straight line is blocked
    tiny = json.loads((MAPS / "tiny.json").read_text())
    assert set(tiny) == {"origin", "area", "start", "end", "sensors", "obstacles"}
    t = load_map(tiny)
    n_obstacles = sum(len(v) for v in tiny["obstacles"].values())
    assert n_obstacles == 1 and len(t.sensors) >= 1
    # the one circle (500, 500) r 60 is what the loaded map blocks: inside it, not just outside
    probe = np.array([[500.0, 500.0], [500.0, 559.0], [500.0, 561.0], [50.0, 50.0]])
    assert points_inside(probe, t.obstacles).tolist() == [True, True, False, False]


def test_generate_suite_writes_each_map_whole_or_not_at_all(tmp_path: Path, monkeypatch) -> None:
    """A write that fails before its rename (a killed run) leaves the old map, not half of
    the new one, and no temporary file."""
    import os

    import planner_core.suite as suite

    monkeypatch.setattr(suite, "suite_maps", lambda seed: {"T01": {"name": "new"}})
    assert suite.generate_suite(tmp_path) == [tmp_path / "T01.json"]
    assert json.loads((tmp_path / "T01.json").read_text()) == {"name": "new"}
    (tmp_path / "T01.json").write_text("old\n")

    def killed(fd: int) -> None:
        raise OSError("killed")

    monkeypatch.setattr(os, "fsync", killed)
    with pytest.raises(OSError, match="killed"):
        suite.generate_suite(tmp_path)
    assert [p.name for p in tmp_path.iterdir()] == ["T01.json"]
    assert (tmp_path / "T01.json").read_text() == "old\n"
