"""Issue 33: the sortie planner against route first, cluster second, on large maps with a
battery, and what three UAVs save (docs/sorties.md, "Measured").

Each large map (examples/maps/large/) gets a battery of `--endurance` hover seconds (default
1,500 s: a 25-min battery, 20 % reserve) and depots: its start ("home"), its end ("end") and a
grid of about one depot per `--spacing` metres square (default 7 km; a grid point inside an
obstacle is moved east until it is clear), swaps of 300 s (`battery_map`). Per map and seed:

* one UAV, objective total: `planner_core.fleet.plan_fleet` (ours) and the route-first peer
  it computes from the same single flight (`FleetResult.peer`, `planner_core.fleet.route_first`),
  paired;
* three UAVs, objective makespan: ours; its makespan over the one-UAV plan's total time.

Every plan is written as a sortie directory (`lamde_mission.sorties.write_sortie_dir`) and
replayed by the simulator: the records keep its verdict, total and makespan (the sim's clock
on the stored missions). `--summary` prints the table of docs/sorties.md from the records,
with a one-sided Wilcoxon signed-rank test (scipy) of ours < peer per map.

    nice python benchmarks/bench_fleet.py --maps L01,L04,L07,L02 --seeds 0-4 \\
        --out runs/fleet.jsonl --dirs runs/fleet-dirs
    python benchmarks/bench_fleet.py --summary docs/sorties-runs/bench-25min.jsonl.gz

Cost: per run the single flight's pipeline (seconds to a minute on 80-160 sensors), the sortie
planner's D + rounds x S pipeline runs on a sortie's sensors, and the LPs across sorties.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def battery_map(src: Path, endurance: float = 1500.0, spacing: float = 7000.0,
                uavs: int = 1) -> dict[str, Any]:
    """The map at `src` with a battery of `endurance` hover seconds (reserve 20 %), depots at
    its start, its end and a grid of spacing ~`spacing` m, swap 300 s, `uavs` UAVs."""
    from planner_core.model.geometry import points_inside
    from planner_core.model.mapio import load_map

    d = json.loads(Path(src).read_text())
    d.pop("witness", None)
    m = load_map(d)
    W, H = m.width, m.height
    nx, ny = max(1, round(W / spacing)), max(1, round(H / spacing))
    pts = [("home", list(m.start)), ("end", list(m.end))]
    pts += [(f"d{i}{j}", [W * (i + 0.5) / nx, H * (j + 0.5) / ny])
            for i in range(nx) for j in range(ny)]  # fmt: skip
    depots = []
    for name, (x, y) in pts:
        p = np.array([[x, y]], dtype=float)
        for _ in range(50):
            if not points_inside(p, m.obstacles).any():
                break
            p = p + np.array([[150.0, 0.0]])
        depots.append({"name": name, "x": round(float(p[0, 0]), 1),
                       "y": round(float(p[0, 1]), 1)})  # fmt: skip
    d["uav"] = dict(d.get("uav", {}))
    d["uav"]["endurance_s"] = float(endurance)
    d["fleet"] = {"uavs": int(uavs), "depots": depots, "swap_s": 300.0}
    d["name"] = f"{d.get('name', 'map')}-{int(endurance / 60)}min"
    return d


def _seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def run(maps: list[str], seeds: list[int], out: Path, dirs: Path, endurance: float) -> None:
    """The runs of the module docstring, one JSON line each, appended to `out`."""
    from lamde_mission.sorties import write_sortie_dir
    from planner_core.fleet import plan_fleet
    from planner_core.model.mapio import load_map
    from planner_core.pipeline import PlanConfig
    from planner_core.pipeline.warmup import warm_up

    warm_up("adaptive")
    with open(out, "a", encoding="utf-8") as fh:
        for seed in seeds:
            for name in maps:
                for uavs, goal in ((1, "total"), (3, "makespan")):
                    m = load_map(battery_map(ROOT / "examples/maps/large" / f"{name}.json",
                                             endurance, uavs=uavs))  # fmt: skip
                    t = time.perf_counter()
                    r = plan_fleet(m, PlanConfig(seed=seed), goal=goal)
                    rec: dict[str, Any] = {"map": name, "seed": seed, "uavs": uavs, "goal": goal,
                                           "wall_s": time.perf_counter() - t}
                    for tag, p in (("ours", r.plan), ("peer", r.peer)):
                        chk, _ = write_sortie_dir(p, m, dirs / f"{name}-s{seed}-u{uavs}-{tag}",
                                                  goal=goal)  # fmt: skip
                        rec[tag] = {
                            "total": p.total, "total_time": p.total_time,
                            "makespan": p.makespan, "sorties": len(p.sorties),
                            "swaps": p.swaps, "energy_ok": p.energy_ok(),
                            "evaluations": p.evaluations, "chained": p.chained(),
                            "sim_passed": chk.passed, "sim_total_s": chk.total_s,
                            "sim_makespan_s": chk.fleet_makespan[0],
                            "max_energy_frac": max(s.verdicts.energy_wh / s.verdicts.usable_wh
                                                   for s in chk.sorties),
                        }  # fmt: skip
                    rec["notes"] = list(r.plan.notes)
                    fh.write(json.dumps(rec) + "\n")
                    fh.flush()
                    print(name, seed, uavs, f"{rec['wall_s']:.1f} s", flush=True)


def summary(path: Path) -> str:
    """The docs table from the records at `path` (module docstring)."""
    from scipy.stats import wilcoxon

    from planner_core.textio import read_jsonl

    recs, seen = [], set()
    for r in read_jsonl(path):  # one record per map, seed and fleet (the first kept)
        if (r["map"], r["seed"], r["uavs"]) not in seen:
            seen.add((r["map"], r["seed"], r["uavs"]))
            recs.append(r)
    one = [r for r in recs if r["uavs"] == 1]
    three = {(r["map"], r["seed"]): r for r in recs if r["uavs"] == 3}
    lines = ["| map | runs | ours total (s) | route-first total (s) | ours vs route-first | "
             "Wilcoxon p (ours < peer) | objective (sum f + swaps) | sorties ours / peer | "
             "3-UAV makespan / 1-UAV total | sim verdicts |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name in sorted({r["map"] for r in one}):
        rs = sorted((r for r in one if r["map"] == name), key=lambda r: r["seed"])
        a = np.array([r["ours"]["sim_total_s"] for r in rs])
        b = np.array([r["peer"]["sim_total_s"] for r in rs])
        diff = a - b
        p = wilcoxon(a, b, alternative="less").pvalue if np.any(diff != 0) else float("nan")
        ratios = [three[(name, r["seed"])]["ours"]["sim_makespan_s"] / r["ours"]["sim_total_s"]
                  for r in rs if (name, r["seed"]) in three]
        ok = sum(r["ours"]["sim_passed"] and r["peer"]["sim_passed"] for r in rs)
        ok3 = sum(three[(name, r["seed"])]["ours"]["sim_passed"] for r in rs
                  if (name, r["seed"]) in three)
        rt = (f"{np.mean(ratios):.3f} (max {np.max(ratios):.3f}, {len(ratios)} runs)" if ratios
              else "-")
        rel = 100 * (a / b - 1)
        fo = np.array([r["ours"]["total"] / r["peer"]["total"] - 1 for r in rs]) * 100
        so = np.mean([r["ours"]["sorties"] for r in rs])
        sp = np.mean([r["peer"]["sorties"] for r in rs])
        lines.append(f"| {name} | {len(rs)} | {a.mean():.0f} | {b.mean():.0f} | "
                     f"{100 * (a.mean() / b.mean() - 1):+.2f} % (per run {rel.min():+.2f} to "
                     f"{rel.max():+.2f} %) | {p:.3g} | {fo.mean():+.2f} % | {so:.1f} / {sp:.1f} | "
                     f"{rt} | "
                     f"{ok}/{len(rs)} pairs, {ok3}/{len(ratios)} 3-UAV |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="L01,L04,L07,L02")
    ap.add_argument("--seeds", default="0-4")
    ap.add_argument("--endurance", type=float, default=1500.0)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--dirs", type=Path)
    ap.add_argument("--summary", type=Path, metavar="JSONL")
    a = ap.parse_args()
    if a.summary:
        print(summary(a.summary))
        return
    if a.out is None or a.dirs is None:
        ap.error("--out and --dirs are required to run (or --summary JSONL)")
    a.dirs.mkdir(parents=True, exist_ok=True)
    run(a.maps.split(","), _seeds(a.seeds), a.out, a.dirs, a.endurance)


if __name__ == "__main__":
    main()
