"""Sortie directories made by hand for the fleet tests (upload --fleet, show DIR/): each sortie
a complete mission written by the existing writer (`formats.write_mission`) for a hand-made
route, and a fleet.json as `plan -o DIR/` writes it (no tests here, so not named test_*)."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from lamde_mission.formats import write_mission
from lamde_mission.formats.fleet import sortie_file_name
from lamde_mission.items import plan_to_items
from planner_core.model.mapio import load_map
from planner_core.model.pads import pad_ranks
from sim import replay

ROOT = Path(__file__).resolve().parents[1]
DEMO_MAP = ROOT / "examples" / "maps" / "small-demo.json"
FLEET_DEMO = ROOT / "examples" / "maps" / "fleet-demo.json"


def write_fleet_dir(
    directory: Path,
    routes: list[list[list[str]]],
    *,
    map_path: Path = DEMO_MAP,
    depots: dict[str, tuple[float, float]] | None = None,
    sortie_depots: list[list[tuple[str, str]]] | None = None,
    own_pads: bool = True,
) -> Path:
    """Write DIR/mission-v{k}-s{j}.plan and DIR/fleet.json for hand-made routes.

    Args:
        directory: where (created).
        routes: routes[k][j] = the sensor ids vehicle k + 1 hovers over (at each sensor) on
            sortie j + 1.
        map_path: the map.
        depots: name -> (x, y) m; default {"home": the map's start}.
        sortie_depots: (take-off depot, landing depot) per sortie; default the first depot.
        own_pads: False: every vehicle takes off from and lands at the depot's point itself,
            as a directory planned before each vehicle had its own pad.

    Each vehicle takes off from and lands at its own pad at a depot of the map's (as `plan`
    writes it: `Map.pads_for`, the vehicles using a depot in the order of their numbers,
    `pad_ranks`); a depot the map does not have is flown from its given point.

    Returns:
        The directory.
    """
    directory.mkdir(parents=True, exist_ok=True)
    doc = json.loads(Path(map_path).read_text())
    depots = depots or {"home": tuple(doc["start"])}
    first = next(iter(depots))
    by_id = {s["id"]: s for s in doc["sensors"]}
    whole = load_map(doc)
    names, _, _ = whole.sortie_sites
    pads = whole.pads_for(max(len(routes), int(whole.uavs)))
    ends = [sortie_depots[k][j] if sortie_depots else (first, first)
            for k, sorties in enumerate(routes) for j in range(len(sorties))]
    who = [k for k, sorties in enumerate(routes) for _ in sorties]
    rank = pad_ranks((k, d) for k, ab in zip(who, ends, strict=True) for d in ab)

    def at(k: int, name: str) -> list[float]:
        if name not in names:
            return list(depots[name])
        if not own_pads:
            return pads[0, names.index(name)].tolist()
        return pads[rank[(k, name)], names.index(name)].tolist()

    vehicles = []
    for k, sorties in enumerate(routes):
        out = []
        for j, ids in enumerate(sorties):
            a, b = sortie_depots[k][j] if sortie_depots else (first, first)
            sub = dict(doc, sensors=[by_id[i] for i in ids], start=at(k, a), end=at(k, b))
            sub.pop("witness", None)
            m = load_map(sub)
            plan = SimpleNamespace(
                hover_points=[[by_id[i]["x"], by_id[i]["y"]] for i in ids],
                hover_times=[1.0] * len(ids),
            )
            name = sortie_file_name(k + 1, j + 1)
            write_mission(directory / name, plan, m)
            t = replay(plan_to_items(plan, m), m).totals
            out.append(
                {
                    "sortie": j + 1,
                    "file": name,
                    "depot_start": a,
                    "depot_end": b,
                    "duration_s": t.t_total,
                    "energy_wh": None,  # as plan writes it for a map without a battery
                    "sensors": list(ids),
                }
            )
        vehicles.append(
            {"vehicle": k + 1, "sorties": out, "makespan_s": sum(s["duration_s"] for s in out)}
        )
    summary: dict[str, Any] = {
        "map": doc["name"],
        "objective": "makespan",
        "vehicles": vehicles,
        "total_s": sum(v["makespan_s"] for v in vehicles),
        "swaps": sum(max(len(v["sorties"]) - 1, 0) for v in vehicles),
    }
    (directory / "fleet.json").write_text(json.dumps(summary, indent=2))
    return directory


def plan_fleet_demo(directory: Path, uavs: int = 2, endurance_s: float | None = None
                    ) -> tuple[Path, Path]:
    """examples/maps/fleet-demo.json flown by `uavs` UAVs (and a battery of `endurance_s` s,
    if given), planned by `plan -o DIR/` at a small budget into `directory`.

    Returns:
        (the map's path, the sortie directory).
    """
    from lamde_mission.cli import main

    d = json.loads((ROOT / "examples" / "maps" / "fleet-demo.json").read_text())
    d["fleet"]["uavs"] = uavs
    if endurance_s is not None:
        d["uav"]["endurance_s"] = endurance_s
    path = directory / f"fleet-demo-{uavs}.json"
    path.write_text(json.dumps(d))
    out = directory / "sorties"
    assert main(["plan", str(path), "-o", str(out), "--budget", "300", "--population", "20",
                 "--sortie-budget", "150", "--rounds", "1", "--quiet"]) == 0  # fmt: skip
    return path, out


def fleet_demo_map(tmp: Path, uavs: int, name: str | None = None) -> Path:
    """A copy of the fleet demo map with `uavs` vehicles (and another name, if given)."""
    doc = json.loads(FLEET_DEMO.read_text())
    doc["fleet"]["uavs"] = uavs
    if name is not None:
        doc["name"] = name
    path = tmp / f"fleet-demo-{uavs}{'-' + name if name else ''}.json"
    path.write_text(json.dumps(doc))
    return path


def quick_fleet_plan(map_path: Path, goal: str | None = None):
    """A quick real fleet plan of the map (one tour, split by the battery, LP hover times; no
    pipeline run): (the map, the `planner_core.fleet.FleetPlan`), for `write_sortie_dir`."""
    import numpy as np

    from planner_core.fleet import FleetSettings, Links, fleet_hover_lp, split_vehicles
    from planner_core.model.problem import Problem

    m = load_map(map_path)
    pm = m.planning_map()
    problem = Problem(pm)
    st = FleetSettings.from_map(m, goal)
    links = Links(problem)
    P, T = links.join(pm.sensors, np.full(len(pm.sensors), 25.0))
    plan = fleet_hover_lp(split_vehicles(st, links, P, T), problem.model)
    assert plan is not None and plan.chained()
    return m, plan
