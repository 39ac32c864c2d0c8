"""`lamde-mission verify MAP MISSION`: replay a mission file in the sim and judge C1..C5."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "verify",
        help="replay a mission file in the simulator and check constraints C1..C5",
        description="Fly a mission file (QGroundControl .plan, ArduPilot .waypoints, or a saved "
        "plan result .json) over MAP with the paper's model, independently of the optimiser, and "
        "print a verdict per constraint with its margin. Exit status: 0 all pass, 1 any fails, "
        "2 bad input.",
    )
    p.add_argument("map", help="map file (JSON)")
    from lamde_mission.commands._common import add_origin_option

    add_origin_option(p)
    p.add_argument("mission", help="mission file: .plan, .waypoints (or a plan result .json)")
    p.add_argument("--json", action="store_true", help="print verdicts and totals as JSON")
    return p


def replay_mission_file(path: str, m: Any) -> Any:
    """Read a mission file and replay it on map `m`; bad input becomes a UsageError."""
    from lamde_mission.errors import UsageError
    from lamde_mission.formats import MissionFileError, load_mission_items
    from lamde_mission.items import MissionError
    from sim import replay

    try:
        items, _fence = load_mission_items(path, m)
    except MissionFileError as exc:
        raise UsageError(str(exc)) from None
    try:
        timeline = replay(items, m)
    except MissionError as exc:
        raise UsageError(f"{path}: {exc}") from None
    for note in timeline.notes:
        print(f"note: {path}: {note}", file=sys.stderr)
    return timeline


def run(args: argparse.Namespace) -> int:
    from lamde_mission.commands._common import load_map_or_fail, with_origin_or_fail
    from sim import verify

    m = load_map_or_fail(args.map)
    m = with_origin_or_fail(m, args.origin)
    timeline = replay_mission_file(args.mission, m)
    verdicts = verify(timeline, m)
    t = timeline.totals
    if args.json:
        out = verdicts.to_dict()
        out["totals"] = {
            "t_fly": t.t_fly, "t_hover": t.t_hover, "f": t.f, "t_takeoff": t.t_takeoff,
            "t_land": t.t_land, "t_return": t.t_return, "t_total": t.t_total,
            "distance": t.distance, "collected": t.collected,
        }  # fmt: skip
        print(json.dumps(out, indent=2))
    else:
        print(f"mission {args.mission} on map '{m.name}': "
              f"{len(timeline.hover_times)} hover points")  # fmt: skip
        print(verdicts.table())
        sf = m.spec.safety
        margins = ", ".join(f"'{k}' {100 * v:+.3g} %" for k, v in verdicts.data_margins.items())
        print(f"safety: clearance {verdicts.clearance:.3f} m (asked {sf.clearance:g} m); data "
              f"margin per sensor (asked {100 * sf.data_margin:g} %): {margins}")
        print(f"f = {t.f:.6f}  (alpha {t.alpha:g}: t_fly {t.t_fly:.3f} s, "
              f"t_hover {t.t_hover:.3f} s)")  # fmt: skip
        print(f"mission time {t.t_total:.1f} s including take-off {t.t_takeoff:.1f} s, "
              f"landing {t.t_land:.1f} s" + (f", return {t.t_return:.1f} s" if t.t_return else "")
              + f"; distance {t.distance:.1f} m")  # fmt: skip
        print("result: " + ("all constraints hold" if verdicts.passed
                            else "FAILED " + ", ".join(verdicts.failed)))  # fmt: skip
    return 0 if verdicts.passed else 1
