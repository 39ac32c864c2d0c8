"""`check` scores the map's stored witness plan on the map as it is now: a map edited after it
was generated kept saying "a known feasible plan is stored" though the plan no longer served
its sensors (phi 2e+06 on small-demo with two sensors asking 1e6 Mbit)."""

from __future__ import annotations

import json

import numpy as np

from lamde_mission.fuzz import run_cli as run_here
from planner_core.model.mapio import load_map
from planner_core.model.problem import Problem
from planner_core.suite import witness_score
from tests.conftest import MAPS


def _witness_line(stdout: str) -> str:
    (line,) = [ln for ln in stdout.splitlines() if ln.strip().startswith("witness")]
    return line.split("witness", 1)[1].strip()


def test_a_witness_that_serves_the_map_is_said_feasible_with_its_f(tmp_path) -> None:
    m = load_map(MAPS / "small-demo.json")
    w = m.spec.witness
    problem = Problem(m)  # by hand: the planner's own scoring of the stored plan
    f, phi = problem.evaluate(problem.encode(np.array(w.hover_points, float),
                                             np.array(w.hover_times, float))[None, :])
    assert phi[0] == 0.0 and witness_score(m) == (float(f[0]), 0.0)
    r = run_here(["check", str(MAPS / "small-demo.json")])
    assert r.status == 0
    assert _witness_line(r.stdout) == (f"a stored plan feasible on this map (f {f[0]:.6g}): a "
                                       "plan exists")
    r = run_here(["check", str(MAPS / "small-demo.json"), "--json"])
    assert json.loads(r.stdout)["witness"] == {"f": float(f[0]), "phi": 0.0, "feasible": True}


def test_a_witness_the_map_was_edited_away_from_is_said_infeasible(tmp_path) -> None:
    d = json.loads((MAPS / "small-demo.json").read_text())
    d["sensors"][0]["required_data"] = 600.0  # 3 x Q_lambda: the stored hover times fall short
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(d))
    f, phi = witness_score(load_map(path))
    assert phi > 0.0
    r = run_here(["check", str(path)])
    assert r.status == 0, r.stdout  # still solvable: more hover time serves S1
    assert _witness_line(r.stdout) == (
        f"a stored plan NOT feasible on this map as it is now (phi {phi:.4g}; edited since it "
        "was stored?): it proves nothing, and nothing plans from it")
    r = run_here(["check", str(path), "--json"])
    assert json.loads(r.stdout)["witness"] == {"f": f, "phi": phi, "feasible": False}


def test_a_map_without_a_witness_prints_no_witness_line() -> None:
    r = run_here(["check", str(MAPS / "tiny.json")])
    assert r.status == 0 and not any(ln.strip().startswith("witness")
                                     for ln in r.stdout.splitlines())
    assert "witness" not in json.loads(run_here(["check", str(MAPS / "tiny.json"),
                                                 "--json"]).stdout)


def test_on_a_battery_map_the_witness_proves_nothing_about_sorties(tmp_path) -> None:
    """A reviewer: on a 3-UAV battery map check said "a stored plan feasible on this map ...:
    a plan exists" beside "valid, but no plan can meet it" and 30 CANNOT lines; the witness is
    a single flight, scored without the battery."""
    d = json.loads((MAPS / "small-demo.json").read_text())
    d["uav"] = {**d.get("uav", {}), "endurance_s": 60.0}  # far too short for any sortie
    path = tmp_path / "battery.json"
    path.write_text(json.dumps(d))
    f, phi = witness_score(load_map(path))
    assert phi == 0.0
    r = run_here(["check", str(path)])
    assert r.status == 1  # CANNOT: the battery
    assert _witness_line(r.stdout) == (f"a stored single flight feasible on this map (f "
                                       f"{f:.6g}), battery left aside: it proves nothing about "
                                       "sorties")


def test_check_says_a_map_with_obstacles_and_no_clearance_has_none() -> None:
    """A reviewer flew nothing but read `safety clearance 0 m` on a battery map the docs point
    to, unremarked: check says that legs may then touch the obstacles' edges and names the
    field; a map with a clearance, or with no obstacles, prints the plain line."""
    def safety(path: str) -> str:
        r = run_here(["check", path])
        (line,) = [ln for ln in r.stdout.splitlines() if ln.strip().startswith("safety")]
        return line.split("safety", 1)[1].strip()

    assert safety(str(MAPS / "L01-25min.json")) == (
        "clearance 0 m (none: legs may touch the obstacles' edges; a field mission wants a "
        "few metres: safety.clearance), data margin 0 %")
    assert safety(str(MAPS / "small-demo.json")) == "clearance 10 m, data margin 2 %"
