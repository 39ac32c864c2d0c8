"""Plan a mission, fly it to a mock autopilot over MAVLink, and check it came back identical.

No simulator or drone needed: the mock vehicle runs in a background thread on 127.0.0.1.

    python examples/upload_to_mock.py                   # MAVSDK, then our pymavlink client
    python examples/upload_to_mock.py --via pymavlink --loss 0.2

Steps: plan examples/maps/small-demo.json (a short DE run), write it as a QGroundControl .plan
(mission + exclusion geofence), read the file back, start `MockVehicle`, upload the mission and
the fence, download both and compare item by item. Before sending, `upload_mission` reads the
vehicle's speed limit: the mock says PX4's default MPC_XY_VEL_MAX, 12 m/s, below the plan's
20 m/s, and the check given here (`speeds.mission_speed_check` on the map) replays the mission
at 12 m/s and notes its longer flight (every check still holds: the map has no battery). The
same thing from a shell:

    lamde-mission plan examples/maps/small-demo.json -o mission.plan
    lamde-mission mock-vehicle &              # sends to 127.0.0.1:14540
    lamde-mission upload mission.plan --map examples/maps/small-demo.json   # on 0.0.0.0:14540
"""

from __future__ import annotations

import argparse
import socket
import sys
import tempfile
from pathlib import Path

import lamde_mission
from lamde_mission.formats import read_mission, write_mission
from lamde_mission.vehicle import MockVehicle, VehicleError, upload_mission
from lamde_mission.vehicle.speeds import mission_speed_check
from planner_core.model.mapio import load_map

ROOT = Path(__file__).resolve().parent
DEMO = ROOT / "maps" / "small-demo.json"
FALLBACK = {  # used if the demo map is missing
    "name": "fallback-demo",
    "area": {"width": 1500, "height": 1000},
    "start": [50, 50],
    "end": [1450, 950],
    "sensors": [{"id": "a", "x": 400, "y": 300}, {"id": "b", "x": 1100, "y": 700}],
    "obstacles": {"circles": [{"x": 750, "y": 500, "radius": 60}]},
}


def free_udp_port() -> int:
    """A free UDP port on 127.0.0.1 (so a `lamde-mission mock-vehicle` elsewhere is no bother)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--via", choices=("mavsdk", "pymavlink", "both"), default="both")
    ap.add_argument("--loss", type=float, default=0.0, help="fraction of the mock's messages lost")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    source = DEMO if DEMO.exists() else FALLBACK
    m = load_map(source)
    print(f"planning '{m.name}' ...")
    plan = lamde_mission.plan(source, seed=args.seed, budget=2000, population=40)
    print(f"  {plan.n_hover} hover points, f = {plan.f:.1f}, feasible: {plan.feasible}")

    with tempfile.TemporaryDirectory() as tmp:
        path = write_mission(Path(tmp) / "mission.plan", plan, m)
        mission, fence = read_mission(path)
        print(f"wrote {path.name}: {len(mission)} mission items, {len(fence)} fence items")

        vias = ("mavsdk", "pymavlink") if args.via == "both" else (args.via,)
        for via in vias:
            port = free_udp_port()
            print(f"\n{via}:")
            with MockVehicle(f"udpout:127.0.0.1:{port}", loss=args.loss, seed=args.seed) as v:
                try:
                    # judged on the map at the vehicle's limit, as `upload --map` does (the
                    # default check, without the map, would warn that 12 m/s is below 20)
                    check = mission_speed_check(mission, source=path, map=m,
                                                note=lambda line: print(f"  note: {line}"))
                    report = upload_mission(mission, fence, connect=f"udpin://127.0.0.1:{port}",
                                            via=via, timeout=20, attempts=5,
                                            speed_check=check)  # fmt: skip
                except VehicleError as exc:
                    print(f"{via}: FAILED: {exc}", file=sys.stderr)
                    return 1
                for line in report.lines():
                    print(f"  {line}")
                kept = v.items()
                print(f"  the mock vehicle holds {len(kept)} mission items; first: "
                      f"command {kept[0].command} at ({kept[0].x:.7f}, {kept[0].y:.7f}), "
                      f"{kept[0].z:g} m")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
