"""Plan a 3-UAV mission, upload each vehicle's first sortie to three mock vehicles, read back.

No simulator or drone needed: three mock autopilots (system ids 1, 2, 3) run in a background
thread on 127.0.0.1, on one link (told apart by system id, as a multi-vehicle radio or a MAVLink
router delivers them) or with --ports on one link each.

    python examples/fleet_to_mock.py                       # pymavlink, one link for all
    python examples/fleet_to_mock.py --via mavsdk --ports  # MAVSDK, one link per vehicle

Steps: load examples/maps/L01-25min.json (80 sensors on 14 km, a 25-min battery, six depots)
with its fleet set to 3 UAVs (objective: makespan), plan the sorties (`lamde_mission.plan_fleet`,
a short run: about 5 s), write the sortie directory
(`lamde_mission.sorties.write_sortie_dir`: mission-v{k}-s{j}.plan and fleet.json, every sortie
replayed by the simulator), start the mock vehicles, upload each vehicle's first sortie by
system id (`upload_fleet`), and check that every mock vehicle holds exactly the mission of its
file. (On examples/maps/fleet-demo.json, 4 sensors on 2 km, three UAVs would hear the same
sensors and wait for each other to launch: the makespan goal flies two there, docs/sorties.md.)
The same from a shell:

    lamde-mission plan MAP -o sorties/                 # a map with "fleet": {"uavs": 3, ...}
    lamde-mission mock-vehicle --vehicles 3 --param MPC_XY_VEL_MAX=20 &   # systems 1, 2, 3
    lamde-mission upload sorties/ --fleet              # listens on 0.0.0.0:14540

The mocks answer MPC_XY_VEL_MAX 20 m/s, the speed the sorties were planned at: at PX4's default
of 12 m/s (the mock's default too) both `upload --fleet` and `upload_fleet` refuse sorties
planned with a battery, nothing sent (their energy at 12 m/s is unchecked; `--map MAP`, or
`speeds.fleet_speed_check(missions, map=m)`, judges them at the limit).
"""

from __future__ import annotations

import argparse
import json
import socket
import sys
import tempfile
from pathlib import Path

import lamde_mission
from lamde_mission.items import MISSION_TYPE
from lamde_mission.sorties import write_sortie_dir
from lamde_mission.vehicle.fleet import first_sortie_missions, upload_fleet
from lamde_mission.vehicle.mock_fleet import MockFleet
from lamde_mission.vehicle.wire import compare_items, wire_mission
from planner_core.model.mapio import load_map

ROOT = Path(__file__).resolve().parent
MAP = ROOT / "maps" / "L01-25min.json"
UAVS = 3
#: m/s, the mocks' MPC_XY_VEL_MAX: the map's uav.max_speed, the speed the sorties ask
SPEED_LIMIT = 20.0


def free_udp_ports(n: int) -> list[int]:
    """n free UDP ports on 127.0.0.1 (so a `lamde-mission mock-vehicle` elsewhere is no bother)."""
    socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(n)]
    try:
        for s in socks:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--via", choices=("mavsdk", "pymavlink"), default="pymavlink")
    ap.add_argument("--ports", action="store_true", help="one link per vehicle")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--budget", type=int, default=2000, help="evaluations of the single flight")
    args = ap.parse_args()

    doc = json.loads(MAP.read_text(encoding="utf-8"))
    doc["fleet"]["uavs"] = UAVS
    doc.setdefault("objective", {})["goal"] = "makespan"
    m = load_map(doc)
    print(f"planning '{m.name}' for {UAVS} UAVs (objective makespan, seed {args.seed}) ...")
    result = lamde_mission.plan_fleet(m, seed=args.seed, budget=args.budget, goal="makespan",
                                      sortie_budget=500, rounds=1)
    plan = result.plan

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "sorties"
        check, written = write_sortie_dir(plan, m, out)  # objective: the plan's
        if not written:
            print("the sorties are infeasible: " + "; ".join(check.failed()), file=sys.stderr)
            return 1
        summary = json.loads((out / "fleet.json").read_text(encoding="utf-8"))
        for v in summary["vehicles"]:
            files = ", ".join(s["file"] for s in v["sorties"]) or "no sortie"
            print(f"  vehicle {v['vehicle']}: {files}; makespan {v['makespan_s']:.1f} s")
        missions = first_sortie_missions(out)

        ports = free_udp_ports(UAVS if args.ports else 1)
        mock_side = [f"udpout:127.0.0.1:{p}" for p in ports]
        ground_side = [f"udpin://127.0.0.1:{p}" for p in ports]
        with MockFleet(mock_side if args.ports else mock_side[0], vehicles=UAVS,
                       params={"MPC_XY_VEL_MAX": SPEED_LIMIT}) as fleet:
            report = upload_fleet(missions, connect=ground_side, via=args.via, timeout=20)
            print("\n".join(report.lines()))
            for fm, r in zip(missions, report.results, strict=True):
                if not fm.mission:
                    continue
                held = fleet.vehicle(r.system_id).wire_items()
                sent = wire_mission(fm.mission, MISSION_TYPE.MISSION)
                same = not compare_items(sent, held)
                print(
                    f"mock system {r.system_id} holds {len(held)} mission items: "
                    f"{'equal to' if same else 'DIFFERENT from'} {fm.source}"
                )
                if not same:
                    return 1
    return 0 if report.ok else 1


if __name__ == "__main__":
    sys.exit(main())
