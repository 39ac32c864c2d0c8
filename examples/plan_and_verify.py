"""Plan a mission from Python, write it for QGroundControl, and check it in the simulator.

    python examples/plan_and_verify.py [MAP] [OUT.plan]

The same steps `lamde-mission plan` takes, spelled out: map -> plan -> mission items -> file ->
independent replay of the file's items with a verdict per constraint. As `plan` does, it writes
no file for an infeasible plan (exit 1) and says in one line what is wrong with a bad map or
output name (exit 2); a map with a battery or fleet plans as sorties, not here (exit 2).
"""

from __future__ import annotations

import sys
from pathlib import Path

import lamde_mission
from lamde_mission.formats import MissionFileError, format_for, read_mission, write_mission
from planner_core import MapError, load_map
from sim import replay, verify

HERE = Path(__file__).resolve().parent


def main() -> int:
    map_path = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "maps" / "small-demo.json"
    out = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("example-mission.plan")
    try:
        m = load_map(map_path)
        format_for(out)  # .plan or .waypoints: known before planning
    except (MapError, MissionFileError) as exc:  # a bad map or output name: one line
        print(f"plan_and_verify: {exc}", file=sys.stderr)
        return 2
    if m.has_battery or m.has_fleet:  # one flight cannot say whether a battery flies it
        print(f"plan_and_verify: {map_path}: a map with a battery or fleet plans as sorties: "
              f"`lamde-mission plan {map_path} -o DIR/` or lamde_mission.plan_fleet "
              "(docs/sorties.md)", file=sys.stderr)  # fmt: skip
        return 2
    plan = lamde_mission.plan(m, seed=0, budget=10_000)
    print(f"{m.name}: {plan.n_hover} hover points, f = {plan.f:.2f}, phi = {plan.phi:g}, "
          f"{plan.wall_time:.2f} s")
    for (x, y), t in zip(plan.hover_points, plan.hover_times, strict=True):
        print(f"  hover at ({x:7.1f}, {y:7.1f}) m for {t:6.1f} s")
    if not plan.feasible:  # as `lamde-mission plan`: an infeasible mission is not written
        print(f"infeasible (phi = {plan.phi:g}): {out} not written; "
              f"`lamde-mission check {map_path}` says what no plan can meet")
        return 1
    write_mission(out, plan, m)
    items, fence = read_mission(out)  # replay what the file says, not the optimiser's arrays
    verdicts = verify(replay(items, m), m)
    print(f"wrote {out}: {len(items)} mission items, {len(fence)} fence items")
    print(verdicts.table())
    return 0 if verdicts.passed else 1


if __name__ == "__main__":
    sys.exit(main())
